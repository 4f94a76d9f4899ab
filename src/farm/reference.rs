//! A variant's error against its reference (when the sweep asks for one):
//! the scene run again with 16× smaller steps and a tight tolerance (the
//! reference of `drape bench accuracy`), each frame of the bake compared
//! with it by RMS distance over the cloth's rest diagonal.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use crate::bake;
use crate::bench::accuracy::{reference_scene, relative_rms, rest_diagonal};
use crate::scene::Scene;
use crate::stage::baked::BakedFrames;

/// The file, in a bake folder, that holds [`ReferenceError`].
pub const ERROR_FILE: &str = "reference_error.json";

/// How far a bake is from its reference.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReferenceError {
    /// Mean over the frames after frame 0 of the relative RMS error (unitless;
    /// times the rest diagonal gives metres).
    pub mean: f64,
    /// The largest frame's.
    pub max: f64,
    /// Frames compared.
    pub frames: usize,
}

/// Runs `scene`'s reference over the frames of the bake in `bake_dir` and
/// compares them; stops early when `cancel` is set.
pub fn measure(scene: &Scene, bake_dir: &Path, cancel: &AtomicBool) -> Result<ReferenceError, String> {
    let baked = BakedFrames::open(bake_dir, scene).map_err(|e| e.to_string())?;
    let diagonal = rest_diagonal(scene).map_err(|e| e.to_string())?;
    let frames = baked.frame_count().saturating_sub(1);
    let mut errors = Vec::with_capacity(frames);
    let (_, failure) = bake::run(&reference_scene(scene), frames, cancel, |sim, record| {
        if record.frame > 0 {
            errors.push(relative_rms(&baked.positions(record.frame), sim.positions(), diagonal));
        }
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    if let Some(failure) = failure {
        return Err(format!("the reference run stopped: {failure}"));
    }
    if errors.len() < frames {
        return Err("the reference run was cancelled".into());
    }
    let mean = errors.iter().sum::<f64>() / errors.len().max(1) as f64;
    Ok(ReferenceError { mean, max: errors.iter().copied().fold(0.0, f64::max), frames })
}
