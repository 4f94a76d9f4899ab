//! Speed against error (SCENES.md, "Error against a reference"): a scene run
//! over a grid of steps per frame and solver tolerances, each run timed and
//! compared with a reference run of 16× smaller steps and tolerance 1e-10.
//!
//! The error of a run is the RMS over vertices of `|x − x_ref|` divided by
//! the cloth's rest diagonal, averaged over the frames of the first 0.5 s
//! after the reference's first contact (before folds make the motion
//! chaotic), and separately at the last frame (the end state of a static
//! scene). Runs no other run beats on both speed and contact-window error
//! form the Pareto front.

use std::fmt::Write as _;
use std::sync::atomic::AtomicBool;

use nalgebra::Vector3;

use super::plots::PlotError;
use crate::bake::summary::BakeSummary;
use crate::bake::{self, BakeError};
use crate::io::atomic::{WriteError, write_file};
use crate::scene::Scene;

/// The reference uses this many times the scene's steps per frame.
pub const REFERENCE_REFINEMENT: u32 = 16;
/// The reference's linear-solver tolerance.
pub const REFERENCE_TOLERANCE: f64 = 1e-10;
/// Length of the window after first contact over which errors are averaged, s.
pub const CONTACT_WINDOW_S: f64 = 0.5;

/// Every frame's cloth positions of one run, with what the run measured.
#[derive(Clone, Debug)]
pub struct Trajectory {
    /// Positions at every frame end, frame 0 (the initial state) first, m.
    pub frames: Vec<Vec<Vector3<f64>>>,
    /// Frame times, s.
    pub times: Vec<f64>,
    /// First frame at whose end the cloth touches a collider or itself.
    pub first_contact: Option<usize>,
    /// Speed, strain and effort of the run.
    pub summary: BakeSummary,
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
    /// Relative RMS error at the last frame, unitless.
    pub end_error: f64,
    /// Largest stretch strain of the run, unitless.
    pub max_strain: f64,
    /// Whether no other point is both faster and more accurate.
    pub pareto: bool,
}

/// Runs `scene` with `steps_per_frame` and `tolerance` (the first `frames`
/// frames) and keeps every frame's positions.
pub fn trajectory(scene: &Scene, steps_per_frame: u32, tolerance: f64, frames: usize) -> Result<Trajectory, BakeError> {
    let mut variant = scene.clone();
    variant.steps_per_frame = steps_per_frame;
    variant.solver.tolerance = tolerance;
    let mut positions = Vec::with_capacity(frames + 1);
    let mut times = Vec::with_capacity(frames + 1);
    let mut first_contact = None;
    let (records, failure) = bake::run(&variant, frames, &AtomicBool::new(false), |sim, record| {
        if first_contact.is_none() && record.contacts + record.triangle_contacts > 0 {
            first_contact = Some(record.frame);
        }
        positions.push(sim.positions().to_vec());
        times.push(record.time_s);
        Ok(())
    })?;
    if let Some(failure) = failure {
        return Err(failure);
    }
    let summary = BakeSummary::new(&variant, &records, frames, None);
    Ok(Trajectory { frames: positions, times, first_contact, summary })
}

/// RMS over vertices of `|a − b|`, divided by `scale`.
pub fn relative_rms(a: &[Vector3<f64>], b: &[Vector3<f64>], scale: f64) -> f64 {
    let sum: f64 = a.iter().zip(b).map(|(p, q)| (p - q).norm_squared()).sum();
    (sum / a.len().max(1) as f64).sqrt() / scale
}

/// The frames the contact-window error averages over: from the reference's
/// first contact for [`CONTACT_WINDOW_S`] (the whole run if it never touches).
pub fn contact_window(reference: &Trajectory) -> std::ops::RangeInclusive<usize> {
    let last = reference.frames.len() - 1;
    let Some(start) = reference.first_contact else { return 0..=last };
    let end_time = reference.times[start] + CONTACT_WINDOW_S;
    let end = (start..=last).take_while(|&f| reference.times[f] <= end_time + 1e-9).last().unwrap_or(start);
    start..=end
}

/// Contact-window and end errors of `run` against `reference`, relative to
/// the rest diagonal `diagonal` (m).
pub fn errors(run: &Trajectory, reference: &Trajectory, diagonal: f64) -> (f64, f64) {
    let window = contact_window(reference);
    let count = window.clone().count() as f64;
    let windowed: f64 =
        window.map(|f| relative_rms(&run.frames[f], &reference.frames[f], diagonal)).sum::<f64>() / count;
    let last = reference.frames.len() - 1;
    (windowed, relative_rms(&run.frames[last], &reference.frames[last], diagonal))
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

/// Runs the reference, then every combination of `steps` and `tolerances`,
/// logging each run as it starts. Returns the points, Pareto front marked.
pub fn sweep(
    scene: &Scene,
    steps: &[u32],
    tolerances: &[f64],
    frames: Option<usize>,
    log: impl Fn(&str),
) -> Result<Vec<AccuracyPoint>, BakeError> {
    let frames = frames.map_or(scene.frame_count, |n| n.min(scene.frame_count));
    let diagonal = rest_diagonal(scene)?;
    let reference_steps = scene.steps_per_frame * REFERENCE_REFINEMENT;
    log(&format!("reference: {reference_steps} steps per frame, tolerance {REFERENCE_TOLERANCE:e} ..."));
    let reference = trajectory(scene, reference_steps, REFERENCE_TOLERANCE, frames)?;
    let mut points = Vec::new();
    for &steps_per_frame in steps {
        for &tolerance in tolerances {
            log(&format!("{steps_per_frame} steps per frame, tolerance {tolerance:e} ..."));
            let run = trajectory(scene, steps_per_frame, tolerance, frames)?;
            let (contact_error, end_error) = errors(&run, &reference, diagonal);
            points.push(AccuracyPoint {
                steps_per_frame,
                tolerance,
                ms_per_frame: run.summary.ms_per_frame_median,
                contact_error,
                end_error,
                max_strain: run.summary.max_strain,
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
        "| steps/frame | tolerance | ms/frame (median) | error, contact window | error, end | max strain | Pareto |\n\
         |---:|---:|---:|---:|---:|---:|:---:|\n",
    );
    for p in points {
        let _ = writeln!(
            out,
            "| {} | {:e} | {:.1} | {:.2e} | {:.2e} | {:.2} % | {} |",
            p.steps_per_frame,
            p.tolerance,
            p.ms_per_frame,
            p.contact_error,
            p.end_error,
            p.max_strain * 100.0,
            if p.pareto { "●" } else { "" }
        );
    }
    out
}

/// Writes `accuracy.csv`, `accuracy.md` and the `speed_against_error`
/// chart (PNG and SVG) of `scene`'s sweep into `dir`.
pub fn write_results(dir: &std::path::Path, scene: &str, points: &[AccuracyPoint]) -> Result<(), PlotError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_owned(), source })?;
    write_file(&dir.join("accuracy.csv"), |w| std::io::Write::write_all(w, csv(points).as_bytes()))?;
    let report = format!("{}\n![speed against error](speed_against_error.png)\n", markdown_table(points));
    write_file(&dir.join("accuracy.md"), |w| std::io::Write::write_all(w, report.as_bytes()))?;
    super::plots::speed_against_error(dir, &[(scene.to_owned(), points.to_vec())])
}

/// The sweep as CSV, one row per point.
pub fn csv(points: &[AccuracyPoint]) -> String {
    let mut out = String::from("steps_per_frame,tolerance,ms_per_frame,contact_error,end_error,max_strain,pareto\n");
    for p in points {
        let _ = writeln!(
            out,
            "{},{:e},{:.4},{:.6e},{:.6e},{:.6},{}",
            p.steps_per_frame, p.tolerance, p.ms_per_frame, p.contact_error, p.end_error, p.max_strain, p.pareto
        );
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
            end_error: 0.0,
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
    fn pareto_front_keeps_only_undominated_points() {
        let mut points = vec![point(10.0, 1e-2), point(20.0, 1e-3), point(30.0, 1e-2), point(20.0, 5e-3)];
        mark_pareto(&mut points);
        let front: Vec<bool> = points.iter().map(|p| p.pareto).collect();
        assert_eq!(front, [true, true, false, false]);
    }
}
