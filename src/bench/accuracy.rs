//! Speed against error (SCENES.md, "Error against a reference"): a scene run
//! over a grid of steps per frame and solver tolerances, each run timed and
//! compared with a reference run of 16× smaller steps and tolerance 1e-10.
//!
//! The error of a run is the RMS over vertices of `|x − x_ref|` divided by
//! the cloth's rest diagonal, averaged over the frames of the first 0.5 s
//! after the reference's first contact (before folds make the motion
//! chaotic; every frame if it never touches anything), and, for static
//! scenes, separately at the last frame (the end state). The reference keeps
//! only those frames and stops at the end of the window unless the end state
//! is wanted; runs are compared frame by frame as they end ([`ErrorMeter`]).
//! Runs no other run beats on both speed and contact-window error form the
//! Pareto front.

use std::fmt::Write as _;
use std::ops::RangeInclusive;
use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::Vector3;

use crate::bake::summary::BakeSummary;
use crate::bake::{self, BakeError};

use crate::scene::Scene;

/// The reference uses this many times the scene's steps per frame.
pub const REFERENCE_REFINEMENT: u32 = 16;
/// The reference's linear-solver tolerance.
pub const REFERENCE_TOLERANCE: f64 = 1e-10;
/// Length of the window after first contact over which errors are averaged, s.
pub const CONTACT_WINDOW_S: f64 = 0.5;
/// Slack when comparing frame times with the window's end, s.
const TIME_SLACK_S: f64 = 1e-9;

/// Which errors a reference run is kept for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorMeasure {
    /// The contact window only.
    ContactWindow,
    /// The contact window and the last frame (the end state of a static scene).
    WithEndState,
}

/// A reference run of a scene ([`REFERENCE_REFINEMENT`]× smaller steps,
/// tolerance [`REFERENCE_TOLERANCE`]), its positions kept at the frames errors
/// are measured on.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Frames of the contact window (every frame after the initial one if
    /// the reference never touches anything).
    window: RangeInclusive<usize>,
    /// Positions at each frame of the window, m.
    window_frames: Vec<Vec<Vector3<f64>>>,
    /// The last frame and its positions, when the end state is measured.
    end: Option<(usize, Vec<Vector3<f64>>)>,
    /// Diagonal of the cloth's rest bounding box, m.
    diagonal_m: f64,
}

/// A run's errors against a reference, relative to the cloth's rest diagonal.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunErrors {
    /// Mean relative RMS error over the contact window, unitless; `None`
    /// unless the run ended every frame of the window.
    pub contact: Option<f64>,
    /// Relative RMS error at the last frame, if measured, unitless.
    pub end: Option<f64>,
}

/// One point of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct AccuracyPoint {
    /// Solver steps per 1/fps frame.
    pub steps_per_frame: u32,
    /// Linear-solver relative tolerance.
    pub tolerance: f64,
    /// Median wall time of the simulation per frame, ms.
    pub ms_per_frame: f64,
    /// Mean relative RMS error over the contact window, unitless.
    pub contact_error: f64,
    /// Relative RMS error at the last frame, if measured, unitless.
    pub end_error: Option<f64>,
    /// Largest stretch strain of the run, unitless.
    pub max_strain: f64,
    /// Whether no other point is both faster and more accurate.
    pub pareto: bool,
}

/// `scene` with `steps_per_frame` solver steps per frame and linear-solver
/// tolerance `tolerance`.
pub fn variant(scene: &Scene, steps_per_frame: u32, tolerance: f64) -> Scene {
    let mut variant = scene.clone();
    variant.steps_per_frame = steps_per_frame;
    variant.solver.tolerance = tolerance;
    variant
}

/// `scene` as its reference runs it: [`REFERENCE_REFINEMENT`]× the steps per
/// frame, tolerance [`REFERENCE_TOLERANCE`], and never a step longer than
/// that.
pub fn reference_scene(scene: &Scene) -> Scene {
    let mut reference = variant(scene, scene.steps_per_frame.saturating_mul(REFERENCE_REFINEMENT), REFERENCE_TOLERANCE);
    reference.long_step_error = 0.0;
    reference
}

impl Reference {
    /// Runs the reference of `scene` over at most `frames` frames: until the
    /// end of the contact window (the first [`CONTACT_WINDOW_S`] after the
    /// first frame that ends in contact with a collider or the cloth itself;
    /// the whole run if there is none), or to the last frame for
    /// [`ErrorMeasure::WithEndState`].
    pub fn run(scene: &Scene, frames: usize, measure: ErrorMeasure) -> Result<Reference, BakeError> {
        let diagonal_m = rest_diagonal(scene)?;
        let refined = reference_scene(scene);
        let frame_s = scene.frame_duration();
        let stop = AtomicBool::new(false);
        // Frames before the first contact, kept in case there is none.
        let mut before_contact = Vec::new();
        let mut window_frames = Vec::new();
        // The first frame in contact and the time its window closes, s.
        let mut window: Option<(usize, f64)> = None;
        let mut end = None;
        let (_, failure) = bake::run(&refined, frames, &stop, |sim, record| {
            if window.is_none() && record.contacts + record.triangle_contacts > 0 {
                window = Some((record.frame, record.time_s + CONTACT_WINDOW_S));
                before_contact = Vec::new();
            }
            match window {
                None => before_contact.push(sim.positions().to_vec()),
                Some((_, until)) if record.time_s <= until + TIME_SLACK_S => {
                    window_frames.push(sim.positions().to_vec());
                    let closes = record.time_s + frame_s > until + TIME_SLACK_S;
                    if closes && measure == ErrorMeasure::ContactWindow {
                        stop.store(true, Ordering::Relaxed);
                    }
                }
                Some(_) => {}
            }
            if record.frame == frames && measure == ErrorMeasure::WithEndState {
                end = Some((record.frame, sim.positions().to_vec()));
            }
            Ok(())
        })?;
        if let Some(failure) = failure {
            return Err(failure);
        }
        let window = match window {
            Some((first, _)) => first..=first + window_frames.len() - 1,
            None => {
                // No contact: every frame but the initial one, which no run can miss.
                window_frames = before_contact.split_off(1.min(before_contact.len()));
                1..=window_frames.len()
            }
        };
        Ok(Reference { window, window_frames, end, diagonal_m })
    }

    /// Frames a run must cover to be measured against this reference.
    pub fn frames_needed(&self) -> usize {
        self.end.as_ref().map_or(*self.window.end(), |(frame, _)| *frame)
    }

    /// The frames of the contact window (every frame after the initial one
    /// if the reference never touches anything).
    pub fn contact_window(&self) -> RangeInclusive<usize> {
        self.window.clone()
    }

    /// A meter of one run's errors against this reference.
    pub fn meter(&self) -> ErrorMeter<'_> {
        ErrorMeter { reference: self, window_sum: 0.0, window_frames: 0, end: None }
    }
}

/// Accumulates a run's errors against a reference as its frames end.
#[derive(Clone, Debug)]
pub struct ErrorMeter<'a> {
    reference: &'a Reference,
    window_sum: f64,
    window_frames: usize,
    end: Option<f64>,
}

impl ErrorMeter<'_> {
    /// Compares the run's `positions` (m) at the end of frame `frame`.
    pub fn record(&mut self, frame: usize, positions: &[Vector3<f64>]) {
        let reference = self.reference;
        if reference.window.contains(&frame) {
            let expected = &reference.window_frames[frame - reference.window.start()];
            debug_assert_eq!(positions.len(), expected.len(), "a run of another cloth");
            self.window_sum += relative_rms(positions, expected, reference.diagonal_m);
            self.window_frames += 1;
        }
        if let Some((last, expected)) = &reference.end
            && *last == frame
        {
            debug_assert_eq!(positions.len(), expected.len(), "a run of another cloth");
            self.end = Some(relative_rms(positions, expected, reference.diagonal_m));
        }
    }

    /// The errors of the frames recorded so far.
    pub fn errors(&self) -> RunErrors {
        let complete = self.window_frames > 0 && self.window_frames == self.reference.window.clone().count();
        RunErrors { contact: complete.then(|| self.window_sum / self.window_frames as f64), end: self.end }
    }
}

/// RMS over vertices of `|a − b|`, divided by `scale`.
pub fn relative_rms(a: &[Vector3<f64>], b: &[Vector3<f64>], scale: f64) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(p, q)| (p - q).norm_squared()).sum();
    (sum / a.len().max(1) as f64).sqrt() / scale
}

/// Marks the points no other point beats on both speed and contact error.
pub fn mark_pareto(points: &mut [AccuracyPoint]) {
    for k in 0..points.len() {
        let p = &points[k];
        let dominated = points.iter().any(|q| {
            q.ms_per_frame <= p.ms_per_frame
                && q.contact_error <= p.contact_error
                && (q.ms_per_frame < p.ms_per_frame || q.contact_error < p.contact_error)
        });
        points[k].pareto = !dominated;
    }
}

/// Length of the diagonal of the box around the cloth's rest positions, m.
pub fn rest_diagonal(scene: &Scene) -> Result<f64, BakeError> {
    let simulator = scene.simulator()?;
    let rest = &simulator.cloth().rest_positions;
    let (lo, hi) =
        rest.iter().fold((Vector3::repeat(f64::INFINITY), Vector3::repeat(f64::NEG_INFINITY)), |(lo, hi), p| {
            (lo.inf(p), hi.sup(p))
        });
    Ok((hi - lo).norm())
}

/// Runs the reference, then every combination of `steps` and `tolerances`
/// over the frames the errors need (to the end of the contact window, or of
/// the scene for the end state: speed is the median over those frames),
/// logging each run as it starts. A run that fails, or ends before the
/// window does, is logged and left out. Returns the points, Pareto front
/// marked; fails only if the reference does.
pub fn sweep(
    scene: &Scene,
    steps: &[u32],
    tolerances: &[f64],
    frames: Option<usize>,
    measure: ErrorMeasure,
    log: impl Fn(&str),
) -> Result<Vec<AccuracyPoint>, BakeError> {
    let frames = frames.map_or(scene.frame_count, |n| n.min(scene.frame_count));
    let reference_steps = scene.steps_per_frame * REFERENCE_REFINEMENT;
    log(&format!(
        "{}: reference, {reference_steps} steps per frame, tolerance {REFERENCE_TOLERANCE:e} ...",
        scene.name
    ));
    let reference = Reference::run(scene, frames, measure)?;
    let mut points = Vec::new();
    for &steps_per_frame in steps {
        for &tolerance in tolerances {
            log(&format!("{}: {steps_per_frame} steps per frame, tolerance {tolerance:e} ...", scene.name));
            let run = variant(scene, steps_per_frame, tolerance);
            let (summary, contact, end) = match super::measure(&run, Some(reference.frames_needed()), Some(&reference))
            {
                Ok((BakeSummary { stopped: Some(why), .. }, _)) => {
                    log(&format!("{}: that run failed ({why}); left out", scene.name));
                    continue;
                }
                Ok((summary, Some(RunErrors { contact: Some(contact), end }))) => (summary, contact, end),
                Ok(_) => {
                    log(&format!("{}: that run ended before the contact window did; left out", scene.name));
                    continue;
                }
                Err(failure) => {
                    log(&format!("{}: that run failed ({failure}); left out", scene.name));
                    continue;
                }
            };
            points.push(AccuracyPoint {
                steps_per_frame,
                tolerance,
                ms_per_frame: summary.ms_per_frame_median,
                contact_error: contact,
                end_error: end,
                max_strain: summary.max_strain,
                pareto: false,
            });
        }
    }
    mark_pareto(&mut points);
    Ok(points)
}

/// The sweep as a Markdown table, Pareto points marked.
pub fn markdown_table(points: &[AccuracyPoint]) -> String {
    let mut out = String::from(
        "| steps/frame | tolerance | ms/frame (median over the frames run) | error, contact window | error, end \
         | max strain | Pareto |\n\
         |---:|---:|---:|---:|---:|---:|:---:|\n",
    );
    for p in points {
        let _ = writeln!(
            out,
            "| {} | {:e} | {:.1} | {:.2e} | {} | {:.2} % | {} |",
            p.steps_per_frame,
            p.tolerance,
            p.ms_per_frame,
            p.contact_error,
            p.end_error.map_or("-".into(), |e| format!("{e:.2e}")),
            p.max_strain * 100.0,
            if p.pareto { "●" } else { "" }
        );
    }
    out
}

/// One scene's sweep.
pub type SceneSweep = (String, Vec<AccuracyPoint>);

/// The sweeps as CSV, one row per scene and point.
pub fn csv(sweeps: &[SceneSweep]) -> String {
    let mut out =
        String::from("scene,steps_per_frame,tolerance,ms_per_frame,contact_error,end_error,max_strain,pareto\n");
    for (scene, points) in sweeps {
        for p in points {
            let _ = writeln!(
                out,
                "{scene},{},{:e},{:.4},{:.6e},{},{:.6},{}",
                p.steps_per_frame,
                p.tolerance,
                p.ms_per_frame,
                p.contact_error,
                p.end_error.map_or(String::new(), |e| format!("{e:.6e}")),
                p.max_strain,
                p.pareto
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(ms: f64, error: f64) -> AccuracyPoint {
        AccuracyPoint {
            steps_per_frame: 1,
            tolerance: 1e-3,
            ms_per_frame: ms,
            contact_error: error,
            end_error: None,
            max_strain: 0.0,
            pareto: false,
        }
    }

    #[test]
    fn relative_rms_is_the_rms_distance_over_the_scale() {
        let a = [Vector3::zeros(), Vector3::zeros()];
        let b = [Vector3::new(3.0, 4.0, 0.0), Vector3::zeros()];
        // RMS = sqrt((25 + 0) / 2).
        assert!((relative_rms(&a, &b, 2.0) - (12.5f64).sqrt() / 2.0).abs() < 1e-15);
        assert_eq!(relative_rms(&a, &a, 1.0), 0.0);
    }

    #[test]
    fn the_meter_averages_over_the_window_and_reads_the_end_frame() {
        let at = |x: f64| vec![Vector3::new(x, 0.0, 0.0)];
        let reference = Reference {
            window: 2..=3,
            window_frames: vec![at(0.0), at(0.0)],
            end: Some((5, at(1.0))),
            diagonal_m: 2.0,
        };
        let mut meter = reference.meter();
        for (frame, x) in [(1, 9.0), (2, 0.2), (3, 0.6), (4, 9.0), (5, 1.5)] {
            meter.record(frame, &at(x));
        }
        let errors = meter.errors();
        // Window: (0.2 + 0.6) / 2 over the diagonal 2; end: 0.5 / 2.
        assert!((errors.contact.unwrap() - 0.2).abs() < 1e-15, "{errors:?}");
        assert_eq!(errors.end, Some(0.25));
        assert_eq!(reference.frames_needed(), 5);
        let mut partial = reference.meter();
        partial.record(2, &at(0.2));
        assert_eq!(partial.errors().contact, None, "frame 3 of the window is missing");
    }

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let mut points = vec![point(10.0, 1e-2), point(20.0, 1e-3), point(30.0, 1e-2), point(20.0, 5e-3)];
        mark_pareto(&mut points);
        let front: Vec<bool> = points.iter().map(|p| p.pareto).collect();
        assert_eq!(front, [true, true, false, false]);
    }
}
