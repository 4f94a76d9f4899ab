//! Long steps while the cloth is calm (`[solver] long_step_error`): a step
//! doubles past the nominal one, up to a frame, while backward Euler's local
//! error estimate allows it, and a long step that comes out further off is
//! taken again shorter.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use drape::bake::{self, FrameRecord};
use drape::scene::Scene;
use nalgebra::Vector3;

fn repo(path: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

/// Bakes `scene` whole: its frame records and the positions at its end.
fn bake_all(scene: &Scene) -> (Vec<FrameRecord>, Vec<Vector3<f64>>) {
    let mut end = Vec::new();
    let (records, failure) = bake::run(scene, scene.frame_count, &AtomicBool::new(false), |sim, _| {
        end = sim.positions().to_vec();
        Ok(())
    })
    .unwrap();
    assert!(failure.is_none(), "{failure:?}");
    (records, end)
}

fn steps(records: &[FrameRecord]) -> Vec<u32> {
    records.iter().map(|r| r.steps).collect()
}

/// The falling cloth's steps are as far off as the nominal step allows
/// (`½ g h²`, four times the allowed half of it at twice the length): it
/// keeps the nominal steps until it lands. Lying still it takes one step per
/// frame, and ends where the nominal steps put it, within a tenth of a
/// millimetre.
#[test]
fn a_cloth_at_rest_takes_one_step_per_frame_and_a_falling_one_the_nominal_steps() {
    let adaptive = Scene::load(&repo("tests/fixtures/scenes/settling.toml")).unwrap();
    assert_eq!(adaptive.long_step_error, 0.5, "on by default");
    let mut nominal = adaptive.clone();
    nominal.long_step_error = 0.0;

    let (long, long_end) = bake_all(&adaptive);
    let (fixed, fixed_end) = bake_all(&nominal);
    assert!(steps(&fixed).iter().all(|&s| s == 4), "without long steps: {:?}", steps(&fixed));
    let long_steps = steps(&long);
    // The cloth's lowest point reaches the ground's thickness at 0.17 s.
    assert!(long_steps[..5].iter().all(|&s| s == 4), "falling: {long_steps:?}");
    assert!(long_steps[long_steps.len() - 15..].iter().all(|&s| s == 1), "at rest: {long_steps:?}");
    let total: u32 = long_steps.iter().sum();
    assert!(total < 4 * long_steps.len() as u32 / 2, "{total} steps, half of them or fewer");

    let apart = long_end.iter().zip(&fixed_end).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
    assert!(apart < 1e-4, "ends {apart} m from the nominal steps' end");
    assert!(long_end.iter().all(|p| p.y >= 0.0), "nothing sinks into the ground");
    let strain = long.iter().map(|r| r.max_strain).fold(0.0, f64::max);
    assert!(strain < 0.0101, "largest strain {strain}");
}

/// The sphere under a settled cloth starts turning: friction speeds the
/// cloth up over a few steps, and the first long step that comes out over
/// the allowed error is taken again shorter; the frames go back to the
/// nominal steps while the cloth is carried round.
#[test]
fn a_long_step_that_comes_out_too_far_off_is_taken_again_shorter() {
    let scene = Scene::parse(
        r#"
        [time]
        fps = 30.0
        duration_s = 1.4
        [solver]
        steps_per_frame = 2
        [[garment]]
        name = "cloth"
        preset = "cotton"
        mesh = { grid = { size_m = 0.6, resolution = 16 } }
        translation_m = [0.0, 0.5, 0.0]
        [[collider]]
        name = "sphere"
        shape = { sphere = { radius_m = 0.2 } }
        position_m = [0.0, 0.25, 0.0]
        friction = 0.5
        motion = { angular_velocity_deg_per_s = [0.0, 360.0, 0.0], start_s = 1.0 }
        [[collider]]
        name = "ground"
        shape = "plane"
        "#,
        "spin",
        Path::new("."),
        "test scene",
    )
    .unwrap();
    let (records, _) = bake_all(&scene);
    let spin_frame = 30;
    let before = &records[spin_frame - 5..spin_frame];
    assert!(before.iter().all(|r| r.steps == 1), "settled before the spin: {:?}", steps(&records));
    let first = records.iter().position(|r| r.long_steps_rejected > 0);
    let first = first.unwrap_or_else(|| panic!("no long step was taken again: {:?}", steps(&records)));
    assert!(first >= spin_frame, "rejected at frame {} before the spin", first + 1);
    let carried = &records[first..first + 5];
    assert!(carried.iter().all(|r| r.steps == 2), "carried round: {:?}", steps(&records));
}
