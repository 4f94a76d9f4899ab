//! Every shipped asset loads; every bad input gets a clear error and no panic;
//! the command line keeps its promises (exit codes, bake folder layout).

use std::path::{Path, PathBuf};
use std::process::Command;

use drape::io::pc2::read_pc2;
use drape::scene::Scene;
use drape::scene::preset::Preset;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn drape(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().expect("the drape binary runs")
}

#[test]
fn every_shipped_preset_and_scene_loads_and_builds_a_simulator() {
    for name in Preset::builtin_names() {
        let from_file = Preset::resolve(&format!("{name}.toml"), &repo("presets"), &toml::Table::new()).unwrap();
        assert_eq!(from_file, Preset::builtin(name).unwrap(), "{name}: the file and the built-in copy agree");
    }
    let mut scenes = 0;
    for entry in std::fs::read_dir(repo("assets/scenes")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            scene.simulator().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            scenes += 1;
        }
    }
    assert!(scenes >= 14, "every scene of SCENES.md is shipped");
}

/// The `bad_mesh` scene: its garment's four defects are each reported, and it
/// simulates without a NaN.
#[test]
fn bad_mesh_loads_with_warnings_and_simulates_finite() {
    let scene = Scene::load(&repo("assets/scenes/bad_mesh.toml")).unwrap();
    let garment = &scene.garments[0];
    let r = &garment.report;
    assert_eq!((r.duplicate_vertices, r.degenerate_triangles, r.non_manifold_edges, r.isolated_vertices), (1, 1, 1, 1));
    assert_eq!(r.warnings().len(), 4, "{:?}", r.warnings());
    let mut sim = scene.simulator().unwrap();
    for _ in 0..scene.frame_count * scene.steps_per_frame as usize {
        sim.step(scene.step_duration()).unwrap();
    }
    assert!(sim.positions().iter().all(|p| p.iter().all(|c| c.is_finite())));
    assert!(sim.positions().iter().all(|p| p.y >= 0.0), "it landed on the ground or the sphere");
}

/// Writes `files` into a fresh folder and loads `scene.toml` from it.
fn load_with(files: &[(&str, &str)]) -> String {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    match Scene::load(&dir.path().join("scene.toml")) {
        Ok(_) => panic!("{files:?} loaded"),
        Err(e) => e.to_string(),
    }
}

/// A `[[collider]]` table: a sphere spinning about Y with the given extra
/// motion fields.
fn spinning_ball(timing: &str) -> String {
    format!(
        "[[collider]]\nname = \"ball\"\nshape = {{ sphere = {{ radius_m = 0.3 }} }}\n\
         motion = {{ angular_velocity_deg_per_s = [0.0, 90.0, 0.0], {timing} }}\n"
    )
}

/// Files to write (name, contents) and the phrases the error must contain.
type BadInputCase<'a> = (Vec<(&'a str, String)>, Vec<&'a str>);

const GOOD_HEAD: &str = "[time]\nduration_s = 1.0\n[[garment]]\nname = \"cloth\"\n";

#[test]
fn bad_inputs_get_clear_errors_naming_the_file_and_the_problem() {
    let grid = "mesh = { grid = { size_m = 1.0, resolution = 8 } }\n";
    let triangle = "v 0 0 0\nv 1 0 0\nv 0 0 1\n";
    let cases: Vec<BadInputCase> = vec![
        (vec![], vec!["cannot read scene file", "scene.toml"]),
        (vec![("scene.toml", "[time\nduration_s = 1".into())], vec!["scene.toml", "line 1"]),
        (
            vec![("scene.toml", format!("{GOOD_HEAD}preset = \"cotton\"\n{grid}colour = \"red\"\n"))],
            vec!["unknown field `colour`", "line 7"],
        ),
        (
            vec![(
                "scene.toml",
                format!("{GOOD_HEAD}preset = \"cotton\"\nfabric = {{ vertex_mass_kg = -0.01 }}\n{grid}"),
            )],
            vec!["vertex_mass_kg = -0.01", "positive mass"],
        ),
        (
            vec![(
                "scene.toml",
                format!("{GOOD_HEAD}preset = \"cotton\"\nfabric = {{ bend_stiffness_n_m = nan }}\n{grid}"),
            )],
            vec!["bend_stiffness_n_m = NaN", "N·m"],
        ),
        (vec![("scene.toml", format!("{GOOD_HEAD}preset = \"velvet\"\n{grid}"))], vec!["unknown preset 'velvet'"]),
        (
            vec![(
                "scene.toml",
                format!("{GOOD_HEAD}preset = \"cotton\"\n{grid}{}", spinning_ball("start_s = 1.0, end_s = nan")),
            )],
            vec!["collider 'ball': motion", "end_s must be a number not before start_s"],
        ),
        (
            vec![(
                "scene.toml",
                format!("{GOOD_HEAD}preset = \"cotton\"\n{grid}{}", spinning_ball("start_s = 2.0, end_s = 1.0")),
            )],
            vec!["collider 'ball': motion", "end_s must be a number not before start_s"],
        ),
        (
            vec![("scene.toml", format!("{GOOD_HEAD}preset = \"cotton\"\n{grid}[camera]\npitch_deg = 95.0\n"))],
            vec!["scene.toml", "camera.pitch_deg", "95", "degrees"],
        ),
        (
            vec![("scene.toml", format!("{GOOD_HEAD}preset = \"cotton\"\n{grid}[camera]\nzoom = 2.0\n"))],
            vec!["unknown field `zoom`"],
        ),
        (
            vec![
                ("scene.toml", format!("{GOOD_HEAD}preset = \"cotton\"\nmesh = {{ obj = \"empty.obj\" }}\n")),
                ("empty.obj", "# nothing\n".into()),
            ],
            vec!["empty.obj", "no triangles"],
        ),
        (
            vec![
                ("scene.toml", format!("{GOOD_HEAD}preset = \"cotton\"\nmesh = {{ obj = \"range.obj\" }}\n")),
                ("range.obj", format!("{triangle}f 1 2 3\nf 1 2 7\n")),
            ],
            vec!["range.obj", "line 5"],
        ),
        (
            vec![("scene.toml", format!("{GOOD_HEAD}preset = \"cotton\"\nmesh = {{ obj = \"absent.obj\" }}\n"))],
            vec!["cannot read OBJ file", "absent.obj"],
        ),
        (
            vec![("scene.toml", format!("{GOOD_HEAD}preset = \"cotton\"\n{grid}[[garment.pin]]\nvertices = [64]\n"))],
            vec!["pin 1", "vertex 64 does not exist", "64 vertices"],
        ),
        (
            vec![(
                "scene.toml",
                format!(
                    "{GOOD_HEAD}preset = \"cotton\"\n{grid}[[collider]]\nname = \"ball\"\nshape = {{ sphere = {{ radius_m = -1.0 }} }}\n"
                ),
            )],
            vec!["collider 'ball'", "radius_m", "positive length"],
        ),
        (vec![("scene.toml", "[time]\nduration_s = 0.0\n".into())], vec!["time.duration_s", "out of range"]),
        (
            vec![("scene.toml", format!("[solver]\nlong_step_error = -0.5\n{GOOD_HEAD}preset = \"cotton\"\n{grid}"))],
            vec!["solver.long_step_error", "-0.5 is out of range", "0 ≤ value ≤ 100"],
        ),
        (
            vec![("scene.toml", format!("[solver]\nlong_step_error = nan\n{GOOD_HEAD}preset = \"cotton\"\n{grid}"))],
            vec!["solver.long_step_error", "NaN is out of range"],
        ),
        (
            vec![("scene.toml", format!("[collision]\npass_progress = 1.0\n{GOOD_HEAD}preset = \"cotton\"\n{grid}"))],
            vec!["collision.pass_progress", "1 is out of range", "0 ≤ p < 1"],
        ),
        (
            vec![(
                "scene.toml",
                format!("[collision]\nrepulsion_stiffness_n_per_m = -2.0\n{GOOD_HEAD}preset = \"cotton\"\n{grid}"),
            )],
            vec!["collision.repulsion_stiffness_n_per_m", "-2 is out of range", "k ≥ 0 N/m"],
        ),
        (
            vec![(
                "scene.toml",
                format!(
                    "[collision]\nfeature_repulsion_stiffness_n_per_m = nan\n{GOOD_HEAD}preset = \"cotton\"\n{grid}"
                ),
            )],
            vec!["collision.feature_repulsion_stiffness_n_per_m", "NaN is out of range", "k ≥ 0 N/m"],
        ),
        (
            vec![(
                "scene.toml",
                format!("[collision]\ntip_repulsion_stiffness_n_per_m = -1\n{GOOD_HEAD}preset = \"cotton\"\n{grid}"),
            )],
            vec!["collision.tip_repulsion_stiffness_n_per_m", "-1 is out of range", "k ≥ 0 N/m"],
        ),
        (
            vec![(
                "scene.toml",
                format!("{GOOD_HEAD}preset = \"cotton\"\nfabric = {{ strain_limit = -0.01 }}\n{grid}"),
            )],
            vec!["strain_limit = -0.01", "0 ≤ value ≤ 1"],
        ),
        (
            vec![(
                "scene.toml",
                format!("{GOOD_HEAD}preset = \"cotton\"\n{grid}[[garment.pin]]\nvertices = [0]\nattach = \"body\"\n"),
            )],
            vec!["pin 1", "`attach = \"body\"` names no mesh collider"],
        ),
        (
            vec![(
                "scene.toml",
                format!(
                    "{GOOD_HEAD}preset = \"cotton\"\n{grid}[[garment.pin]]\nvertices = [0]\nattach = \"body\"\nmotion = {{ velocity_m_per_s = [1.0, 0.0, 0.0] }}\n"
                ),
            )],
            vec!["pin 1", "give `attach` or `motion`, not both"],
        ),
    ];
    for (files, expected) in cases {
        let files: Vec<(&str, &str)> = files.iter().map(|(n, t)| (*n, t.as_str())).collect();
        let message = load_with(&files);
        for fragment in expected {
            assert!(message.contains(fragment), "expected '{fragment}' in: {message}");
        }
    }
}

#[test]
fn bake_writes_the_documented_folder_and_a_readable_point_cache() {
    let out = tempfile::tempdir().unwrap();
    let dir = out.path().join("bake");
    let result = drape(&[
        "bake",
        repo("assets/scenes/drape_sphere.toml").to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
        "--frames",
        "3",
    ]);
    assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
    for file in ["frame_0000.obj", "frame_0003.obj", "materials.mtl", "cloth.pc2", "summary.json"] {
        assert!(dir.join(file).is_file(), "{file} missing");
    }
    let cache = read_pc2(&std::fs::read(dir.join("cloth.pc2")).unwrap()).unwrap();
    assert_eq!((cache.points, cache.samples.len()), (4096, 4));
    let summary: serde_json::Value = serde_json::from_slice(&std::fs::read(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["frames"], 4);
    assert_eq!(summary["complete"], true);
    assert!(summary["ms_per_frame_median"].as_f64().unwrap() > 0.0);
    let frame = drape::io::obj::read_obj(&dir.join("frame_0003.obj")).unwrap();
    assert_eq!(frame.mesh.vertex_count(), 4096, "same vertices, same order");
    for (p, q) in frame.mesh.positions.iter().zip(&cache.samples[3]) {
        assert!((p.x as f32 - q[0]).abs() < 1e-5 && (p.y as f32 - q[1]).abs() < 1e-5);
    }
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".partial"))
        .collect();
    assert!(leftovers.is_empty(), "no temporary files left");
}

#[test]
fn exit_codes_say_ok_or_bad_input() {
    let ok = drape(&["check", repo("assets/scenes/pillars.toml").to_str().unwrap()]);
    assert_eq!(ok.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&ok.stdout).contains("collider 'cone'"));

    let missing = drape(&["check", "no/such/scene.toml"]);
    assert_eq!(missing.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("no/such/scene.toml"));

    let file_in_the_way = tempfile::NamedTempFile::new().unwrap();
    let blocked = drape(&[
        "bake",
        repo("assets/scenes/drape_sphere.toml").to_str().unwrap(),
        "--out",
        file_in_the_way.path().to_str().unwrap(),
        "--frames",
        "1",
    ]);
    assert_eq!(blocked.status.code(), Some(1), "{}", String::from_utf8_lossy(&blocked.stderr));
    assert!(String::from_utf8_lossy(&blocked.stderr).contains("cannot write"));

    let unreadable = drape(&["bench", "accuracy", "scene.toml", "--tolerances", "abc"]);
    assert_eq!(unreadable.status.code(), Some(1), "a command line we cannot read is bad input");
    assert!(String::from_utf8_lossy(&unreadable.stderr).contains("--tolerances"));
    let zero_steps = drape(&["bench", "accuracy", "scene.toml", "--steps", "0"]);
    assert_eq!(zero_steps.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&zero_steps.stderr).contains("--steps"));
    assert_eq!(drape(&["--help"]).status.code(), Some(0));
}

/// The bake command as a user who may not write to `out` (as root, whom
/// permissions do not stop, the command runs as `nobody` through setpriv).
fn bake_without_write_permission(scene: &Path, out: &Path) -> std::process::Output {
    let exe = env!("CARGO_BIN_EXE_drape");
    let args = ["bake", scene.to_str().unwrap(), "--out", out.to_str().unwrap()];
    let is_root = Command::new("id").arg("-u").output().is_ok_and(|o| o.stdout.starts_with(b"0"));
    let mut command = if is_root {
        let mut c = Command::new("setpriv");
        c.args(["--reuid=65534", "--regid=65534", "--clear-groups", exe]);
        c
    } else {
        Command::new(exe)
    };
    command.args(args).output().expect("setpriv (util-linux) runs the bake as nobody")
}

#[test]
fn a_read_only_output_folder_is_a_clear_error_and_gets_no_partial_files() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("tiny.toml");
    std::fs::write(
        &scene,
        "[time]\nfps = 30.0\nduration_s = 0.1\n[[garment]]\nname = \"cloth\"\npreset = \"silk\"\n\
         mesh = { grid = { size_m = 0.3, resolution = 4 } }\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    for (path, mode) in [(dir.path(), 0o755), (scene.as_path(), 0o644), (out.as_path(), 0o555)] {
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
    }
    let refused = bake_without_write_permission(&scene, &out);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert_eq!(refused.status.code(), Some(1), "bad output is bad input: {stderr}");
    assert!(stderr.contains(out.to_str().unwrap()) && stderr.contains("Permission denied"), "{stderr}");
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0, "nothing half-written is left");
}
