//! Limits the pins make unreachable are reported as such (docs/hard-cases.md):
//! a frame whose pins are further apart than the cloth between them may
//! reach says which pins and by how much, and the summary keeps the largest
//! strain of the frames whose limits were reachable apart.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use drape::bake::summary::BakeSummary;
use drape::bake::{self, FrameRecord};
use drape::scene::Scene;

/// A 0.5 m cotton square (11 × 11 vertices) pinned along its left and right
/// edges; the right edge's pins move away at `speed` m/s from 0.2 s.
fn strip(speed: f64) -> Scene {
    let text = format!(
        r#"
[time]
fps = 30.0
duration_s = 1.0
[[garment]]
name = "cloth"
preset = "cotton"
mesh = {{ grid = {{ size_m = 0.5, resolution = 11 }} }}
translation_m = [0.0, 1.0, 0.0]
[[garment.pin]]
region = {{ min_m = [-0.26, -1.0, -1.0], max_m = [-0.24, 1.0, 1.0] }}
[[garment.pin]]
region = {{ min_m = [0.24, -1.0, -1.0], max_m = [0.26, 1.0, 1.0] }}
motion = {{ velocity_m_per_s = [{speed}, 0.0, 0.0], start_s = 0.2 }}
"#
    );
    Scene::parse(&text, "strip", Path::new("."), "strip.toml").unwrap_or_else(|e| panic!("{e}"))
}

fn bake_whole(scene: &Scene) -> Vec<FrameRecord> {
    let (records, failure) =
        bake::run(scene, scene.frame_count, &AtomicBool::new(false), |_, _| Ok(())).unwrap_or_else(|e| panic!("{e}"));
    assert!(failure.is_none(), "{failure:?}");
    records
}

/// Pins that pull the cloth up to 24 % longer than its rest width make the 1 %
/// limit unreachable: once they are further apart than 1.01 × 0.5 m, every
/// frame says so, with an excess that grows with the pull; before, none does.
#[test]
fn pins_pulled_apart_make_the_limits_unreachable_and_say_so() {
    let scene = strip(0.15);
    let records = bake_whole(&scene);
    let mut last_excess = 0.0;
    for record in &records {
        let pulled = 0.15 * (record.time_s - 0.2).max(0.0);
        // The pins' columns are 0.5 m apart at rest; the cloth between them
        // reaches 0.505 m.
        let beyond = 0.5 + pulled - 0.505;
        match record.limits_unreachable {
            Some(unreachable) => {
                assert!(beyond > 0.0, "frame {} reported unreachable {pulled:.3} m into the pull", record.frame);
                assert!((unreachable.excess_m - beyond).abs() < 1e-3, "frame {}: {unreachable:?}", record.frame);
                assert!(unreachable.excess_m >= last_excess, "the excess grows with the pull");
                last_excess = unreachable.excess_m;
                assert!((unreachable.forced_strain - beyond / 0.5).abs() < 1e-3, "{unreachable:?}");
            }
            None => assert!(beyond < 1e-3, "frame {}: {beyond:.4} m beyond reach, not reported", record.frame),
        }
    }
    assert!(last_excess > 0.05, "the pull ends {last_excess:.3} m beyond reach");
    let summary = BakeSummary::new(&scene, &records, scene.frame_count, None);
    let unreachable = records.iter().filter(|r| r.limits_unreachable.is_some()).count();
    assert_eq!(summary.frames_limits_unreachable, unreachable);
    let (frame, worst) = summary.limits_unreachable.expect("the worst pair is kept");
    assert_eq!(frame, records.last().map(|r| r.frame).unwrap_or_default());
    assert!(worst.to_string().starts_with("limits unreachable: pins "), "{worst}");
    // Beyond what the pins force, the cloth held the limits: where they were
    // reachable, and where the pins stretched it (uniformly, as far as they must).
    assert!(summary.max_free_strain_reachable <= 0.02, "{:.2} %", summary.max_free_strain_reachable * 100.0);
    let last = records.last().expect("frames were baked");
    assert!(last.max_free_strain > 0.2, "the pull stretches the cloth {:.2} %", last.max_free_strain * 100.0);
    assert!(last.free_strain_beyond_pins() <= 0.02, "{:.2} % beyond the pins", last.free_strain_beyond_pins() * 100.0);
}

/// A cloth whose pins move apart less than its limit allows never reports
/// unreachable limits, and holds them.
#[test]
fn pins_within_reach_leave_the_limits_reachable() {
    let scene = strip(0.005);
    let records = bake_whole(&scene);
    assert!(records.iter().all(|r| r.limits_unreachable.is_none()));
    let largest = records.iter().map(|r| r.max_free_strain).fold(0.0, f64::max);
    assert!(largest <= 0.02, "{:.2} %", largest * 100.0);
}
