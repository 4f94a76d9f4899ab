//! The error estimate shown in the editor: the scene run again on a thread
//! with 16× smaller steps and a tight solver tolerance (the reference of
//! `drape bench accuracy`), and each simulated frame compared with it.

use std::sync::Arc;
use std::sync::atomic::AtomicBool;

use nalgebra::Vector3;

use super::job::Job;
use crate::bake;
use crate::bench::accuracy::{reference_scene, relative_rms, rest_diagonal};
use crate::scene::Scene;

/// A finished reference run.
#[derive(Clone, Debug)]
pub struct Reference {
    /// Positions at every frame end, frame 0 first, m.
    pub frames: Vec<Arc<Vec<Vector3<f64>>>>,
    /// Diagonal of the cloth's rest bounding box, m: errors are relative to it.
    pub diagonal_m: f64,
    /// The steps per frame it used.
    pub steps_per_frame: u32,
}

impl Reference {
    /// Relative RMS distance of `positions` from the reference's frame
    /// `frame` (unitless; times the diagonal gives metres), if it has it.
    pub fn error(&self, frame: usize, positions: &[Vector3<f64>]) -> Option<f64> {
        let reference = self.frames.get(frame)?;
        (reference.len() == positions.len()).then(|| relative_rms(positions, reference, self.diagonal_m))
    }
}

/// Starts the reference run of `scene` (its fabrics and steps per frame as
/// they are now) on a thread.
pub fn start(scene: Scene) -> Job<Reference> {
    Job::start(scene.frame_count, move |stop, progress| run(scene, stop, progress))
}

fn run(scene: Scene, stop: &AtomicBool, progress: &dyn Fn(usize)) -> Result<Reference, String> {
    let diagonal_m = rest_diagonal(&scene).map_err(|e| e.to_string())?;
    let scene = reference_scene(&scene);
    let total = scene.frame_count;
    let mut frames = Vec::with_capacity(total + 1);
    let (records, failure) = bake::run(&scene, total, stop, |sim, record| {
        frames.push(Arc::new(sim.positions().to_vec()));
        progress(record.frame);
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    if let Some(failure) = failure {
        return Err(format!("the reference run failed: {failure}"));
    }
    if records.len() < total {
        return Err("cancelled".into());
    }
    Ok(Reference { frames, diagonal_m, steps_per_frame: scene.steps_per_frame })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_is_the_rms_distance_over_the_diagonal_and_needs_matching_sizes() {
        let frame = Arc::new(vec![Vector3::zeros(), Vector3::zeros()]);
        let reference = Reference { frames: vec![frame], diagonal_m: 2.0, steps_per_frame: 32 };
        let moved = [Vector3::new(0.1, 0.0, 0.0), Vector3::new(-0.1, 0.0, 0.0)];
        assert!((reference.error(0, &moved).unwrap() - 0.05).abs() < 1e-15);
        assert_eq!(reference.error(1, &moved), None, "no such frame");
        assert_eq!(reference.error(0, &moved[..1]), None, "another cloth");
    }
}
