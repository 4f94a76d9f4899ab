//! Bodies from FBX: skinning against Blender's own evaluation, the walk, motion
//! reuse, and bad files.

use std::path::{Path, PathBuf};

use drape::body::Body;
use drape::io::fbx::{FbxError, read_fbx};
use drape::sim::adaptive::{AdaptiveSettings, Stepper};
use nalgebra::Vector3;

const FPS: f64 = 30.0;

/// Fastest a walking body's centre moves forward between frames, m/s: a brisk
/// walk is ~1.5 m/s.
const MAX_WALKING_SPEED: f64 = 2.5;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn body(name: &str) -> Body {
    read_fbx(&repo(&format!("assets/bodies/{name}.fbx"))).unwrap_or_else(|e| panic!("{e}"))
}

/// Every `stride`-th vertex of a fixture written by tools/make_bodies.py.
fn fixture(path: &Path) -> Vec<Vector3<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let c: Vec<f64> = l.split_whitespace().map(|x| x.parse().unwrap()).collect();
            Vector3::new(c[0], c[1], c[2])
        })
        .collect()
}

#[test]
fn skinned_positions_match_blenders_evaluation_within_a_millimetre() {
    let body = body("female_walk");
    let motion = body.motion.clone().expect("the walk is animated");
    let mut posed = Vec::new();
    for frame in [0, 17, 33, 60] {
        let expected = fixture(&repo(&format!("tests/fixtures/bodies/female_walk_frame_{frame:03}.obj")));
        body.pose_into(&motion, f64::from(frame) / FPS, &mut posed);
        let ours: Vec<Vector3<f64>> = posed.iter().step_by(7).copied().collect();
        assert_eq!(ours.len(), expected.len(), "frame {frame}: vertex count");
        let worst = ours.iter().zip(&expected).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
        assert!(worst < 1e-3, "frame {frame}: {:.2} mm from Blender's evaluation", worst * 1e3);
    }
}

/// Lowest point of each foot (vertices left / right of the body's centre below
/// ankle height) at every frame of `motion` on `body`.
fn feet_over_time(body: &Body, motion: &drape::body::motion::Motion) -> Vec<(f64, f64, f64)> {
    let bind = body.bind_pose();
    let ankle_height = 0.12;
    let frames = (motion.duration_s() * FPS).floor() as usize;
    let mut posed = Vec::new();
    (0..=frames)
        .map(|f| {
            body.pose_into(motion, f as f64 / FPS, &mut posed);
            let lowest = |left: bool| {
                posed
                    .iter()
                    .zip(&bind)
                    .filter(|(_, b)| b.y < ankle_height && (b.x > 0.0) == left)
                    .map(|(p, _)| p.y)
                    .fold(f64::INFINITY, f64::min)
            };
            let centre_z = posed.iter().map(|p| p.z).sum::<f64>() / posed.len() as f64;
            (lowest(true), lowest(false), centre_z)
        })
        .collect()
}

#[test]
fn the_walk_keeps_a_foot_on_the_ground_and_travels_forward() {
    let body = body("female_walk");
    let motion = body.motion.clone().unwrap();
    assert!(motion.duration_s() >= 3.0, "at least three steps: {} s", motion.duration_s());
    let feet = feet_over_time(&body, &motion);
    for (frame, &(left, right, _)) in feet.iter().enumerate() {
        // The stance foot is the lower one: within 3 cm of the ground, never below it by more than 5 mm.
        let stance = left.min(right);
        assert!(stance.abs() < 0.03 && stance > -0.005, "frame {frame}: stance foot at {stance:.3} m");
    }
    // Both feet take turns: each is lifted more than 5 cm at some point.
    assert!(feet.iter().any(|f| f.0 > 0.05) && feet.iter().any(|f| f.1 > 0.05));
    let travelled = feet.last().unwrap().2 - feet[0].2;
    assert!(travelled > 2.0, "the body walks forward (+Z): {travelled:.2} m");
    // The planted foot carries the body forward smoothly: it never steps
    // back (the root once jumped 10 cm back at every step, where the lowest
    // point of the stance foot passed from its heel to its ball).
    for (frame, pair) in feet.windows(2).enumerate() {
        let speed = (pair[1].2 - pair[0].2) * FPS;
        assert!((0.0..MAX_WALKING_SPEED).contains(&speed), "frame {frame}: the body moves at {speed:.2} m/s");
    }

    let in_place = read_fbx(&repo("assets/bodies/female_walk_inplace.fbx")).unwrap();
    let feet = feet_over_time(&in_place, in_place.motion.as_ref().unwrap());
    assert!((feet.last().unwrap().2 - feet[0].2).abs() < 0.1, "the in-place walk stays put");
}

#[test]
fn a_walk_reused_on_another_body_moves_the_same_bones() {
    let female = body("female_walk");
    let male = body("male_walk");
    let walk = female.motion.clone().unwrap();
    let matched = walk.bone_match(&male.skeleton);
    assert!(matched.is_complete(), "{:?}", matched.missing_in_skeleton);
    // Every bone the walk turns turns on the male body too, and the male's feet stay grounded.
    let moved = |body: &Body| -> Vec<String> {
        let (a, b) = (
            walk.pose(&body.skeleton, 0.0, body.skeleton_height()),
            walk.pose(&body.skeleton, 0.4, body.skeleton_height()),
        );
        body.skeleton
            .bones
            .iter()
            .zip(a.iter().zip(&b))
            .filter(|(_, (x, y))| (x.rotation_deg - y.rotation_deg).norm() > 1.0)
            .map(|(bone, _)| bone.name.clone())
            .collect()
    };
    assert_eq!(moved(&male), moved(&female));
    assert!(moved(&male).len() >= 10);
    let feet = feet_over_time(&male, &walk);
    let worst = feet.iter().map(|f| f.0.min(f.1).abs()).fold(0.0, f64::max);
    assert!(worst < 0.04, "reused walk: stance foot up to {worst:.3} m off the ground");
    assert!(feet.last().unwrap().2 - feet[0].2 > 2.0);

    let mut renamed = male.skeleton.clone();
    let thigh = renamed.find("thigh_l").unwrap();
    renamed.bones[thigh].name = "LeftUpLeg".into();
    let report = walk.bone_match(&renamed);
    assert!(report.missing_in_skeleton.contains(&"thigh_l".to_owned()), "{report:?}");
    assert!(!report.is_complete());
}

#[test]
fn a_mesh_without_skin_is_a_static_body() {
    let body = read_fbx(&repo("tests/fixtures/bodies/static_box.fbx")).unwrap();
    assert!(body.motion.is_none());
    assert_eq!(body.mesh.triangles.len(), 12);
    let (low, high) = body.mesh.bounds().unwrap();
    // A 0.5 m cube standing on the ground (Blender Z up, converted to Y up).
    assert!((high - low - Vector3::repeat(0.5)).norm() < 1e-6, "{low} {high}");
    assert!(low.y.abs() < 1e-6);
}

#[test]
fn bad_fbx_files_get_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    };
    let ascii = write("ascii.fbx", b"; FBX 7.4.0 project file\n; ----\nFBXHeaderExtension:  {\n}\n");
    let e = read_fbx(&ascii).unwrap_err();
    assert!(matches!(e, FbxError::NoMesh { .. }) && e.to_string().contains("ascii.fbx has no polygon mesh"), "{e}");
    let old = write("old.fbx", b"; FBX 6.1.0 project file\nFBXHeaderExtension:  {\n}\n");
    let e = read_fbx(&old).unwrap_err();
    assert!(matches!(e, FbxError::OldVersion { version: 6100, .. }) && e.to_string().contains("FBX 7.4"), "{e}");

    let full = std::fs::read(repo("assets/bodies/female_walk.fbx")).unwrap();
    let truncated = write("truncated.fbx", &full[..full.len() / 3]);
    let e = read_fbx(&truncated).unwrap_err();
    assert!(matches!(e, FbxError::Malformed { .. }) && e.to_string().contains("truncated.fbx"), "{e}");

    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let noise: Vec<u8> = (0..4096)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state as u8
        })
        .collect();
    let e = read_fbx(&write("noise.fbx", &noise)).unwrap_err();
    assert!(matches!(e, FbxError::NotFbx { .. }), "{e}");

    let e = read_fbx(&repo("tests/fixtures/bodies/skeleton_only.fbx")).unwrap_err();
    assert!(matches!(e, FbxError::NoMesh { .. }) && e.to_string().contains("skeleton_only.fbx"), "{e}");

    let e = read_fbx(&dir.path().join("absent.fbx")).unwrap_err();
    assert!(matches!(e, FbxError::Read { .. }) && e.to_string().contains("absent.fbx"), "{e}");
}

fn drape_cli(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_drape")).args(args).output().expect("the drape binary runs")
}

#[test]
fn a_motion_cache_plays_the_body_it_was_made_from() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("walk.motion");
    let fbx = repo("assets/bodies/female_walk.fbx");
    let out = drape_cli(&["import-motion", fbx.to_str().unwrap(), "--out", cache.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let scene_text = |file: &str| {
        format!(
            "[time]\nduration_s = 1.0\n[[body]]\nfile = \"{file}\"\n[[garment]]\nname = \"cloth\"\npreset = \"cotton\"\n\
             mesh = {{ grid = {{ size_m = 0.2, resolution = 4 }} }}\ntranslation_m = [0.0, 2.5, 0.0]\n"
        )
    };
    let from_cache = drape::scene::Scene::parse(&scene_text("walk.motion"), "cached", dir.path(), "cached").unwrap();
    let from_fbx = drape::scene::Scene::parse(&scene_text(fbx.to_str().unwrap()), "fbx", dir.path(), "fbx").unwrap();
    let (a, b) = (&from_cache.mesh_colliders[0], &from_fbx.mesh_colliders[0]);
    for t in [0.0, 0.5, 0.9] {
        let worst =
            a.world_vertices(t).iter().zip(b.world_vertices(t)).map(|(p, q)| (p - q).norm()).fold(0.0, f64::max);
        assert!(worst < 1e-5, "t = {t}: the cache is {worst} m from skinning (f32 storage)");
    }
    // The body moves: it is a deforming collider, not a static one.
    assert!((a.world_vertices(0.0)[0] - a.world_vertices(0.9)[0]).norm() > 0.1);
}

/// The whole walk: never inside the body or itself, and never snagged. Where
/// a leg swings through the hem, a step can carry a few hem particles with
/// the calf, through impact zones or impulses (398 % strain for a frame once).
/// The projections between collision passes keep the cloth off the body, and
/// a step that raises the largest strain by more than 25 points is retried
/// shorter: the largest strain at a frame end stays under 20 % (13.7 %
/// measured: the waistband ring, stretched by the skin it is glued to; 32 %
/// where the body blended into the walk in 0.5 s, 79 % at frame 42 without
/// the retries, in a bake before the strain projection's factor was
/// mended), and every edge with an end off the waistband within cotton's
/// 1 % limit, give or take 0.5 points (1.02 % measured).
#[test]
fn skirt_walk_bakes_with_the_skirt_outside_the_body_at_every_frame() {
    let scene = drape::scene::Scene::load(&repo("assets/scenes/skirt_walk.toml")).unwrap();
    let mut baker = drape::bake::Baker::new(&scene).unwrap();
    let count = scene.garments[0].mesh.vertex_count() as f64;
    let centre = |p: &[Vector3<f64>]| p.iter().sum::<Vector3<f64>>() / count;
    let start = centre(baker.simulator().positions());
    while baker.frame() < scene.frame_count {
        let record = baker.advance().unwrap_or_else(|e| panic!("{e}"));
        let i = &record.intersections;
        assert_eq!((i.cloth_pairs, i.collider_pairs, i.penetrating_vertices), (0, 0, 0), "frame {}", record.frame);
        assert!(
            record.max_strain < 0.2,
            "frame {}: the hem snagged, {:.0} % strain",
            record.frame,
            record.max_strain * 100.0
        );
        assert!(record.max_free_strain < 0.015, "frame {}: {}", record.frame, record.max_free_strain);
    }
    let end = centre(baker.simulator().positions());
    assert!(end.z - start.z > 2.0, "the skirt travels with the body: {:.2} m", end.z - start.z);
}

/// The walk played three times as fast (SCENES.md's `fast_body`): the skirt
/// stays outside the body at every frame end. Here legs cross the hem faster
/// than a step's first impulse passes resolve it; the strain projections
/// between passes take what they pushed back, the correction after impact
/// zones moves the cloth after them, and a step that still raises the
/// cloth's own strain by more than 25 points would be retried shorter
/// (tested below). Every edge with an end off the waistband stays within its
/// limit and a point (1.01 % measured; 3.85 % while the projections took the
/// waistband's edges, stretched by the body and out of their reach, for a
/// stall; 26.5 % at frame 16 when the retry looked at the largest strain of
/// all, the waistband's 13.7 %, and so missed a rise from 1 %), the
/// waistband under 20 % (13.7 %).
#[test]
fn fast_body_keeps_the_skirt_outside_the_body_and_the_cloth_within_its_limit() {
    let scene = drape::scene::Scene::load(&repo("assets/scenes/fast_body.toml")).unwrap();
    let mut baker = drape::bake::Baker::new(&scene).unwrap();
    while baker.frame() < scene.frame_count {
        let record = baker.advance().unwrap_or_else(|e| panic!("{e}"));
        let i = &record.intersections;
        assert_eq!((i.cloth_pairs, i.collider_pairs, i.penetrating_vertices), (0, 0, 0), "frame {}", record.frame);
        assert!(record.max_free_strain < 0.0201, "frame {}: {:.2} %", record.frame, record.max_free_strain * 100.0);
        assert!(record.max_strain < 0.2, "frame {}: {:.1} %", record.frame, record.max_strain * 100.0);
    }
}

/// With a snag strain of half a point, the walk's steps that stretch
/// the skirt more are rolled back and retried shorter: frames with a retry
/// take more, shorter steps, and in frames without one no step raised the
/// cloth's own largest strain (off the waistband) by more than the bound.
#[test]
fn steps_that_snag_the_skirt_on_the_walking_body_are_retried_shorter() {
    const SNAG_STRAIN: f64 = 0.005;
    let scene = drape::scene::Scene::load(&repo("assets/scenes/skirt_walk.toml")).unwrap();
    let mut sim = scene.simulator().unwrap();
    let settings = AdaptiveSettings { snag_strain: SNAG_STRAIN, ..AdaptiveSettings::default() };
    let mut stepper = Stepper::new(scene.step_duration(), settings);
    let mut snagged = 0;
    for frame in 0..45 {
        let (_, mut before) = sim.largest_strains();
        let mut largest_rise = f64::MIN;
        let advance = stepper
            .advance(&mut sim, scene.steps_per_frame, |report| {
                largest_rise = largest_rise.max(report.max_free_strain - before);
                before = report.max_free_strain;
            })
            .unwrap_or_else(|e| panic!("frame {frame}: {e}"));
        assert_eq!(advance.rollbacks, advance.causes.snagged, "frame {frame}: {advance:?}");
        if advance.rollbacks == 0 {
            assert!(largest_rise <= SNAG_STRAIN, "frame {frame}: a step raised the strain {largest_rise}");
        } else {
            assert!(advance.steps > scene.steps_per_frame && advance.shortest_step_s < scene.step_duration());
        }
        snagged += advance.causes.snagged;
    }
    assert!(snagged > 0, "no step snagged: the test does not test");
}

#[test]
fn a_body_sampled_over_an_absurdly_long_scene_is_refused_before_allocating() {
    let fbx = repo("assets/bodies/female_walk.fbx");
    let text = format!(
        "[time]\nfps = 1000.0\nduration_s = 36000.0\n[[body]]\nfile = \"{}\"\n[[garment]]\nname = \"cloth\"\n\
         preset = \"cotton\"\nmesh = {{ grid = {{ size_m = 0.2, resolution = 4 }} }}\n",
        fbx.display()
    );
    let e = drape::scene::Scene::parse(&text, "long", Path::new("."), "long.toml").unwrap_err().to_string();
    assert!(e.contains("long.toml") && e.contains("GB") && e.contains("import-motion"), "{e}");
}
