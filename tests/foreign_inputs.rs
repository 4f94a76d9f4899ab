//! Inputs from other programs: garments and bodies as Maya, 3ds Max,
//! Marvelous Designer, Windows editors, FBX 2016+ exporters and Mixamo write
//! them (`tests/fixtures/foreign/`, made by `tools/make_foreign_inputs.py`)
//! load with the geometry, names and units their files hold.

use std::path::{Path, PathBuf};

use drape::body::Body;
use drape::io::fbx::read_fbx;
use drape::io::obj::read_obj;
use nalgebra::Vector3;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/foreign").join(name)
}

/// `expected.toml`: what each file holds, measured when it was made.
fn expected() -> toml::Table {
    toml::from_str(&std::fs::read_to_string(fixture("expected.toml")).unwrap()).unwrap()
}

fn floats(value: &toml::Value) -> Vec<f64> {
    value.as_array().unwrap().iter().map(|v| v.as_float().unwrap_or_else(|| v.as_integer().unwrap() as f64)).collect()
}

fn strings(value: &toml::Value) -> Vec<String> {
    value.as_array().unwrap().iter().map(|v| v.as_str().unwrap().to_owned()).collect()
}

fn count(table: &toml::Table, key: &str) -> usize {
    table[key].as_integer().unwrap() as usize
}

/// Bounding box of `points`.
fn bounds(points: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let min = points.iter().fold(Vector3::repeat(f64::INFINITY), |m, p| m.inf(p));
    let max = points.iter().fold(Vector3::repeat(f64::NEG_INFINITY), |m, p| m.sup(p));
    (min, max)
}

fn assert_box(name: &str, what: &str, (min, max): (Vector3<f64>, Vector3<f64>), table: &toml::Table, keys: [&str; 2]) {
    let tolerance = 1e-3;
    for (got, key) in [(min, keys[0]), (max, keys[1])] {
        let want = floats(&table[key]);
        for axis in 0..3 {
            assert!((got[axis] - want[axis]).abs() < tolerance, "{name}: {what} {key}[{axis}] is {got}, not {want:?}");
        }
    }
}

#[test]
fn garments_from_other_programs_load_with_their_geometry_parts_and_materials() {
    for (name, value) in expected() {
        let table = value.as_table().unwrap();
        if table["kind"].as_str() != Some("garment") {
            continue;
        }
        let garment = read_obj(&fixture(table["file"].as_str().unwrap())).unwrap_or_else(|e| panic!("{name}: {e}"));
        let mesh = &garment.mesh;
        assert_eq!(mesh.vertex_count(), count(table, "vertices"), "{name}: vertices after welding");
        assert_eq!(mesh.triangles.len(), count(table, "triangles"), "{name}: triangles");
        assert_eq!(mesh.quads.len(), count(table, "quads"), "{name}: quads kept for shear");
        assert_eq!(garment.report.duplicate_vertices, count(table, "duplicate_positions"), "{name}: duplicates");
        assert_eq!(garment.report.degenerate_triangles, 0, "{name}");
        let parts: Vec<String> = mesh.surface.parts.iter().map(|p| p.name.clone()).collect();
        assert_eq!(parts, strings(&table["parts"]), "{name}: parts");
        let materials: Vec<String> = mesh.surface.materials.iter().map(|m| m.name.clone()).collect();
        assert_eq!(materials, strings(&table["materials"]), "{name}: materials");
        if let Some(colours) = table.get("material_diffuse") {
            for (material, colour) in mesh.surface.materials.iter().zip(colours.as_array().unwrap()) {
                let colour = floats(colour);
                assert!(material.diffuse.iter().zip(&colour).all(|(a, b)| (*a as f64 - b).abs() < 1e-4), "{name}");
            }
        }
        assert_box(&name, "garment", bounds(&mesh.positions), table, ["bbox_min", "bbox_max"]);
    }
}

#[test]
fn a_texture_the_material_names_but_nobody_shipped_is_a_warning_not_a_failure() {
    let garment = read_obj(&fixture("maya_quads_crlf.obj")).unwrap();
    assert!(garment.mesh.surface.materials.iter().all(|m| m.diffuse_texture.is_none()));
    let warning = garment.warnings.iter().find(|w| w.contains("cotton_red.png"));
    assert!(warning.is_some_and(|w| w.contains("cotton_redSG")), "{:?}", garment.warnings);
}

#[test]
fn vertices_keep_the_file_order_whatever_the_whitespace() {
    // Pins by index mean what the modelling tool shows: vertex k is the
    // file's k-th `v` line, tabs and indentation or not.
    let garment = read_obj(&fixture("tabs_and_comments.obj")).unwrap();
    let text = std::fs::read_to_string(fixture("tabs_and_comments.obj")).unwrap();
    let declared: Vec<Vector3<f64>> = text
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").split_whitespace().collect::<Vec<_>>())
        .filter(|t| t.first() == Some(&"v"))
        .map(|t| Vector3::new(t[1].parse().unwrap(), t[2].parse().unwrap(), t[3].parse().unwrap()))
        .collect();
    assert_eq!(garment.mesh.positions, declared);
}

fn body(name: &str) -> Body {
    read_fbx(&fixture(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The body posed at the end of its own motion.
fn last_pose(body: &Body) -> Vec<Vector3<f64>> {
    let motion = body.motion.as_ref().unwrap();
    let mut posed = Vec::new();
    body.pose_into(motion, motion.duration_s(), &mut posed);
    posed
}

#[test]
fn bodies_in_any_up_axis_unit_and_fbx_version_arrive_in_metres_y_up() {
    for (name, value) in expected() {
        let table = value.as_table().unwrap();
        if table["kind"].as_str() != Some("body") {
            continue;
        }
        let body = body(table["file"].as_str().unwrap());
        assert_eq!(body.mesh.triangles.len(), count(table, "triangles"), "{name}: triangles");
        for bone in strings(&table["bones"]) {
            assert!(body.skeleton.find(&bone).is_some(), "{name}: bone {bone} missing");
        }
        let motion = body.motion.as_ref().unwrap_or_else(|| panic!("{name}: no motion"));
        let mut animated: Vec<String> = motion.animated_bones().map(str::to_owned).collect();
        animated.sort();
        assert_eq!(animated, strings(&table["animated_models"]), "{name}: animated bones");
        let length = table["end_s"].as_float().unwrap() - table["start_s"].as_float().unwrap();
        assert!((motion.duration_s() - length).abs() < 1e-6, "{name}: {} s", motion.duration_s());
        assert_box(&name, "bind pose", bounds(&body.bind_pose()), table, ["bind_bbox_min_m", "bind_bbox_max_m"]);
        let last = ["last_frame_bbox_min_m", "last_frame_bbox_max_m"];
        assert_box(&name, "last frame", bounds(&last_pose(&body)), table, last);
    }
}

#[test]
fn a_mixamo_motion_drives_a_rig_whose_bones_have_no_namespace() {
    let plain = body("yup_m.fbx");
    let mixamo = body("mixamo_names.fbx");
    let motion = mixamo.motion.clone().unwrap();
    let matched = motion.bone_match(&plain.skeleton);
    assert!(matched.is_complete(), "unmatched: {:?}", matched.missing_in_skeleton);
    let mut posed = Vec::new();
    plain.pose_into(&motion, motion.duration_s(), &mut posed);
    let own = last_pose(&plain);
    let furthest = posed.iter().zip(&own).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    assert!(furthest < 1e-6, "the borrowed motion poses the body as its own does (off by {furthest} m)");
}
