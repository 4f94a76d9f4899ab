//! Exporting the simulated frames from the editor, on a thread of its own:
//! the bake folder (OBJ sequence, PC2 point caches, summary), USD, glTF or
//! MDD files for other tools, and PNG frames rendered offscreen.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use super::job::Job;
use super::worker::Frame;
use crate::bake::FrameRecord;
use crate::bake::output::BakeFolder;
use crate::bake::summary::BakeSummary;
use crate::render::{Gpu, LightRig};
use crate::scene::Scene;
use crate::stage::offscreen::{OffscreenStage, write_png};

/// What to export.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ExportKind {
    /// OBJ sequence, PC2 point caches and summary.json (as `drape bake` writes).
    Geometry,
    /// A file for other tools (USD, glTF; MDD per garment), with the body.
    Format(crate::export::Format),
    /// PNG frames of the viewport's light rig, `frame_NNNN.png`.
    Images {
        /// Width, pixels.
        width: u32,
        /// Height, pixels.
        height: u32,
    },
}

/// Starts writing `frames` of `scene` into `dir` on a thread; the job's
/// result is the folder.
pub fn start(kind: ExportKind, scene: Scene, frames: Vec<Frame>, rig: LightRig, dir: PathBuf) -> Job<PathBuf> {
    Job::start(frames.len(), move |stop, progress| {
        match kind {
            ExportKind::Geometry => write_geometry(&scene, &frames, &dir, stop, progress)?,
            ExportKind::Format(format) => write_format(format, &scene, &frames, &dir, stop, progress)?,
            ExportKind::Images { width, height } => {
                write_images(&scene, &frames, rig, (width, height), &dir, stop, progress)?
            }
        }
        Ok(dir)
    })
}

fn write_geometry(
    scene: &Scene,
    frames: &[Frame],
    dir: &Path,
    stop: &AtomicBool,
    progress: &dyn Fn(usize),
) -> Result<(), String> {
    let mut folder = BakeFolder::create(dir, scene).map_err(|e| e.to_string())?;
    for (k, frame) in frames.iter().enumerate() {
        if stop.load(Ordering::Relaxed) {
            return folder.abandon().map_err(|e| e.to_string());
        }
        let time_s = k as f64 / scene.fps;
        folder.write_frame(k, time_s, &frame.positions).map_err(|e| e.to_string())?;
        progress(k + 1);
    }
    let records: Vec<FrameRecord> = frames.iter().skip(1).map(|f| f.record.clone()).collect();
    let summary = BakeSummary::new(scene, &records, scene.frame_count, None);
    folder.finish(&summary).map_err(|e| e.to_string())
}

fn write_format(
    format: crate::export::Format,
    scene: &Scene,
    frames: &[Frame],
    dir: &Path,
    stop: &AtomicBool,
    progress: &dyn Fn(usize),
) -> Result<(), String> {
    use crate::export::{ExportRequest, export};
    let positions: Vec<&[nalgebra::Vector3<f64>]> = frames.iter().map(|f| f.positions.as_slice()).collect();
    let baked = crate::stage::baked::BakedFrames::from_positions(scene, &positions);
    // The job counts frames; the export counts meshes × frames.
    let count = frames.len();
    let report = |done: usize, total: usize| progress(done * count / total.max(1));
    export(scene, &baked, &ExportRequest::new(format), dir, &report, stop).map(drop).map_err(|e| e.to_string())
}

fn write_images(
    scene: &Scene,
    frames: &[Frame],
    rig: LightRig,
    (width, height): (u32, u32),
    dir: &Path,
    stop: &AtomicBool,
    progress: &dyn Fn(usize),
) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let gpu = Gpu::headless().map_err(|e| e.to_string())?;
    let mut stage = OffscreenStage::new(&gpu, scene, width, height, rig).map_err(|e| e.to_string())?;
    for (k, frame) in frames.iter().enumerate() {
        if stop.load(Ordering::Relaxed) {
            return Ok(());
        }
        let image = stage.render(&frame.positions, k as f64 / scene.fps).map_err(|e| e.to_string())?;
        write_png(&dir.join(format!("frame_{k:04}.png")), &image).map_err(|e| e.to_string())?;
        progress(k + 1);
    }
    Ok(())
}
