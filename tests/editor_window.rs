//! Smoke test of the real editor window: `drape` opens on the default scene
//! under a virtual X display (Xvfb, installed by the test command),
//! simulates a few frames live, and writes the window's image to
//! `target/smoke/editor.png` (kept as a CI artifact).

use std::path::Path;
use std::process::Command;

/// Window size of the editor, logical pixels (scale 1 under Xvfb).
const WINDOW: (u32, u32) = (1440, 860);

#[test]
fn the_editor_window_opens_on_the_default_scene_and_simulates() {
    let shot = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/smoke/editor.png");
    std::fs::create_dir_all(shot.parent().unwrap()).unwrap();
    let _ = std::fs::remove_file(&shot);
    let output = Command::new("xvfb-run")
        .args(["-a", "-s", "-screen 0 1600x1000x24", env!("CARGO_BIN_EXE_drape"), "edit", "--screenshot"])
        .arg(&shot)
        .args(["--screenshot-after", "4"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("xvfb-run is missing: tools/test installs it (apt-get install xvfb)");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "the editor failed: {stderr}");
    let image = image::open(&shot).unwrap_or_else(|e| panic!("no screenshot at {}: {e}", shot.display())).to_rgba8();
    assert_eq!(image.dimensions(), WINDOW);
    // The viewport (right of the 340-point panel, below the toolbar) shows a
    // lit scene: many distinct shades, not a cleared background.
    let mut shades = std::collections::HashSet::new();
    for y in (60..WINDOW.1 - 60).step_by(4) {
        for x in (400..WINDOW.0 - 20).step_by(4) {
            let p = image.get_pixel(x, y);
            shades.insert([p[0] / 8, p[1] / 8, p[2] / 8]);
        }
    }
    assert!(shades.len() > 40, "the viewport looks empty: {} shades", shades.len());
    // The stats overlay reports the frames simulated live.
    let overlay_text_pixels = (8..110u32)
        .flat_map(|y| (350..800u32).map(move |x| (x, y)))
        .filter(|&(x, y)| image.get_pixel(x, y)[0] > 200)
        .count();
    assert!(overlay_text_pixels > 200, "no statistics overlay ({overlay_text_pixels} bright pixels)");
}
