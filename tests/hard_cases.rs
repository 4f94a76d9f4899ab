//! The hard cases of SCENES.md that are not about collisions alone: large
//! steps and stiff fabric, and the reference drape: finite, no
//! intersections, energy bounded by what gravity released, and every stretch
//! edge within its fabric's strain limit (PAPER eq. 6) at every frame end.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use drape::bake;
use drape::scene::Scene;
use drape::scene::file::SceneFile;
use drape::sim::Simulator;

fn standard(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes").join(format!("{name}.toml"))
}

/// Gravitational potential energy of the cloth relative to height zero, J.
fn potential_energy(sim: &Simulator) -> f64 {
    sim.positions().iter().zip(&sim.cloth().mass).map(|(p, m)| m * 9.81 * p.y).sum()
}

/// The tolerance on a strain limit the tests allow: 0.1 % (SCENES.md).
const STRAIN_SLACK: f64 = 0.001;

/// Bakes `scene` to the end and checks at every frame end: positions
/// finite, no intersecting triangle pair or penetrating vertex (independent
/// checker), kinetic energy no more than the gravitational energy
/// released since the start (springs and damping can only take energy
/// away; a blow-up would create it), and the largest stretch within the
/// fabric's strain limit.
fn assert_finite_separate_bounded_and_limited(scene: &Scene) {
    let limit = scene.garments[0].fabric.strain_limit.expect("the standard scenes' fabrics have a strain limit");
    let mut start_energy = None;
    let (records, failure) = bake::run(scene, scene.frame_count, &AtomicBool::new(false), |sim, record| {
        assert!(sim.positions().iter().all(|p| p.iter().all(|c| c.is_finite())), "frame {}", record.frame);
        let i = &record.intersections;
        assert_eq!((i.pairs(), i.penetrating_vertices), (0, 0), "{}: frame {} intersects", scene.name, record.frame);
        let potential = potential_energy(sim);
        let released = *start_energy.get_or_insert(potential) - potential;
        let kinetic = sim.kinetic_energy();
        assert!(
            kinetic <= released.max(0.0) * 1.01 + 1e-9,
            "{}: frame {}: kinetic {kinetic} J > released {released} J",
            scene.name,
            record.frame
        );
        assert!(
            record.max_strain <= limit + STRAIN_SLACK,
            "{}: frame {}: strain {:.3} % over the limit {:.1} %",
            scene.name,
            record.frame,
            record.max_strain * 100.0,
            limit * 100.0
        );
        Ok(())
    })
    .unwrap_or_else(|e| panic!("{}: {e}", scene.name));
    assert!(failure.is_none(), "{}: {failure:?}", scene.name);
    assert_eq!(records.len(), scene.frame_count);
}

/// `large_step`: `drape_sphere` with one solver step per frame, at 30 and at
/// 24 frames per second; full size.
#[test]
fn large_steps_stay_finite_separate_bounded_and_within_the_strain_limit() {
    for fps in [30.0, 24.0] {
        let scene = Scene::load_edited(&standard("large_step"), |file: &mut SceneFile| {
            file.time.fps = fps;
        })
        .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.steps_per_frame, 1);
        assert!((scene.step_duration() - 1.0 / fps).abs() < 1e-12);
        assert_finite_separate_bounded_and_limited(&scene);
    }
}

/// `stiff`: stretch stiffness 100 × cotton swinging down from horizontal;
/// full size.
#[test]
fn stiff_fabric_stays_finite_separate_bounded_and_within_the_strain_limit() {
    let scene = Scene::load(&standard("stiff")).unwrap_or_else(|e| panic!("{e}"));
    assert_finite_separate_bounded_and_limited(&scene);
}

/// `drape_sphere` itself, full size with self-collision: the collision
/// impulses and the strain limit are met together.
#[test]
fn drape_sphere_stays_within_the_strain_limit_with_self_collision() {
    let scene = Scene::load(&standard("drape_sphere")).unwrap_or_else(|e| panic!("{e}"));
    assert!(scene.garments[0].self_collision);
    assert_finite_separate_bounded_and_limited(&scene);
}

/// A swinging cloth whose linear solve is capped (block Jacobi, 320
/// iterations) just below what a 1/30 s step needs once it swings, but not a
/// 1/60 s step: the safety net rolls those steps back, retries them halved,
/// grows back, and the bake finishes with every frame at its time.
fn capped_swing(max_iterations: u32) -> Scene {
    let text = format!(
        r#"
        [time]
        fps = 30.0
        duration_s = 1.0
        [solver]
        steps_per_frame = 1
        tolerance = 1e-6
        max_iterations = {max_iterations}
        preconditioner = "block_jacobi"
        [[garment]]
        name = "cloth"
        preset = "cotton"
        mesh = {{ grid = {{ size_m = 0.5, resolution = 16 }} }}
        translation_m = [0.0, 1.0, 0.0]
        [[garment.pin]]
        vertices = [0, 15]
        "#
    );
    Scene::parse(&text, "capped_swing", Path::new("."), "test").unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn failed_steps_are_rolled_back_retried_halved_and_the_bake_finishes() {
    let scene = capped_swing(320);
    let (records, failure) = bake::run(&scene, scene.frame_count, &AtomicBool::new(false), |sim, record| {
        assert!(sim.positions().iter().all(|p| p.iter().all(|c| c.is_finite())));
        assert!((sim.time() - record.frame as f64 / 30.0).abs() < 1e-12, "frame {} ends at its time", record.frame);
        Ok(())
    })
    .unwrap();
    assert!(failure.is_none(), "{failure:?}");
    assert_eq!(records.len(), 30);
    let rollbacks: u32 = records.iter().map(|r| r.rollbacks).sum();
    assert!(rollbacks > 0, "the capped solve never failed: the test does not test");
    let unconverged: u32 = records.iter().map(|r| r.rollback_causes.unconverged).sum();
    assert_eq!(unconverged, rollbacks, "every rollback is counted under its cause, the capped solve");
    assert!(records.iter().any(|r| r.rollbacks > 0 && r.steps == 2 && r.shortest_step_s == 1.0 / 60.0));
    assert!(records[..4].iter().all(|r| r.steps == 1 && r.rollbacks == 0), "calm frames keep the nominal step");
}

/// When even the shortest step fails, the bake stops with the frame and the
/// cause, and keeps the frames before it.
#[test]
fn a_step_that_fails_at_the_floor_stops_the_bake_with_frame_and_cause() {
    let scene = capped_swing(3);
    let (records, failure) = bake::run(&scene, scene.frame_count, &AtomicBool::new(false), |_, _| Ok(())).unwrap();
    let message = failure.expect("a 3-iteration cap cannot hold a swinging cloth").to_string();
    assert!(message.contains(&format!("frame {}", records.len() + 1)), "{message}");
    assert!(message.contains("did not converge") && message.contains("shortest allowed step"), "{message}");
}

/// A benchmark case whose simulation stops is measured over the frames
/// before the stop, with the reason, instead of ending the whole suite.
#[test]
fn a_benchmark_run_that_stops_is_measured_up_to_the_stop() {
    let scene = capped_swing(3);
    let (records, _) = bake::run(&scene, scene.frame_count, &AtomicBool::new(false), |_, _| Ok(())).unwrap();
    let (summary, _) = drape::bench::measure(&scene, None, None).expect("the run starts");
    assert!(!summary.complete);
    let why = summary.stopped.expect("the reason is kept");
    assert!(why.contains(&format!("frame {}", records.len() + 1)) && why.contains("did not converge"), "{why}");
    assert_eq!(summary.per_frame.len(), records.len(), "every frame before the stop is measured");
}
