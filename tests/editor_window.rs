//! Smoke test of the real editor window: `drape` opens on the default scene
//! under a virtual X display (Xvfb, installed by the test command),
//! simulates a second of the walk live, and writes the window's image to
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
        .args(["--screenshot-after", "30"])
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

/// A process killed when dropped (the test's Xvfb and editor).
struct Child(std::process::Child);

impl Drop for Child {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// CPU time the process `pid` has used so far, seconds (user + system, from
/// `/proc/PID/stat`).
fn cpu_time_s(pid: u32) -> f64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    // The fields after the command name, which is in parentheses.
    let fields: Vec<&str> = stat[stat.rfind(')').unwrap() + 2..].split_whitespace().collect();
    let ticks: f64 = fields[11].parse::<f64>().unwrap() + fields[12].parse::<f64>().unwrap();
    // SAFETY: sysconf only reads a system constant.
    ticks / unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64
}

/// A free X display number and its Xvfb, up once its socket exists.
fn virtual_display() -> (String, Child) {
    let number = (90..200).find(|n| !Path::new(&format!("/tmp/.X11-unix/X{n}")).exists()).unwrap();
    let display = format!(":{number}");
    let xvfb = Command::new("Xvfb")
        .args([display.as_str(), "-screen", "0", "1600x1000x24", "-nolisten", "tcp"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("Xvfb is missing: tools/test installs it (apt-get install xvfb)");
    let socket = format!("/tmp/.X11-unix/X{number}");
    for _ in 0..200 {
        if Path::new(&socket).exists() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    (display, Child(xvfb))
}

/// Idle (nothing simulating, playing or moving), the editor sleeps: under
/// 2 % of a core over 5 s once the window has settled.
#[test]
fn the_idle_editor_uses_under_two_percent_of_a_core() {
    let (display, _xvfb) = virtual_display();
    let editor = Command::new(env!("CARGO_BIN_EXE_drape"))
        .arg("edit")
        .env("DISPLAY", &display)
        .env_remove("WAYLAND_DISPLAY")
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let editor = Child(editor);
    let pid = editor.0.id();
    // Settled: the window is up and drawn when a whole second passes with
    // (almost) no CPU time; at most a minute.
    let second = std::time::Duration::from_secs(1);
    let mut before = cpu_time_s(pid);
    for _ in 0..60 {
        std::thread::sleep(second);
        let now = cpu_time_s(pid);
        let settled = now - before < 0.02 && now > 0.5;
        before = now;
        if settled {
            break;
        }
    }
    let start = (std::time::Instant::now(), cpu_time_s(pid));
    std::thread::sleep(5 * second);
    let used = cpu_time_s(pid) - start.1;
    let share = used / start.0.elapsed().as_secs_f64();
    assert!(share < 0.02, "the idle editor used {:.1} % of a core", 100.0 * share);
}
