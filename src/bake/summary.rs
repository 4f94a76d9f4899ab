//! The bake summary (`summary.json`): speed, solver effort, strain and contacts
//! over the whole bake and per frame.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::FrameRecord;
use crate::metrics::intersections::Intersections;
use crate::scene::Scene;
use crate::sim::adaptive::RollbackCauses;
use crate::sim::pin_reach::Unreachable;
use crate::sim::step::StageTimings;

/// Everything `summary.json` holds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BakeSummary {
    /// Scene name.
    pub scene: String,
    /// Scene file, if baked from one.
    pub scene_file: Option<String>,
    /// True when every requested frame was baked.
    pub complete: bool,
    /// Why the bake stopped early, if it did.
    pub stopped: Option<String>,
    /// Frames written, including the initial frame 0.
    pub frames: usize,
    /// Frames per second.
    pub fps: f64,
    /// Solver steps per frame.
    pub steps_per_frame: u32,
    /// Nominal solver step, s.
    pub step_s: f64,
    /// Solver steps taken per frame, on average: fewer than `steps_per_frame`
    /// where steps lengthened while the cloth was calm.
    #[serde(default)]
    pub steps_per_frame_mean: f64,
    /// The local error estimate a step longer than the nominal one could
    /// have, as a fraction of the nominal step's error in free fall (0:
    /// every step nominal).
    #[serde(default)]
    pub long_step_error: f64,
    /// Long steps rolled back for their error or their strain and retried
    /// shorter.
    #[serde(default)]
    pub long_steps_rejected: u32,
    /// Worker threads used by the solver.
    pub threads: usize,
    /// Cloth particles.
    pub vertices: usize,
    /// Springs (stretch and shear).
    pub springs: usize,
    /// Bending hinges.
    pub hinges: usize,
    /// Median wall time of the simulation per frame (no I/O), ms.
    pub ms_per_frame_median: f64,
    /// 95th percentile of the wall time per frame (nearest rank), ms.
    #[serde(default)]
    pub ms_per_frame_p95: f64,
    /// Mean wall time per frame, ms.
    pub ms_per_frame_mean: f64,
    /// Slowest frame, ms.
    pub ms_per_frame_max: f64,
    /// What a `drape bake` run took per frame it simulated, ms: from the
    /// first frame started to the last one on disk, with the independent
    /// check of every frame and the writing (none outside `drape bake`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ms_per_frame_wall: Option<f64>,
    /// Median time per frame of each pipeline stage, ms.
    pub stage_ms_per_frame_median: BTreeMap<String, f64>,
    /// Mean conjugate-gradient iterations per step.
    pub cg_iterations_per_step_mean: f64,
    /// Steps rolled back and retried at half the length (the safety net).
    pub rollbacks: u32,
    /// Why they were rolled back.
    #[serde(default)]
    pub rollback_causes: RollbackCauses,
    /// Mean Newton iterations of the inextensibility projection per step.
    pub projection_iterations_per_step_mean: f64,
    /// Steps whose projection fell back to clamping.
    pub projection_fallbacks: u32,
    /// Largest stretch (l − l₀) / l₀ at any frame end.
    pub max_strain: f64,
    /// Frame of the largest strain.
    pub max_strain_frame: usize,
    /// Largest stretch at any frame end of a stretch spring not pinned at
    /// both ends: the cloth's own strain, which the solver controls.
    #[serde(default)]
    pub max_free_strain: f64,
    /// Frame of that largest free strain.
    #[serde(default)]
    pub max_free_strain_frame: usize,
    /// The largest free strain at a frame end beyond what the pins force
    /// there ([`FrameRecord::free_strain_beyond_pins`]: all of it where the
    /// pins left the limits reachable): what the solver answers for.
    #[serde(default)]
    pub max_free_strain_reachable: f64,
    /// Frame of that largest strain beyond what the pins force.
    #[serde(default)]
    pub max_free_strain_reachable_frame: usize,
    /// Frames that ended with pins further apart than the cloth between them
    /// may reach ([`crate::sim::pin_reach`]): their limits could not be met.
    #[serde(default)]
    pub frames_limits_unreachable: usize,
    /// The worst of those pin pairs over the bake, with its frame.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits_unreachable: Option<(usize, Unreachable)>,
    /// Mean strain at the last frame.
    pub mean_strain_last: f64,
    /// Mean speed of the cloth's particles over the last second of the bake
    /// (the frames ending in it), m/s: how far from rest the drape ends.
    #[serde(default)]
    pub mean_speed_last_second_m_per_s: f64,
    /// Most particle-collider contacts in a step.
    pub contacts_max: u32,
    /// Most triangle-feature contacts (vertex-triangle and edge-edge, cloth
    /// and mesh colliders such as a body) in a frame.
    pub triangle_contacts_max: u32,
    /// Intersecting triangle pairs (cloth-cloth and cloth-collider) found by the
    /// independent checker, summed over every frame end. Zero is the promise.
    pub intersections_total: u32,
    /// Cloth vertices found inside a collider, summed over every frame end.
    pub penetrations_total: u32,
    /// Elementary collision tests run.
    pub collision_tests: u64,
    /// Elementary collision tests the same pairs would need without
    /// representative triangles.
    pub collision_tests_without_ownership: u64,
    /// Steps that needed rigid impact zones.
    pub impact_zone_steps: u32,
    /// Per-garment outputs.
    pub garments: Vec<GarmentOutput>,
    /// Per simulated frame.
    pub per_frame: Vec<FrameRow>,
}

/// A garment's files in the bake folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GarmentOutput {
    /// Garment name (the object name in the OBJ frames).
    pub name: String,
    /// Its vertices (the PC2 point count).
    pub vertices: usize,
    /// Its point cache file.
    pub pc2: String,
}

/// One simulated frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRow {
    /// Frame number.
    pub frame: usize,
    /// Simulation wall time, ms.
    pub ms: f64,
    /// Solver steps taken.
    #[serde(default)]
    pub steps: u32,
    /// Conjugate-gradient iterations over the frame.
    pub cg_iterations: u32,
    /// Cholesky factors built over the frame.
    pub factorizations: u32,
    /// Newton iterations of the inextensibility projection over the frame.
    pub projection_iterations: u32,
    /// Largest stretch at the frame end.
    pub max_strain: f64,
    /// Largest stretch at the frame end of a spring not pinned at both ends.
    #[serde(default)]
    pub max_free_strain: f64,
    /// Pins further apart at the frame end than the cloth between them may
    /// reach, when any are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits_unreachable: Option<Unreachable>,
    /// Mean strain at the frame end.
    pub mean_strain: f64,
    /// Mean speed of the cloth's particles over the frame, m/s.
    #[serde(default)]
    pub mean_speed_m_per_s: f64,
    /// Most contacts in a step.
    pub contacts: u32,
    /// Triangle-pair contacts found, summed over the frame's steps.
    pub triangle_contacts: u32,
    /// Steps of the frame that needed rigid impact zones.
    pub impact_zone_steps: u32,
    /// Crossings the collision pipeline could not resolve, summed over the
    /// frame's steps (0 unless something failed).
    pub unresolved_crossings: u32,
    /// What the independent checker found at the frame end.
    pub intersections: Intersections,
}

/// Median of `values` (0 for none).
pub fn median(values: &[f64]) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    match sorted.len() {
        0 => 0.0,
        n if n % 2 == 1 => sorted[n / 2],
        n => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
    }
}

/// The `q`-quantile of `values` by nearest rank (the smallest value with at
/// least a fraction `q` of them at or below it; 0 for none), `q` in (0, 1].
pub fn percentile(values: &[f64], q: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = (q * sorted.len() as f64).ceil() as usize;
    sorted.get(rank.max(1) - 1).copied().unwrap_or(0.0)
}

/// Mean of the frames' mean speeds over the frames that end in the last
/// second of `records`, m/s (0 for none).
fn mean_speed_over_last_second(records: &[FrameRecord]) -> f64 {
    let Some(end) = records.last().map(|r| r.time_s) else { return 0.0 };
    let last = records.iter().filter(|r| r.time_s > end - 1.0 + 1e-9);
    let (sum, count) = last.fold((0.0, 0), |(sum, count), r| (sum + r.mean_speed_m_per_s, count + 1));
    sum / f64::from(count.max(1))
}

impl BakeSummary {
    /// Summarises `records` of a bake of `scene` that asked for `requested`
    /// frames; `stopped` says why it ended early.
    pub fn new(scene: &Scene, records: &[FrameRecord], requested: usize, stopped: Option<String>) -> Self {
        let cloth = scene.cloth();
        let ms = |r: &FrameRecord| r.timings.total().as_secs_f64() * 1e3;
        let frame_ms: Vec<f64> = records.iter().map(ms).collect();
        let mut stage_ms = BTreeMap::new();
        for (k, (name, _)) in StageTimings::default().stages().iter().enumerate() {
            let per_frame: Vec<f64> = records.iter().map(|r| r.timings.stages()[k].1.as_secs_f64() * 1e3).collect();
            stage_ms.insert((*name).to_owned(), median(&per_frame));
        }
        let steps: u32 = records.iter().map(|r| r.steps).sum();
        let worst = records.iter().max_by(|a, b| a.max_strain.total_cmp(&b.max_strain));
        let worst_free = records.iter().max_by(|a, b| a.max_free_strain.total_cmp(&b.max_free_strain));
        let worst_beyond_pins =
            records.iter().max_by(|a, b| a.free_strain_beyond_pins().total_cmp(&b.free_strain_beyond_pins()));
        BakeSummary {
            scene: scene.name.clone(),
            scene_file: scene.source.as_ref().map(|p| p.display().to_string()),
            complete: stopped.is_none() && records.len() == requested,
            stopped,
            frames: records.len() + 1,
            fps: scene.fps,
            steps_per_frame: scene.steps_per_frame,
            step_s: scene.step_duration(),
            steps_per_frame_mean: f64::from(steps) / records.len().max(1) as f64,
            long_step_error: scene.long_step_error,
            long_steps_rejected: records.iter().map(|r| r.long_steps_rejected).sum(),
            threads: rayon::current_num_threads(),
            vertices: cloth.vertex_count(),
            springs: cloth.spring_count(),
            hinges: cloth.hinge_vertices.len(),
            ms_per_frame_median: median(&frame_ms),
            ms_per_frame_p95: percentile(&frame_ms, 0.95),
            ms_per_frame_mean: frame_ms.iter().sum::<f64>() / frame_ms.len().max(1) as f64,
            ms_per_frame_max: frame_ms.iter().copied().fold(0.0, f64::max),
            ms_per_frame_wall: None,
            stage_ms_per_frame_median: stage_ms,
            cg_iterations_per_step_mean: records.iter().map(|r| r.cg_iterations as f64).sum::<f64>()
                / steps.max(1) as f64,
            rollbacks: records.iter().map(|r| r.rollbacks).sum(),
            rollback_causes: records.iter().fold(RollbackCauses::default(), |mut all, r| {
                all.add(&r.rollback_causes);
                all
            }),
            projection_iterations_per_step_mean: records.iter().map(|r| r.projection_iterations as f64).sum::<f64>()
                / steps.max(1) as f64,
            projection_fallbacks: records.iter().map(|r| r.projection_fallbacks).sum(),
            max_strain: worst.map_or(0.0, |r| r.max_strain),
            max_strain_frame: worst.map_or(0, |r| r.frame),
            max_free_strain: worst_free.map_or(0.0, |r| r.max_free_strain),
            max_free_strain_frame: worst_free.map_or(0, |r| r.frame),
            max_free_strain_reachable: worst_beyond_pins.map_or(0.0, FrameRecord::free_strain_beyond_pins),
            max_free_strain_reachable_frame: worst_beyond_pins.map_or(0, |r| r.frame),
            frames_limits_unreachable: records.iter().filter(|r| r.limits_unreachable.is_some()).count(),
            limits_unreachable: records
                .iter()
                .filter_map(|r| r.limits_unreachable.map(|u| (r.frame, u)))
                .max_by(|a, b| a.1.forced_strain.total_cmp(&b.1.forced_strain)),
            mean_strain_last: records.last().map_or(0.0, |r| r.mean_strain),
            mean_speed_last_second_m_per_s: mean_speed_over_last_second(records),
            contacts_max: records.iter().map(|r| r.contacts).max().unwrap_or(0),
            triangle_contacts_max: records.iter().map(|r| r.triangle_contacts).max().unwrap_or(0),
            intersections_total: records.iter().map(|r| r.intersections.pairs()).sum(),
            penetrations_total: records.iter().map(|r| r.intersections.penetrating_vertices).sum(),
            collision_tests: records.iter().map(|r| r.collision_tests).sum(),
            collision_tests_without_ownership: records.iter().map(|r| r.collision_tests_without_ownership).sum(),
            impact_zone_steps: records.iter().map(|r| r.impact_zone_steps).sum(),
            garments: scene
                .garments
                .iter()
                .map(|g| GarmentOutput {
                    name: g.name.clone(),
                    vertices: g.mesh.vertex_count(),
                    pc2: format!("{}.pc2", g.name),
                })
                .collect(),
            per_frame: records
                .iter()
                .map(|r| FrameRow {
                    frame: r.frame,
                    ms: ms(r),
                    steps: r.steps,
                    cg_iterations: r.cg_iterations,
                    factorizations: r.factorizations,
                    projection_iterations: r.projection_iterations,
                    max_strain: r.max_strain,
                    max_free_strain: r.max_free_strain,
                    limits_unreachable: r.limits_unreachable,
                    mean_strain: r.mean_strain,
                    mean_speed_m_per_s: r.mean_speed_m_per_s,
                    contacts: r.contacts,
                    triangle_contacts: r.triangle_contacts,
                    impact_zone_steps: r.impact_zone_steps,
                    unresolved_crossings: r.unresolved_crossings,
                    intersections: r.intersections,
                })
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest strain (a waistband ring glued to stretching skin) and the
    /// cloth's own largest strain come from different frames; both are kept
    /// with their frames, per frame too.
    #[test]
    fn the_largest_strain_and_the_largest_off_the_pins_are_summarised_apart() {
        let text = "[time]\nduration_s = 0.1\n[[garment]]\nname = \"cloth\"\npreset = \"cotton\"\n\
                    mesh = { grid = { size_m = 0.2, resolution = 4 } }\n";
        let scene = Scene::parse(text, "strains", std::path::Path::new("."), "strains").expect("a valid scene");
        let record = |frame, max_strain, max_free_strain| FrameRecord {
            frame,
            steps: 2,
            max_strain,
            max_free_strain,
            ..Default::default()
        };
        let records = [record(1, 0.05, 0.009), record(2, 0.137, 0.0101), record(3, 0.08, 0.012)];
        let summary = BakeSummary::new(&scene, &records, 3, None);
        assert_eq!((summary.max_strain, summary.max_strain_frame), (0.137, 2));
        assert_eq!((summary.max_free_strain, summary.max_free_strain_frame), (0.012, 3));
        assert_eq!(summary.per_frame[0].max_free_strain, 0.009);
    }

    /// Pins beyond reach explain a frame's strain only up to what they force:
    /// a strip stretched uniformly 24 % by pins whose reach is 23 % short
    /// answers for 1 %; an edge at 601 % beside pins 0.12 % short answers
    /// for the rest (`twist`'s wound frames), as does a frame without them.
    #[test]
    fn unreachable_limits_explain_only_the_strain_the_pins_force() {
        let text = "[time]\nduration_s = 0.1\n[[garment]]\nname = \"cloth\"\npreset = \"cotton\"\n\
                    mesh = { grid = { size_m = 0.2, resolution = 4 } }\n";
        let scene = Scene::parse(text, "pins", std::path::Path::new("."), "pins").expect("a valid scene");
        let record = |frame, max_free_strain, forced_strain: Option<f64>| FrameRecord {
            frame,
            steps: 2,
            max_free_strain,
            limits_unreachable: forced_strain.map(|forced_strain| Unreachable {
                pins: [0, 3],
                excess_m: 0.0,
                forced_strain,
            }),
            ..Default::default()
        };
        let records = [record(1, 0.24, Some(0.23)), record(2, 0.012, None), record(3, 6.01, Some(0.0012))];
        assert!((records[0].free_strain_beyond_pins() - 0.01).abs() < 1e-12);
        let summary = BakeSummary::new(&scene, &records[..2], 2, None);
        assert_eq!((summary.max_free_strain_reachable, summary.max_free_strain_reachable_frame), (0.012, 2));
        let summary = BakeSummary::new(&scene, &records, 3, None);
        assert_eq!(summary.max_free_strain_reachable_frame, 3);
        assert!((summary.max_free_strain_reachable - 6.0088).abs() < 1e-12);
        assert_eq!(summary.frames_limits_unreachable, 2);
    }

    #[test]
    fn median_of_odd_and_even_counts() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 2.0, 3.0]), 2.5);
        assert_eq!(median(&[]), 0.0);
    }

    #[test]
    fn percentile_by_nearest_rank() {
        let hundred: Vec<f64> = (1..=100).rev().map(f64::from).collect();
        assert_eq!(percentile(&hundred, 0.95), 95.0);
        assert_eq!(percentile(&hundred, 1.0), 100.0);
        assert_eq!(percentile(&[7.0, 3.0], 0.95), 7.0);
        assert_eq!(percentile(&[4.0], 0.5), 4.0);
        assert_eq!(percentile(&[], 0.95), 0.0);
    }
}
