//! Variant sweeps on a farm: keys, local and Slurm runs giving the same bytes
//! as `drape bake`, a requeued task resumed to the same bytes, and the
//! collected table and contact sheet.
//!
//! The Slurm test brings up a real single-node Slurm with `tools/slurm-local`
//! (Debian, as root; elsewhere it says why it is skipped) and stops it by PID.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

use drape::farm::layout::{read_manifest, write_sweep};
use drape::farm::sweep::Sweep;

fn drape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().expect("the drape binary runs")
}

fn ok(output: Output) -> String {
    let text = format!("{}{}", String::from_utf8_lossy(&output.stdout), String::from_utf8_lossy(&output.stderr));
    assert!(output.status.success(), "drape failed: {text}");
    text
}

/// A small cloth on a sphere read from an OBJ (an asset whose bytes count),
/// and a sweep of two presets × `frictions` over `frames` frames.
fn small_sweep(dir: &Path, frictions: &[f64], frames: usize) -> PathBuf {
    let grid = drape::mesh::generate::grid(0.4, 16);
    let mut obj = String::new();
    for p in &grid.positions {
        obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in &grid.triangles {
        obj += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    std::fs::write(dir.join("cloth.obj"), obj).unwrap();
    std::fs::write(
        dir.join("base.toml"),
        "description = \"test\"\n[time]\nfps = 30.0\nduration_s = 1.0\n[solver]\nsteps_per_frame = 2\n\
         [[garment]]\nname = \"cloth\"\npreset = \"cotton\"\nmesh = { obj = \"cloth.obj\" }\ntranslation_m = [0.0, 0.5, 0.0]\n\
         [[collider]]\nname = \"ball\"\nshape = { sphere = { radius_m = 0.15 } }\nposition_m = [0.0, 0.3, 0.0]\n",
    )
    .unwrap();
    let values: Vec<String> = frictions.iter().map(|f| format!("{f:?}")).collect();
    let sweep = format!(
        "base = \"base.toml\"\nframes = {frames}\n[[axis]]\nkey = \"garment.0.preset\"\nvalues = [\"cotton\", \"silk\"]\n\
         [[axis]]\nkey = \"garment.0.fabric.friction\"\nvalues = [{}]\n[slurm]\ncpus_per_task = 1\n",
        values.join(", ")
    );
    let path = dir.join("sweep.toml");
    std::fs::write(&path, sweep).unwrap();
    path
}

fn keys(sweep: &Path, out: &Path) -> Vec<String> {
    let entries = write_sweep(&Sweep::load(sweep).unwrap(), out).unwrap_or_else(|e| panic!("{e}"));
    entries.into_iter().map(|e| e.key).collect()
}

#[test]
fn keys_change_when_an_assets_bytes_change_and_only_then() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = small_sweep(dir.path(), &[0.2, 0.8], 10);
    let out = dir.path().join("out");
    let first = keys(&sweep, &out);
    assert_eq!(first.len(), 4);
    assert_eq!(first.iter().collect::<std::collections::HashSet<_>>().len(), 4, "every variant its own key");
    // The same files elsewhere: the same keys (paths in the key are as written).
    let moved = dir.path().join("moved");
    std::fs::create_dir(&moved).unwrap();
    for name in ["cloth.obj", "base.toml", "sweep.toml"] {
        std::fs::copy(dir.path().join(name), moved.join(name)).unwrap();
    }
    assert_eq!(keys(&moved.join("sweep.toml"), &moved.join("out")), first, "same sweep, same keys, anywhere");
    // The same bytes written again: the same keys; a comment in the base scene: the same.
    let obj = std::fs::read(dir.path().join("cloth.obj")).unwrap();
    std::fs::write(dir.path().join("cloth.obj"), &obj).unwrap();
    let base = std::fs::read_to_string(dir.path().join("base.toml")).unwrap();
    std::fs::write(dir.path().join("base.toml"), format!("# a comment\n{base}")).unwrap();
    assert_eq!(keys(&sweep, &out), first);
    // The OBJ's bytes changed (a comment, the same cloth): every key changes.
    let changed = [obj.as_slice(), b"# edited\n"].concat();
    std::fs::write(dir.path().join("cloth.obj"), changed).unwrap();
    let second = keys(&sweep, &out);
    assert!(first.iter().zip(&second).all(|(a, b)| a != b), "the asset's bytes are in every key");
}

/// Waits up to `limit` for `done`.
fn wait_for(what: &str, limit: Duration, done: impl Fn() -> bool) {
    let deadline = Instant::now() + limit;
    while !done() {
        assert!(Instant::now() < deadline, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(250));
    }
}

/// The variant's PC2 next to a `drape bake` of its resolved scene.
fn assert_same_as_a_plain_bake(out: &Path, index: usize) {
    let folder = out.join(format!("v{index:04}"));
    let plain = folder.join("plain");
    let scene = folder.join("scene.toml");
    let (scene, plain) = (scene.to_string_lossy(), plain.to_string_lossy());
    let mut args = vec!["bake".to_owned(), scene.to_string(), "--out".to_owned(), plain.to_string()];
    if let Some(frames) = read_manifest(out).unwrap()[index].frames {
        args.extend(["--frames".to_owned(), frames.to_string()]);
    }
    ok(drape(&args.iter().map(String::as_str).collect::<Vec<_>>()));
    let plain = folder.join("plain");
    let farm = std::fs::read(folder.join("bake/cloth.pc2")).unwrap();
    assert!(
        farm == std::fs::read(plain.join("cloth.pc2")).unwrap(),
        "variant {index}: the farm's PC2 is the bake's, byte for byte"
    );
    std::fs::remove_dir_all(plain).unwrap();
}

#[test]
fn a_local_run_bakes_every_variant_as_drape_bake_does_and_collect_reports_them() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = small_sweep(dir.path(), &[0.2, 0.8], 10);
    let out = dir.path().join("out");
    ok(drape(&["sweep", &sweep.to_string_lossy(), "--out", &out.to_string_lossy()]));
    let text = ok(drape(&["farm", "run", &out.to_string_lossy(), "--local", "-j", "2"]));
    assert!(text.contains("4 variants baked, 0 failed"), "{text}");
    for index in 0..4 {
        assert_same_as_a_plain_bake(&out, index);
    }
    let again = ok(drape(&["farm", "run", &out.to_string_lossy(), "--local"]));
    assert!(again.contains("nothing to run"), "{again}");
    let status = ok(drape(&["farm", "status", &out.to_string_lossy()]));
    assert!(status.contains("4 variants: 4 finished"), "{status}");

    ok(drape(&["farm", "collect", &out.to_string_lossy(), "--frame", "5"]));
    let csv = std::fs::read_to_string(out.join("report.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 4, "one row per variant:\n{csv}");
    assert!(rows.iter().all(|r| r.contains(",finished,11,")), "frames 0 to 10:\n{csv}");
    let sheet = image::open(out.join("contact_sheet.png")).unwrap().to_rgba8();
    let (w, h) = drape::farm::report::TILE;
    assert_eq!(sheet.dimensions(), (2 * w, 2 * h), "a 2 × 2 grid of tiles");
    for k in 0..4u32 {
        let (x0, y0) = ((k % 2) * w, (k / 2) * h);
        let band_y = y0 + h - 14;
        let lettered = (x0..x0 + w).filter(|&x| sheet.get_pixel(x, band_y)[0] > 150).count();
        assert!(lettered > 5, "tile {k} has its caption ({lettered} light pixels on its band)");
        let cloth = (y0..y0 + h - 30).step_by(4).flat_map(|y| (x0..x0 + w).step_by(4).map(move |x| (x, y)));
        let shades: std::collections::HashSet<[u8; 3]> =
            cloth.map(|(x, y)| sheet.get_pixel(x, y).0).map(|p| [p[0] / 16, p[1] / 16, p[2] / 16]).collect();
        assert!(shades.len() > 8, "tile {k} is a rendered scene ({} shades)", shades.len());
    }
}

#[test]
fn a_variant_that_fails_is_reported_with_why_and_not_retried() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = small_sweep(dir.path(), &[0.2], 10);
    let out = dir.path().join("out");
    ok(drape(&["sweep", &sweep.to_string_lossy(), "--out", &out.to_string_lossy()]));
    // Variant 1's scene broken after the sweep wrote it (as a node with a
    // damaged copy would see it): its task fails, and says why.
    let scene = out.join("v0001/scene.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, text.replace("duration_s = 1.0", "duration_s = -1.0")).unwrap();
    let run = drape(&["farm", "run", &out.to_string_lossy(), "--local", "-j", "2"]);
    assert!(!run.status.success(), "a failed variant fails the run");
    let status = ok(drape(&["farm", "status", &out.to_string_lossy()]));
    let line = status.lines().find(|l| l.starts_with("v0001")).unwrap();
    assert!(line.contains("failed") && line.contains("duration_s"), "{status}");
    assert!(status.contains("1 failed, 1 finished"), "{status}");
    let again = ok(drape(&["farm", "run", &out.to_string_lossy(), "--local"]));
    assert!(again.contains("nothing to run"), "a failed variant is not retried: {again}");
    let bad = drape(&["sweep", &dir.path().join("nope.toml").to_string_lossy(), "--out", &out.to_string_lossy()]);
    assert_eq!(bad.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("nope.toml"));
}

/// A real single-node Slurm for the test's duration (`tools/slurm-local`),
/// stopped by PID when dropped; `None`, with the reason printed, where it
/// cannot run (not Debian, not root).
struct LocalSlurm;

impl LocalSlurm {
    fn start() -> Option<LocalSlurm> {
        let debian = Path::new("/etc/debian_version").exists();
        // SAFETY: geteuid has no preconditions.
        let root = unsafe { libc::geteuid() } == 0;
        if !(debian && root) {
            eprintln!("skipped: a local Slurm needs Debian and root (debian: {debian}, root: {root})");
            return None;
        }
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/slurm-local");
        let started = Command::new(&script).arg("start").output().expect("tools/slurm-local runs");
        assert!(started.status.success(), "Slurm did not come up: {}", String::from_utf8_lossy(&started.stderr));
        Some(LocalSlurm)
    }
}

impl Drop for LocalSlurm {
    fn drop(&mut self) {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/slurm-local");
        let _ = Command::new(script).arg("stop").output();
    }
}

fn finished_count(out: &Path) -> usize {
    let status = ok(drape(&["farm", "status", &out.to_string_lossy()]));
    status.lines().filter(|l| l.starts_with('v') && l.contains(" finished ")).count()
}

/// A long enough bake to requeue in its middle: a 64 × 64 cloth for 8 s.
fn long_sweep(dir: &Path) -> PathBuf {
    std::fs::write(
        dir.join("long.toml"),
        "description = \"long\"\n[time]\nfps = 30.0\nduration_s = 8.0\n[solver]\nsteps_per_frame = 2\n\
         [[garment]]\nname = \"cloth\"\npreset = \"cotton\"\nmesh = { grid = { size_m = 1.0, resolution = 64 } }\n\
         translation_m = [0.0, 1.0, 0.0]\n[[collider]]\nname = \"ball\"\nshape = { sphere = { radius_m = 0.3 } }\n\
         position_m = [0.0, 0.5, 0.0]\n",
    )
    .unwrap();
    let path = dir.join("long_sweep.toml");
    std::fs::write(&path, "base = \"long.toml\"\nmode = \"list\"\n[[variant]]\nset = { \"garment.0.fabric.friction\" = 0.3 }\n[slurm]\ncpus_per_task = 1\n").unwrap();
    path
}

#[test]
fn slurm_runs_the_sweep_as_drape_bake_does_and_a_requeued_task_resumes_to_the_same_bytes() {
    let Some(_slurm) = LocalSlurm::start() else { return };
    let dir = tempfile::tempdir().unwrap();
    let sweep = small_sweep(dir.path(), &[0.2, 0.8], 10);
    let out = dir.path().join("out");
    ok(drape(&["sweep", &sweep.to_string_lossy(), "--out", &out.to_string_lossy()]));
    let submitted = ok(drape(&["farm", "run", &out.to_string_lossy(), "--slurm"]));
    assert!(submitted.contains("submitted job") && submitted.contains("4 tasks"), "{submitted}");
    wait_for("the 4 tasks", Duration::from_secs(300), || finished_count(&out) == 4);
    for index in 0..4 {
        assert_same_as_a_plain_bake(&out, index);
    }
    let again = ok(drape(&["farm", "run", &out.to_string_lossy(), "--slurm"]));
    assert!(again.contains("nothing to run"), "a second run submits nothing: {again}");

    // Requeued in the middle of its bake: the task resumes from its checkpoint.
    let long = dir.path().join("long");
    ok(drape(&["sweep", &long_sweep(dir.path()).to_string_lossy(), "--out", &long.to_string_lossy()]));
    ok(drape(&["farm", "run", &long.to_string_lossy(), "--slurm"]));
    let job = std::fs::read_to_string(long.join("jobs.txt")).unwrap().trim().to_owned();
    let checkpoint = long.join("v0000/bake.partial/.resume/checkpoint.bin");
    wait_for("the first checkpoint", Duration::from_secs(120), || checkpoint.is_file());
    let requeue = Command::new("scontrol").args(["requeue", &format!("{job}_0")]).output().unwrap();
    assert!(requeue.status.success(), "{}", String::from_utf8_lossy(&requeue.stderr));
    wait_for("the requeued task", Duration::from_secs(300), || finished_count(&long) == 1);
    let log = std::fs::read_to_string(long.join("logs/0.log")).unwrap();
    assert!(
        log.contains("DUE TO JOB REQUEUE") && log.contains("resuming"),
        "the task was requeued and resumed:\n{log}"
    );
    assert_same_as_a_plain_bake(&long, 0);
}

#[test]
fn a_sweep_that_asks_for_the_reference_reports_each_variants_error() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = small_sweep(dir.path(), &[0.3], 6);
    let text = std::fs::read_to_string(&sweep).unwrap().replace("frames = 6\n", "frames = 6\nreference = true\n");
    std::fs::write(&sweep, text).unwrap();
    let out = dir.path().join("out");
    ok(drape(&["sweep", &sweep.to_string_lossy(), "--out", &out.to_string_lossy()]));
    ok(drape(&["farm", "run", &out.to_string_lossy(), "--local", "-j", "2"]));
    let report = ok(drape(&["farm", "collect", &out.to_string_lossy()]));
    let csv = std::fs::read_to_string(out.join("report.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let column = header.iter().position(|h| *h == "reference_error").unwrap();
    for row in csv.lines().skip(1) {
        let error: f64 = row.split(',').nth(column).unwrap().parse().unwrap_or_else(|_| panic!("no error in {row}"));
        assert!(
            error > 0.0 && error < 0.05,
            "a 2-step bake is within 5 % of the diagonal of its 16x reference: {error}"
        );
    }
    assert!(report.contains("error vs reference"), "{report}");
}
