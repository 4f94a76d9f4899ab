//! A character made of several meshes (assets/bodies/character_walk.fbx:
//! four skinned meshes, two rigid eyes on the head bone, a blend shape, two
//! animation stacks): every mesh where Blender puts it, parts and stacks
//! chosen by name, the same body on every read, and `drape body` on it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use drape::body::{Body, PartKind};
use drape::io::fbx::{BodyOptions, read_body};
use nalgebra::Vector3;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn character(options: &BodyOptions) -> Body {
    read_body(&repo("assets/bodies/character_walk.fbx"), options).unwrap_or_else(|e| panic!("{e}"))
}

/// Every 7th vertex of each mesh, by mesh name, from a fixture of tools/make_character.py.
fn fixture(frame: u32) -> BTreeMap<String, Vec<Vector3<f64>>> {
    let text =
        std::fs::read_to_string(repo(&format!("tests/fixtures/bodies/character_walk_frame_{frame:03}.obj"))).unwrap();
    let mut meshes: BTreeMap<String, Vec<Vector3<f64>>> = BTreeMap::new();
    let mut current = String::new();
    for line in text.lines() {
        if let Some(name) = line.strip_prefix("o ") {
            current = name.to_owned();
        } else if let Some(v) = line.strip_prefix("v ") {
            let c: Vec<f64> = v.split_whitespace().map(|x| x.parse().unwrap()).collect();
            meshes.entry(current.clone()).or_default().push(Vector3::new(c[0], c[1], c[2]));
        }
    }
    meshes
}

#[test]
fn every_mesh_of_the_character_is_where_blender_puts_it() {
    let body = character(&BodyOptions::default());
    let names: Vec<&str> = body.parts.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["Body", "Eye_L", "Eye_R", "Head", "Legs", "Shoes"]);
    let kinds: Vec<PartKind> = body.parts.iter().map(|p| p.kind).collect();
    use PartKind::{Rigid, Skinned};
    assert_eq!(kinds, [Skinned, Rigid, Rigid, Skinned, Skinned, Skinned]);
    let motion = body.motion.clone().unwrap();
    assert_eq!(motion.name, "Walk");
    let mut posed = Vec::new();
    for frame in [0, 17, 33, 60] {
        body.pose_into(&motion, f64::from(frame) / 30.0, &mut posed);
        for (name, expected) in fixture(frame) {
            let part = body.parts.iter().find(|p| p.name == name).unwrap();
            let ours = posed[part.first_vertex..part.first_vertex + part.points.len()].iter().step_by(7);
            assert_eq!(ours.len(), expected.len(), "frame {frame} {name}");
            let worst = ours.zip(&expected).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
            // The fixtures hold five decimals (10 µm).
            assert!(worst < 2e-5, "frame {frame}, {name}: {:.3} mm from Blender", worst * 1e3);
        }
    }
}

#[test]
fn the_blend_shape_breathes_with_the_stack() {
    let body = character(&BodyOptions::default());
    let motion = body.motion.clone().unwrap();
    let breathe = &body.parts[0].shapes[0];
    assert_eq!(breathe.name, "Breathe");
    // Keyed 0 -> 100 -> 0 % over frames 0, 49 and 98.
    let percent = |frame: f64| motion.shape_percent("Breathe", breathe.percent, frame / 30.0).unwrap();
    assert!(percent(0.0).abs() < 1e-6 && (percent(49.0) - 100.0).abs() < 1e-6, "{} {}", percent(0.0), percent(49.0));
    assert!(percent(20.0) > 10.0 && percent(20.0) < 90.0);
}

#[test]
fn stacks_and_parts_are_chosen_by_name_and_unknown_names_are_listed() {
    let idle = character(&BodyOptions { stack: Some("Idle".into()), ..Default::default() });
    let motion = idle.motion.as_ref().unwrap();
    assert_eq!((motion.name.as_str(), idle.stacks.len()), ("Idle", 2));
    assert!((motion.duration_s() - 59.0 / 30.0).abs() < 1e-6, "{}", motion.duration_s());

    let without_eyes = character(&BodyOptions { exclude: vec!["Eye_L".into(), "Eye_R".into()], ..Default::default() });
    let all = character(&BodyOptions::default());
    assert_eq!(without_eyes.parts.len(), 4);
    assert_eq!(without_eyes.mesh.vertex_count(), all.mesh.vertex_count() - 2 * 114);
    let legs = character(&BodyOptions { parts: Some(vec!["Legs".into()]), ..Default::default() });
    assert_eq!((legs.parts.len(), legs.mesh.vertex_count()), (1, 1208));

    let path = repo("assets/bodies/character_walk.fbx");
    let e = read_body(&path, &BodyOptions { stack: Some("Run".into()), ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("character_walk.fbx") && e.contains("'Run'") && e.contains("'Walk', 'Idle'"), "{e}");
    let e =
        read_body(&path, &BodyOptions { exclude: vec!["Hair".into()], ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("'Hair'") && e.contains("'Body', 'Eye_L', 'Eye_R', 'Head', 'Legs', 'Shoes'"), "{e}");
}

#[test]
fn the_rigid_eyes_ride_on_the_head() {
    let body = character(&BodyOptions::default());
    let motion = body.motion.clone().unwrap();
    let centre = |positions: &[Vector3<f64>], name: &str| {
        let part = body.parts.iter().find(|p| p.name == name).unwrap();
        let slice = &positions[part.first_vertex..part.first_vertex + part.points.len()];
        slice.iter().sum::<Vector3<f64>>() / slice.len() as f64
    };
    let (mut a, mut b) = (Vec::new(), Vec::new());
    body.pose_into(&motion, 0.0, &mut a);
    body.pose_into(&motion, 1.5, &mut b);
    // The eye travels with the walk, and keeps its distance to the head's centre.
    assert!((centre(&b, "Eye_L") - centre(&a, "Eye_L")).norm() > 0.5);
    let gap = |p: &[Vector3<f64>]| (centre(p, "Eye_L") - centre(p, "Head")).norm();
    assert!((gap(&a) - gap(&b)).abs() < 1e-3, "{} {}", gap(&a), gap(&b));
}

#[test]
fn the_same_file_gives_the_same_body_bit_for_bit() {
    let (a, b) = (character(&BodyOptions::default()), character(&BodyOptions::default()));
    let motion = a.motion.clone().unwrap();
    let (mut pa, mut pb) = (Vec::new(), Vec::new());
    a.pose_into(&motion, 0.7, &mut pa);
    b.pose_into(&motion, 0.7, &mut pb);
    assert_eq!(pa, pb);
    assert_eq!(a.mesh, b.mesh);
}

fn drape(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().unwrap()
}

#[test]
fn drape_body_lists_every_mesh_and_stack() {
    let path = repo("assets/bodies/character_walk.fbx");
    let out = drape(&["body", path.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(text.contains("6 meshes, 6350 vertices"), "{text}");
    for line in
        ["Body       2420  skinned (linear, 53 bones), blend shapes: Breathe", "Eye_L       114  rigid (under head)"]
    {
        assert!(text.contains(line), "{line}\n{text}");
    }
    assert!(text.contains("'Walk' 0.000..3.267 s (used), 'Idle' 0.000..1.967 s"), "{text}");
    let out = drape(&["body", path.to_str().unwrap(), "--stack", "Idle"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("motion 'Idle'"));

    // A file with a skeleton and no mesh is described as a motion.
    let skeleton = repo("tests/fixtures/bodies/skeleton_only.fbx");
    let out = drape(&["body", skeleton.to_str().unwrap()]);
    assert!(out.status.success() && String::from_utf8_lossy(&out.stdout).contains("no mesh: a skeleton of"));
}

#[test]
fn printing_into_a_closed_pipe_ends_quietly() {
    use std::process::{Command, Stdio};
    let path = repo("assets/bodies/character_walk.fbx");
    // The reading end closes before the body is read, so every line goes
    // into a closed pipe (as with `drape body F | head -1`).
    let mut child = Command::new(env!("CARGO_BIN_EXE_drape"))
        .args(["body", path.to_str().unwrap()])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.is_empty(), "{stderr}");
}

/// SCENES.md's skirt_walk on the character of several meshes: the waistband
/// glues to the nearest mesh (Legs), and the skirt bakes outside every mesh
/// with its own strain within 5 % (1.01 % measured, as on the one-mesh body).
#[test]
fn a_skirt_glued_to_the_characters_waist_bakes_outside_every_mesh() {
    use drape::sim::step::PinTarget;
    let scene = drape::scene::Scene::load(&repo("assets/scenes/skirt_character_walk.toml")).unwrap();
    let legs = scene.bodies[0].loaded.parts.iter().find(|p| p.name == "Legs").unwrap().triangles.clone();
    let pins = &scene.garments[0].pins;
    assert!(pins.len() > 50);
    for pin in pins {
        let PinTarget::OnMesh { triangle, .. } = pin.target else { panic!("{pin:?}") };
        assert!(legs.contains(&(triangle as usize)), "waistband vertex {} glued off the Legs", pin.vertex);
    }
    let mut baker = drape::bake::Baker::new(&scene).unwrap();
    let mut worst: f64 = 0.0;
    while baker.frame() < scene.frame_count {
        let record = baker.advance().unwrap_or_else(|e| panic!("{e}"));
        let i = &record.intersections;
        assert_eq!((i.cloth_pairs, i.collider_pairs, i.penetrating_vertices), (0, 0, 0), "frame {}", record.frame);
        worst = worst.max(record.max_free_strain);
    }
    assert!(worst < 0.05, "the skirt's own strain reached {:.2} %", worst * 100.0);
}
