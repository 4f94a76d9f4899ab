# Sourced by tools/test: the independent readers the export tests read
# drape's files back with, installed once into target/readers (only what is
# missing): Pixar's usd-core and pygltflib in a Python venv, the Khronos glTF
# validator from npm. Exports DRAPE_READERS_PYTHON and
# DRAPE_GLTF_VALIDATOR_MODULES for tests/exports.rs, and DRAPE_REQUIRE_READERS
# so that a reader that is missing fails the tests instead of skipping them.
drape_readers="$PWD/target/readers"
if ! "$drape_readers/venv/bin/python" -c "import pxr.UsdValidation, pygltflib, numpy" 2>/dev/null; then
    echo "installing the export readers (usd-core, pygltflib) into $drape_readers/venv"
    python3 -m venv "$drape_readers/venv" || {
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv
        python3 -m venv "$drape_readers/venv"
    }
    "$drape_readers/venv/bin/pip" install -q --disable-pip-version-check \
        usd-core==26.11 pygltflib==1.16.5 numpy==2.4.6
fi
if [ ! -f "$drape_readers/node/node_modules/gltf-validator/package.json" ]; then
    command -v npm >/dev/null || {
        apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm
    }
    echo "installing the Khronos glTF validator into $drape_readers/node"
    npm install --silent --no-audit --no-fund --prefix "$drape_readers/node" gltf-validator@2.0.0-dev.3.10
fi
export DRAPE_READERS_PYTHON="$drape_readers/venv/bin/python"
export DRAPE_GLTF_VALIDATOR_MODULES="$drape_readers/node/node_modules"
export DRAPE_REQUIRE_READERS=1
