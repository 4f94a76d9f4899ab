//! drape's FBX evaluation against the applications that wrote the files:
//! every reference mesh of the committed corpus subset (tests/data/ufbx,
//! from the ufbx project) within 0.01 % of its bounding-box diagonal, curve
//! tables key for key, and every file of the subset read or refused with a
//! clear message through `drape body`.

use std::path::{Path, PathBuf};

use drape::body::motion::PropertyKind;
use drape::io::fbx::{BodyOptions, read_body};
use drape::metrics::pose_error::{compare, read_reference};

/// Largest deviation accepted, % of a mesh's bounding-box diagonal.
const TOLERANCE_PERCENT: f64 = 0.01;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/ufbx").join(name)
}

/// One row of checks.tsv.
struct Check {
    fbx: String,
    reference: String,
    time_s: Option<f64>,
    stack: String,
}

fn checks() -> Vec<Check> {
    let text = std::fs::read_to_string(data("checks.tsv")).unwrap();
    text.lines()
        .skip(1)
        .map(|line| {
            let c: Vec<&str> = line.split('\t').collect();
            Check { fbx: c[0].into(), reference: c[1].into(), time_s: c[2].parse().ok(), stack: c[3].into() }
        })
        .collect()
}

/// Ten when the reference's application rounded its positions (ufbx's
/// authors mark those `ufbx:position_scale=0.1`), else one.
fn coarseness(reference: &Path) -> f64 {
    let text = std::fs::read_to_string(reference).unwrap();
    let marked = text.lines().take(20).any(|l| l.contains("ufbx:position_scale=0.1"));
    if marked { 10.0 } else { 1.0 }
}

/// The worst mesh of a check, % of its diagonal.
fn worst_percent(check: &Check) -> f64 {
    let path = data(&check.fbx);
    let mut body = read_body(&path, &BodyOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    if !check.stack.is_empty() {
        let stack = body.stacks.iter().find(|s| s.name.contains(&check.stack)).map(|s| s.name.clone());
        let options = BodyOptions {
            stack: Some(stack.unwrap_or_else(|| panic!("{}: no stack {}", check.fbx, check.stack))),
            ..Default::default()
        };
        body = read_body(&path, &options).unwrap();
    }
    let mut positions = Vec::new();
    match (check.time_s, &body.motion) {
        (Some(t), Some(motion)) => body.pose_in_file(motion, t - motion.start_s, &mut positions),
        _ => body.static_in_file(&mut positions),
    }
    let reference = read_reference(&data(&check.reference)).unwrap();
    let errors = compare(&body, &positions, &reference);
    assert!(!errors.is_empty(), "{}: no mesh in {}", check.fbx, check.reference);
    for e in &errors {
        assert!(e.part.is_some(), "{}: no mesh for group '{}' of {}", check.fbx, e.reference, check.reference);
    }
    errors.iter().map(|e| e.percent_of_diagonal()).fold(0.0, f64::max) / coarseness(&data(&check.reference))
}

#[test]
fn every_reference_mesh_is_within_a_ten_thousandth_of_its_size() {
    let checks = checks();
    assert!(checks.len() >= 100, "{} checks", checks.len());
    let mut failures = Vec::new();
    for check in &checks {
        let worst = worst_percent(check);
        if worst > TOLERANCE_PERCENT {
            failures.push(format!("{} at {:?}: {worst:.4} %", check.fbx, check.time_s));
        }
    }
    assert!(failures.is_empty(), "{} of {} checks off:\n{}", failures.len(), checks.len(), failures.join("\n"));
}

/// A table of curves.toml.
#[derive(serde::Deserialize)]
struct Table {
    file: String,
    fps: f64,
    frames: Vec<f64>,
    values: Vec<f64>,
}

#[derive(serde::Deserialize)]
struct Tables {
    curve: Vec<Table>,
}

#[test]
fn curves_match_their_applications_values_frame_for_frame_far_outside_their_keys() {
    let tables: Tables = toml::from_str(&std::fs::read_to_string(data("curves.toml")).unwrap()).unwrap();
    assert!(tables.curve.len() >= 7);
    for table in &tables.curve {
        let body = read_body(&data(&table.file), &BodyOptions::default()).unwrap();
        let motion = body.motion.as_ref().unwrap();
        let cube = body.skeleton.find("pCube1").unwrap();
        let node = motion.nodes.iter().find(|n| n.bone == cube).unwrap();
        let translation = node.translation.as_ref().unwrap();
        let rest = body.skeleton.bones[cube].rest.translation;
        for (&frame, &expected) in table.frames.iter().zip(&table.values) {
            let value = translation.value(rest.as_slice(), frame / table.fps, PropertyKind::Plain)[0];
            let tolerance = f64::min(1e-3, 1e-4 * expected.abs().max(1.0));
            assert!((value - expected).abs() <= tolerance, "{} frame {frame}: {value} not {expected}", table.file);
        }
    }
}

#[test]
fn big_endian_files_read_as_their_little_endian_twins() {
    let reference = read_reference(&data("maya_cube_big_endian.obj")).unwrap();
    for version in [7100, 7400, 7500] {
        let body =
            read_body(&data(&format!("maya_cube_big_endian_{version}_binary.fbx")), &BodyOptions::default()).unwrap();
        let mut positions = Vec::new();
        body.static_in_file(&mut positions);
        let errors = compare(&body, &positions, &reference);
        assert!(errors[0].max_distance < 1e-6, "{version}: {:?}", errors[0]);
    }
}

/// Every file of the subset through `drape body`, as a user would run it:
/// it describes the file (exit 0) or says, naming the file, what it does
/// not read (exit 1); never a panic.
#[test]
fn every_file_is_read_or_refused_with_its_name_and_the_reason() {
    let mut files: Vec<PathBuf> = std::fs::read_dir(data("."))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "fbx"))
        .collect();
    files.sort();
    assert!(files.len() >= 50);
    let mut refused = 0;
    for file in &files {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_drape")).arg("body").arg(file).output().unwrap();
        let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
        match out.status.code() {
            Some(0) => assert!(stdout.contains("FBX 7"), "{}: {stdout}", file.display()),
            Some(1) => {
                refused += 1;
                assert!(stderr.contains(&file.display().to_string()) && stderr.starts_with("error: "), "{stderr}");
            }
            other => panic!("{}: exit {other:?}\n{stderr}", file.display()),
        }
    }
    // The one FBX 6 file of the subset, refused with the version and what to do.
    assert_eq!(refused, 1);
}
