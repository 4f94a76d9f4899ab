# Sourced by tools/test and tools/edit: installs, on Debian 12 as root, the
# system packages that drape's window, renderer and charts need, only those
# missing. Mesa's lavapipe is the software Vulkan driver used when the
# machine has no GPU; Xvfb is a virtual display; the X client libraries are
# what winit loads.
drape_packages=(
    mesa-vulkan-drivers libvulkan1
    xvfb xauth
    libx11-6 libx11-xcb1 libxcursor1 libxrandr2 libxi6 libxkbcommon-x11-0
    # The benchmark charts' text: plotters finds a sans-serif font through
    # fontconfig and draws it with FreeType (linked at build time).
    pkg-config libfontconfig1-dev libfreetype-dev fonts-dejavu-core
)
drape_missing=()
for p in "${drape_packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || drape_missing+=("$p")
done
if [ ${#drape_missing[@]} -gt 0 ]; then
    echo "installing ${drape_missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${drape_missing[@]}"
fi

# The Vulkan loader wants a private runtime folder; without one it only warns.
if [ -z "${XDG_RUNTIME_DIR:-}" ]; then
    XDG_RUNTIME_DIR="$(mktemp -d)"
    export XDG_RUNTIME_DIR
fi
