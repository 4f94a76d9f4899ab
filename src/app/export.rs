//! Exporting the simulated frames from the editor, on a thread of its own:
//! the bake folder (OBJ sequence, PC2 point caches, summary), USD, glTF or
//! MDD files for other tools, and PNG frames rendered offscreen.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use super::job::Job;
use super::orbit::CameraControl;
use super::worker::Frame;
use crate::bake::FrameRecord;
use crate::bake::output::BakeFolder;
use crate::bake::summary::BakeSummary;
use crate::render::{Gpu, LightRig};
use crate::scene::Scene;
use crate::stage::figure::FigurePath;
use crate::stage::fit_map::{FitMap, map_values};
use crate::stage::legend::draw_legend;
use crate::stage::offscreen::{OffscreenStage, write_png};

/// What to export.
#[derive(Clone, Debug, PartialEq)]
pub enum ExportKind {
    /// OBJ sequence, PC2 point caches and summary.json (as `drape bake` writes).
    Geometry,
    /// A file for other tools (USD, glTF; MDD per garment), with the body.
    Format(crate::export::Format),
    /// PNG frames, `frame_NNNN.png`, as the viewport shows them.
    Images(ImageRequest),
}

/// What PNG frames show.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageRequest {
    /// Width and height, pixels.
    pub size: (u32, u32),
    /// Through which camera.
    pub camera: ImageCamera,
    /// The fit map colouring the cloth, if any (its legend is drawn in).
    pub map: Option<FitMap>,
    /// Only this frame, or every simulated frame.
    pub only_frame: Option<usize>,
}

/// The camera of exported images.
#[derive(Clone, Debug, PartialEq)]
pub enum ImageCamera {
    /// The scene file's camera (or its framing of the figure).
    Scene,
    /// The view composed in the editor, following the figure as it does.
    View(CameraControl, FigurePath),
}

/// Starts writing `frames` of `scene` into `dir` on a thread; the job's
/// result is the folder.
pub fn start(kind: ExportKind, scene: Scene, frames: Vec<Frame>, rig: LightRig, dir: PathBuf) -> Job<PathBuf> {
    let units = match &kind {
        ExportKind::Images(ImageRequest { only_frame: Some(_), .. }) => 1,
        _ => frames.len(),
    };
    Job::start(units, move |stop, progress| {
        match kind {
            ExportKind::Geometry => write_geometry(&scene, &frames, &dir, stop, progress)?,
            ExportKind::Format(format) => write_format(format, &scene, &frames, &dir, stop, progress)?,
            ExportKind::Images(request) => write_images(&scene, &frames, rig, &request, &dir, stop, progress)?,
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
    request: &ImageRequest,
    dir: &Path,
    stop: &AtomicBool,
    progress: &dyn Fn(usize),
) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let gpu = Gpu::headless().map_err(|e| e.to_string())?;
    let (width, height) = request.size;
    let mut stage = OffscreenStage::new(&gpu, scene, width, height, rig).map_err(|e| e.to_string())?;
    if request.map.is_some() {
        stage.use_fit_map();
    }
    let chosen: Vec<usize> = match request.only_frame {
        Some(k) => vec![k.min(frames.len().saturating_sub(1))],
        None => (0..frames.len()).collect(),
    };
    for (done, &k) in chosen.iter().enumerate() {
        if stop.load(Ordering::Relaxed) {
            return Ok(());
        }
        let Some(frame) = frames.get(k) else { continue };
        let t = k as f64 / scene.fps;
        let aspect = width as f32 / height as f32;
        let camera = match &request.camera {
            ImageCamera::Scene => stage.stage().camera(aspect, t),
            ImageCamera::View(control, figure) => control.camera(stage.stage().camera(aspect, 0.0), figure, t),
        };
        if let Some(map) = request.map {
            stage.set_fit_map_values(map_values(map, scene, &frame.positions, &frame.contact_force_n));
        }
        let mut image = stage.render_through(&frame.positions, t, camera).map_err(|e| e.to_string())?;
        if let Some(map) = request.map {
            let (title, labels) = map.legend(scene);
            draw_legend(&mut image, &title, &labels);
        }
        write_png(&dir.join(format!("frame_{k:04}.png")), &image).map_err(|e| e.to_string())?;
        progress(done + 1);
    }
    Ok(())
}
