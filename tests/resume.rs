//! No lost work: a bake stopped by Ctrl-C or killed keeps every finished
//! frame whole, and `drape bake --resume` finishes it bit-identical to a bake
//! that never stopped; what cannot be resumed is a clear error.

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use drape::bake::Baker;
use drape::bake::resume::{self, Checkpoint};
use drape::io::obj::read_obj;
use drape::scene::Scene;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn drape(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().expect("the drape binary runs")
}

/// Every frame's positions, bit for bit, of a bake of `frames` frames of
/// `scene` interrupted after frame `stop`: its state goes through the
/// checkpoint file's encoding into a new baker, which finishes the bake.
fn positions_resumed_at(scene: &Scene, stop: usize, frames: usize) -> Vec<Vec<[u64; 3]>> {
    let bits = |baker: &Baker| baker.simulator().positions().iter().map(|p| p.map(f64::to_bits).into()).collect();
    let mut first = Baker::new(scene).unwrap();
    let mut out = Vec::new();
    while first.frame() < stop {
        first.advance().unwrap();
        out.push(bits(&first));
    }
    let checkpoint = Checkpoint {
        drape_version: "test".into(),
        scene_fingerprint: 0,
        frame: stop,
        records_bytes: 0,
        snapshot: first.simulator().snapshot().unwrap(),
    };
    drop(first);
    let saved = resume::decode(&resume::encode(&checkpoint).unwrap()).unwrap();
    let mut second = Baker::new(scene).unwrap();
    second.resume_at(saved.frame, &saved.snapshot).unwrap();
    while second.frame() < frames {
        second.advance().unwrap();
        out.push(bits(&second));
    }
    out
}

#[test]
fn a_simulation_taken_up_from_its_snapshot_goes_on_bit_identically() {
    // drape_sphere stopped in contact (the kept factor, resting contacts and
    // contact influences all matter); skirt_walk adds the moving body and the
    // waistband glued to it; the settled square takes one long step per
    // frame, whose length the last step's error decides.
    let scenes = [
        ("assets/scenes/drape_sphere.toml", 8, 12),
        ("assets/scenes/skirt_walk.toml", 18, 22),
        ("tests/fixtures/scenes/settling.toml", 30, 34),
    ];
    for (name, stop, frames) in scenes {
        let scene = Scene::load(&repo(name)).unwrap();
        let uninterrupted = positions_resumed_at(&scene, frames, frames);
        let resumed = positions_resumed_at(&scene, stop, frames);
        for (k, (a, b)) in uninterrupted.iter().zip(&resumed).enumerate() {
            assert!(a == b, "{name}: frame {} differs after resuming at frame {stop}", k + 1);
        }
    }
}

/// Starts `drape bake` of `frames` frames of drape_sphere into `dir`.
/// Re-simulating from a frame (the editor's "Re-simulate from here") takes
/// the state the editor kept of it, without the solver's factor (the next
/// step rebuilds one): the simulation goes on as the run it left, to within
/// the solver's tolerance (under 1 % of how far the cloth moves); the state is taken even while a fabric
/// change blends in; a state of another cloth or with a NaN is refused.
#[test]
fn a_simulation_restarted_from_a_kept_frame_state_goes_on_as_before() {
    let scene = Scene::load(&repo("assets/scenes/drape_sphere.toml")).unwrap();
    let mut first = Baker::new(&scene).unwrap();
    while first.frame() < 20 {
        first.advance().unwrap();
    }
    let kept = first.simulator().state();
    assert!(kept.factor.is_none(), "the factor is not kept per frame");
    while first.frame() < 26 {
        first.advance().unwrap();
    }
    let mut second = Baker::new(&scene).unwrap();
    second.restart_from(20, &kept).unwrap();
    while second.frame() < 26 {
        second.advance().unwrap();
    }
    let distance = |a: &[nalgebra::Vector3<f64>], b: &[nalgebra::Vector3<f64>]| {
        a.iter().zip(b).map(|(p, q)| (p - q).norm()).fold(0.0, f64::max)
    };
    let apart = distance(first.simulator().positions(), second.simulator().positions());
    let moved = distance(&kept.positions.iter().map(|&p| p.into()).collect::<Vec<_>>(), second.simulator().positions());
    assert!(apart < 0.01 * moved && moved > 0.01, "{apart} m from the run it left after moving {moved} m");

    let mut tuning = Baker::new(&scene).unwrap();
    tuning.advance().unwrap();
    let mut silk = scene.garments[0].fabric.clone();
    silk.bend_stiffness_n_m *= 0.1;
    tuning.set_fabric(0, silk).unwrap();
    tuning.advance().unwrap();
    assert!(tuning.simulator().snapshot().is_err(), "a bake snapshot waits for the blend");
    let mut third = Baker::new(&scene).unwrap();
    third.restart_from(2, &tuning.simulator().state()).unwrap();
    assert!(third.restart_from(3, &kept).is_err(), "the state is not at frame 3's end");
    let mut other = kept.clone();
    other.positions.pop();
    assert!(third.restart_from(20, &other).is_err(), "another cloth");
    let mut poisoned = kept.clone();
    poisoned.velocities[3][1] = f64::NAN;
    let error = third.restart_from(20, &poisoned).unwrap_err();
    assert!(error.to_string().contains("velocity"), "{error}");
}

fn start_bake(dir: &Path, frames: usize, resume: bool) -> Child {
    let scene = repo("assets/scenes/drape_sphere.toml");
    let mut command = Command::new(env!("CARGO_BIN_EXE_drape"));
    command.args(["bake", scene.to_str().unwrap(), "--out", dir.to_str().unwrap(), "--frames", &frames.to_string()]);
    if resume {
        command.arg("--resume");
    }
    command.stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null()).spawn().unwrap()
}

/// Waits until `dir` holds frame `frame`, then sends `signal` to the bake.
fn signal_after_frame(bake: &mut Child, dir: &Path, frame: usize, signal: &str) -> std::process::ExitStatus {
    let file = dir.join(format!("frame_{frame:04}.obj"));
    let start = Instant::now();
    while !file.exists() {
        assert!(start.elapsed() < Duration::from_secs(600), "the bake never reached frame {frame}");
        assert!(bake.try_wait().unwrap().is_none(), "the bake ended before frame {frame}");
        std::thread::sleep(Duration::from_millis(5));
    }
    let pid = bake.id().to_string();
    assert!(Command::new("kill").args([signal, &pid]).status().unwrap().success());
    bake.wait().unwrap()
}

/// The visible files of `dir` with their bytes, sorted by name.
fn visible_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_type().unwrap().is_file())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), std::fs::read(e.path()).unwrap()))
        .collect();
    files.sort();
    files
}

/// summary.json without what depends on the wall clock.
fn physics_of_summary(dir: &Path) -> serde_json::Value {
    let mut summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    let object = summary.as_object_mut().unwrap();
    object.retain(|key, _| !key.starts_with("ms_per_frame") && key != "stage_ms_per_frame_median");
    for row in object["per_frame"].as_array_mut().unwrap() {
        row.as_object_mut().unwrap().remove("ms");
    }
    summary
}

#[test]
fn a_bake_cancelled_then_killed_then_resumed_is_identical_to_one_that_never_stopped() {
    let out = tempfile::tempdir().unwrap();
    let (whole, broken) = (out.path().join("whole"), out.path().join("broken"));
    let frames = 14;
    assert!(start_bake(&whole, frames, false).wait().unwrap().success());

    // Ctrl-C: the bake stops after a whole frame, says how to go on, and
    // writes what it has (summary marked incomplete, a readable cache).
    let status = signal_after_frame(&mut start_bake(&broken, frames, false), &broken, 3, "-INT");
    assert_eq!(status.code(), Some(130), "Ctrl-C is exit code 130");
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(broken.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["complete"], false);

    // Resumed, then killed outright in the middle of a frame.
    let status = signal_after_frame(&mut start_bake(&broken, frames, true), &broken, 8, "-KILL");
    assert!(!status.success());
    for (name, _) in visible_files(&broken).iter().filter(|(n, _)| n.starts_with("frame_")) {
        let frame = read_obj(&broken.join(name)).unwrap_or_else(|e| panic!("{name} is not whole: {e}"));
        assert_eq!(frame.mesh.vertex_count(), 64 * 64, "{name} has every vertex");
    }

    let resumed = drape(&[
        "bake",
        repo("assets/scenes/drape_sphere.toml").to_str().unwrap(),
        "--out",
        broken.to_str().unwrap(),
        "--frames",
        &frames.to_string(),
        "--resume",
    ]);
    assert!(resumed.status.success(), "{}", String::from_utf8_lossy(&resumed.stderr));
    assert!(String::from_utf8_lossy(&resumed.stdout).contains("resuming the bake"));

    let (a, b) = (visible_files(&whole), visible_files(&broken));
    let names = |files: &[(String, Vec<u8>)]| files.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a), names(&b), "the same files, and no temporaries left");
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        if name != "summary.json" {
            assert!(x == y, "{name} differs from the uninterrupted bake's");
        }
    }
    assert_eq!(physics_of_summary(&whole), physics_of_summary(&broken));
    assert!(!broken.join(".resume").exists(), "a finished bake drops its working files");
}

#[test]
fn what_cannot_be_resumed_is_a_clear_error() {
    let out = tempfile::tempdir().unwrap();
    let scene = repo("assets/scenes/drape_sphere.toml");
    let bake = |dir: &Path, scene: &Path, frames: &str, resume: bool| {
        let mut args = vec!["bake", scene.to_str().unwrap(), "--out", dir.to_str().unwrap(), "--frames", frames];
        if resume {
            args.push("--resume");
        }
        drape(&args)
    };
    let refused = |result: std::process::Output, dir: &Path, words: &str| {
        let stderr = String::from_utf8_lossy(&result.stderr).into_owned();
        assert_eq!(result.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains(words) && stderr.contains(dir.to_str().unwrap()), "{stderr}");
    };

    let finished = out.path().join("finished");
    refused(bake(&finished, &scene, "2", true), &finished, "no resume checkpoint");
    assert!(bake(&finished, &scene, "2", false).status.success());
    refused(bake(&finished, &scene, "2", true), &finished, "finished bake");

    let killed = out.path().join("killed");
    let status = signal_after_frame(&mut start_bake(&killed, 6, false), &killed, 2, "-KILL");
    assert!(!status.success());
    refused(bake(&killed, &repo("assets/scenes/drape_table.toml"), "6", true), &killed, "another scene");

    let checkpoint = killed.join(".resume/checkpoint.bin");
    let mut bytes = std::fs::read(&checkpoint).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x40;
    std::fs::write(&checkpoint, &bytes).unwrap();
    refused(bake(&killed, &scene, "6", true), &killed, "checksum");
}

/// A tmpfs of `size` mounted on `dir` for the life of the guard (root only).
struct SmallDisk(PathBuf);

impl SmallDisk {
    fn mount(dir: &Path, size: &str) -> Option<SmallDisk> {
        std::fs::create_dir_all(dir).unwrap();
        let mounted =
            Command::new("mount").args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"]).arg(dir).output();
        mounted.ok().filter(|o| o.status.success()).map(|_| SmallDisk(dir.to_owned()))
    }

    fn grow(&self, size: &str) {
        let remount = Command::new("mount").args(["-o", &format!("remount,size={size}")]).arg(&self.0).status();
        assert!(remount.unwrap().success());
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

#[test]
fn a_full_disk_stops_the_bake_with_a_clear_error_and_resume_finishes_it_once_there_is_room() {
    let out = tempfile::tempdir().unwrap();
    let Some(disk) = SmallDisk::mount(&out.path().join("disk"), "10m") else {
        eprintln!("skipped: mounting a small tmpfs needs root (the CI runs as root)");
        return;
    };
    let (whole, full) = (out.path().join("whole"), disk.0.join("bake"));
    let scene = repo("assets/scenes/drape_sphere.toml");
    let bake = |dir: &Path, resume: bool| {
        let mut args = vec!["bake", scene.to_str().unwrap(), "--out", dir.to_str().unwrap(), "--frames", "8"];
        if resume {
            args.push("--resume");
        }
        drape(&args)
    };
    let stopped = bake(&full, false);
    let stderr = String::from_utf8_lossy(&stopped.stderr);
    assert_eq!(stopped.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("No space left on device") && stderr.contains("--resume"), "{stderr}");
    let kept: Vec<_> = visible_files(&full).into_iter().filter(|(n, _)| n.starts_with("frame_")).collect();
    assert!(!kept.is_empty() && kept.len() < 9, "{} frames fitted", kept.len());
    for (name, _) in &kept {
        read_obj(&full.join(name)).unwrap_or_else(|e| panic!("{name} is not whole: {e}"));
    }

    disk.grow("64m");
    assert!(bake(&full, true).status.success());
    assert!(bake(&whole, false).status.success());
    let (a, b) = (visible_files(&whole), visible_files(&full));
    assert_eq!(a.len(), b.len());
    for ((name, x), (other, y)) in a.iter().zip(&b) {
        assert_eq!(name, other);
        assert!(name == "summary.json" || x == y, "{name} differs from the uninterrupted bake's");
    }
}
