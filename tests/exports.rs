//! Exports read back by independent readers (tools/readers.sh installs
//! them; tools/test sets DRAPE_REQUIRE_READERS so a missing one fails):
//! USD with Pixar's usd-core (its validators, then every time sample
//! against the bake's point cache), glTF with the Khronos validator and
//! pygltflib (base + morph target k = frame k), MDD read with struct. And
//! bad requests refused with exit code 1, leaving no file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use serde_json::Value;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn drape(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().expect("the drape binary runs")
}

/// The first 13 frames of skirt_walk (skirt, body, ground), baked once and
/// exported in every format by `drape bake --export`.
fn bake() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let scene = repo("assets/scenes/skirt_walk.toml");
        let out = drape(&[
            "bake",
            scene.to_str().unwrap(),
            "--out",
            dir.path().to_str().unwrap(),
            "--frames",
            "12",
            "--export",
            "usd,gltf,mdd",
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        dir
    })
    .path()
}

/// The Python with usd-core and pygltflib, or `None` (with the reason
/// printed) when the readers are not installed and not required.
fn readers_python() -> Option<String> {
    match std::env::var("DRAPE_READERS_PYTHON") {
        Ok(python) => Some(python),
        Err(_) if std::env::var_os("DRAPE_REQUIRE_READERS").is_some() => panic!("DRAPE_READERS_PYTHON is not set"),
        Err(_) => {
            eprintln!("skipped: the export readers are not installed (tools/test installs them)");
            None
        }
    }
}

/// tests/readers/check_export.py's report on `file` of the bake.
fn check(kind: &str, file: &str) -> Option<Value> {
    let python = readers_python()?;
    let script = repo("tests/readers/check_export.py");
    let dir = bake();
    let out = Command::new(python)
        .args([script.to_str().unwrap(), kind, dir.to_str().unwrap(), dir.join(file).to_str().unwrap(), "skirt"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    Some(serde_json::from_slice(&out.stdout).unwrap())
}

#[test]
fn usd_validates_and_holds_every_frame_of_the_point_cache() {
    let Some(report) = check("usd", "skirt_walk.usda") else { return };
    assert_eq!(report["errors"], serde_json::json!([]), "usd-core's validators: {report}");
    assert_eq!((report["up_axis"].as_str(), report["meters_per_unit"].as_f64()), (Some("Y"), Some(1.0)));
    assert_eq!(report["time_codes_per_second"].as_f64(), Some(30.0));
    assert_eq!((report["start"].as_f64(), report["end"].as_f64()), (Some(0.0), Some(12.0)));
    assert_eq!(report["time_samples"], report["frames"]);
    // f32 written so that USD reads back the same bits.
    assert_eq!(report["largest_difference_m"].as_f64(), Some(0.0), "{report}");
    assert_eq!(report["extent_difference_m"].as_f64(), Some(0.0), "extent per sample: {report}");
    assert_eq!(report["faces"], report["obj_faces"]);
    assert_eq!((report["same_corners"].as_bool(), report["uv_indices_match"].as_bool()), (Some(true), Some(true)));
    assert_eq!(report["uvs"], report["obj_uvs"]);
    assert_eq!(report["interpolation"], "faceVarying");
    assert_eq!(report["body_meshes"], serde_json::json!(["body"]));
    assert!(report["body_moves_m"].as_f64().unwrap() > 0.05, "the body walks: {report}");
}

#[test]
fn gltf_passes_the_khronos_validator_and_each_morph_target_is_its_frame() {
    let Some(report) = check("gltf", "skirt_walk.glb") else { return };
    // Base + target k = frame k, to the rounding of one f32 subtraction.
    assert!(report["largest_difference_m"].as_f64().unwrap() < 2.5e-7, "{report}");
    assert_eq!(report["targets"].as_u64(), Some(12));
    assert_eq!(report["weights_one_hot"].as_bool(), Some(true));
    assert_eq!(report["vertex_map_matches_the_obj"].as_bool(), Some(true), "_DRAPE_VERTEX: {report}");
    assert_eq!(report["sheen"].as_bool(), Some(true));
    assert_eq!(report["nodes"], serde_json::json!(["skirt", "body", "ground"]));

    let modules = std::env::var("DRAPE_GLTF_VALIDATOR_MODULES").expect("set with DRAPE_READERS_PYTHON");
    let out = Command::new("node")
        .env("NODE_PATH", modules)
        .args([
            repo("tests/readers/validate_gltf.js").to_str().unwrap(),
            bake().join("skirt_walk.glb").to_str().unwrap(),
        ])
        .output()
        .unwrap();
    let validation: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((validation["errors"].as_i64(), validation["warnings"].as_i64()), (Some(0), Some(0)), "{validation}");
}

#[test]
fn mdd_reads_back_equal_to_the_point_cache() {
    let Some(report) = check("mdd", "skirt.mdd") else { return };
    assert_eq!(report["equal_to_pc2"].as_bool(), Some(true), "{report}");
    assert_eq!((report["frames"].as_u64(), report["points"].as_u64()), (Some(13), Some(2232)));
    assert_eq!(report["size_bytes"].as_u64(), Some(8 + 4 * 13 + 12 * 13 * 2232));
    assert_eq!(report["first_times"][1].as_f64(), Some(f64::from(1.0f32 / 30.0)));
}

#[test]
fn a_quantized_gltf_with_a_target_every_four_frames_validates() {
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("q.glb");
    let out = drape(&[
        "export",
        bake().to_str().unwrap(),
        "--format",
        "gltf",
        "--quantize",
        "--every",
        "4",
        "--out",
        glb.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let full = std::fs::metadata(bake().join("skirt_walk.glb")).unwrap().len();
    assert!(std::fs::metadata(&glb).unwrap().len() < full / 3, "quantized keyframes are smaller");
    let Some(python) = readers_python() else { return };
    let modules = std::env::var("DRAPE_GLTF_VALIDATOR_MODULES").unwrap();
    let out = Command::new("node")
        .env("NODE_PATH", modules)
        .args([repo("tests/readers/validate_gltf.js").to_str().unwrap(), glb.to_str().unwrap()])
        .output()
        .unwrap();
    let validation: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(validation["errors"].as_i64(), Some(0), "{validation}");
    // The keyframes are frames 0, 4, 8 and 12; positions within a 16-bit step of the bake's.
    let script = repo("tests/readers/check_export.py");
    let out = Command::new(python)
        .args([script.to_str().unwrap(), "gltf", bake().to_str().unwrap(), glb.to_str().unwrap(), "skirt"])
        .output()
        .unwrap();
    let report: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["frames"], serde_json::json!([0, 4, 8, 12]));
    assert_eq!(report["extensions_required"], serde_json::json!(["KHR_mesh_quantization"]));
    assert!(report["largest_difference_m"].as_f64().unwrap() < 1e-4, "{report}");
}

/// A request that cannot be met: exit code 1, a message naming the
/// problem, and no file (not even a half-written one).
fn refused(args: &[&str], expected: &[&str], out_file: &Path) {
    let out = drape(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{args:?}: {stderr}");
    for text in expected {
        assert!(stderr.contains(text), "{args:?}: '{text}' not in {stderr}");
    }
    assert!(!out_file.exists(), "{args:?} left {}", out_file.display());
    let leftovers = out_file.parent().and_then(|p| std::fs::read_dir(p).ok()).into_iter().flatten().flatten();
    assert!(leftovers.filter(|e| e.file_name().to_string_lossy().ends_with(".partial")).count() == 0);
}

#[test]
fn bad_requests_are_refused_and_leave_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("out.usda");
    let t = target.to_str().unwrap();
    // A folder that is not a bake.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    refused(
        &["export", empty.to_str().unwrap(), "--format", "usd", "--out", t],
        &["not a bake folder", "summary.json"],
        &target,
    );
    // An unfinished bake.
    let unfinished = dir.path().join("unfinished");
    std::fs::create_dir(&unfinished).unwrap();
    let mut summary: Value = serde_json::from_slice(&std::fs::read(bake().join("summary.json")).unwrap()).unwrap();
    summary["complete"] = Value::Bool(false);
    std::fs::write(unfinished.join("summary.json"), summary.to_string()).unwrap();
    refused(
        &["export", unfinished.to_str().unwrap(), "--format", "usd", "--out", t],
        &["unfinished", "--resume"],
        &target,
    );
    // Frames outside the bake.
    let b = bake().to_str().unwrap();
    refused(
        &["export", b, "--format", "gltf", "--frames", "5..40", "--out", t],
        &["--frames 5..40", "last frame available is 12"],
        &target,
    );
    // An output that cannot be written: its folder is a file.
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, "x").unwrap();
    let inside = blocker.join("out.usda");
    refused(&["export", b, "--format", "usd", "--out", inside.to_str().unwrap()], &["file"], &inside);
    // A format drape does not write.
    refused(&["export", b, "--format", "abc", "--out", t], &["--format abc", "usd, gltf or mdd"], &target);
}

#[test]
fn a_position_that_is_not_a_number_never_reaches_a_file() {
    use drape::export::{ExportError, ExportRequest, Format, export};
    use drape::stage::baked::BakedFrames;
    use nalgebra::Vector3;
    let scene = drape::scene::Scene::load(&repo("assets/scenes/drape_sphere.toml")).unwrap();
    let count = scene.garments[0].mesh.vertex_count();
    let mut frames = vec![scene.garments[0].mesh.positions.clone(); 3];
    frames[2][7] = Vector3::new(f64::NAN, 0.0, 0.0);
    let frames: Vec<&[Vector3<f64>]> = frames.iter().map(Vec::as_slice).collect();
    let baked = BakedFrames::from_positions(&scene, &frames);
    let dir = tempfile::tempdir().unwrap();
    for format in [Format::Usd, Format::Gltf] {
        let result = export(&scene, &baked, &ExportRequest::new(format), dir.path(), &|_, _| {}, &Default::default());
        let e = result.unwrap_err();
        assert!(matches!(e, ExportError::Invalid(_)) && e.to_string().contains("vertex 7 at frame 2"), "{e}");
    }
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "no file, not even a temporary, of {count} vertices");
}
