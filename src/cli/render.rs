//! `drape render`: frames of a bake or a scene drawn offscreen into PNGs.

use std::path::{Path, PathBuf};

use drape::bake;

use super::bake::scene_of_bake;
use crate::{Failure, input, load_scene};

/// The options of `drape render` besides its source and output.
pub(crate) struct RenderRequest {
    /// Frames to draw, `A..B` or `N` (default: all).
    pub frames: Option<String>,
    /// Light rig, by name or file.
    pub light: String,
    /// Image size, `WIDTHxHEIGHT`, pixels.
    pub size: String,
    /// Turntable period, s (the camera circles the scene).
    pub turntable: Option<f64>,
    /// The scene of a bake folder, when its summary names none.
    pub scene: Option<PathBuf>,
}

/// Parses `WIDTHxHEIGHT`.
fn parse_size(text: &str) -> Result<(u32, u32), Failure> {
    let bad =
        || Failure::Input(format!("--size {text}: expected WIDTHxHEIGHT in pixels, e.g. 1280x720, each 16 to 8192"));
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.trim().parse().map_err(|_| bad())?, h.trim().parse().map_err(|_| bad())?);
    match (16..=8192).contains(&w) && (16..=8192).contains(&h) {
        true => Ok((w, h)),
        false => Err(bad()),
    }
}

/// Parses `A..B` (inclusive) or `N` against the `last` frame available.
pub(crate) fn parse_frames(text: Option<&str>, last: usize) -> Result<std::ops::RangeInclusive<usize>, Failure> {
    let Some(text) = text else { return Ok(0..=last) };
    let bad = |why: &str| Failure::Input(format!("--frames {text}: {why}"));
    let number = |s: &str| s.trim().parse::<usize>().map_err(|_| bad("expected A..B or N, frame numbers from 0"));
    let (a, b) = match text.split_once("..") {
        Some((a, b)) => (number(a)?, number(b.trim_start_matches('='))?),
        None => (number(text)?, number(text)?),
    };
    if a > b {
        return Err(bad("the first frame is after the last"));
    }
    if b > last {
        return Err(bad(&format!("the last frame available is {last}")));
    }
    Ok(a..=b)
}

/// `drape render SCENE|BAKE_DIR --out DIR`: the frames asked for, drawn
/// offscreen into `DIR/frame_NNNN.png`.
pub(crate) fn run_render(source: &Path, out: &Path, request: &RenderRequest) -> Result<(), Failure> {
    use drape::render::{Gpu, LightRig, RenderError};
    use drape::stage::baked::BakedFrames;
    use drape::stage::offscreen::{OffscreenStage, write_png};

    let (width, height) = parse_size(&request.size)?;
    let rig = LightRig::find(&request.light).map_err(input)?;
    if let Some(period) = request.turntable.filter(|p| !(p.is_finite() && *p >= 0.1)) {
        return Err(Failure::Input(format!("--turntable {period}: expected a period of at least 0.1 s")));
    }
    let baked = source.is_dir();
    let scene_path = match (baked, &request.scene) {
        (_, Some(path)) => path.clone(),
        (false, None) => source.to_owned(),
        (true, None) => scene_of_bake(source).ok_or_else(|| {
            Failure::Input(format!(
                "{}: its summary.json names no scene file that exists; give it with --scene",
                source.display()
            ))
        })?,
    };
    let mut scene = load_scene(&scene_path)?;
    if let Some(period) = request.turntable {
        scene.file.camera.turntable_period_s = Some(period);
    }
    std::fs::create_dir_all(out).map_err(|e| Failure::Input(format!("cannot create {}: {e}", out.display())))?;
    let gpu = Gpu::headless().map_err(|e| Failure::Internal(e.to_string()))?;
    let mut stage = OffscreenStage::new(&gpu, &scene, width, height, rig).map_err(|e| match e {
        RenderError::Unsupported { .. } => Failure::Internal(e.to_string()),
        other => input(other),
    })?;
    let mut times_ms = Vec::new();
    let mut shoot = |frame: usize, positions: &[nalgebra::Vector3<f64>], t: f64| -> Result<(), Failure> {
        let started = std::time::Instant::now();
        let image = stage.render(positions, t).map_err(|e| Failure::Internal(e.to_string()))?;
        times_ms.push(started.elapsed().as_secs_f64() * 1e3);
        write_png(&out.join(format!("frame_{frame:04}.png")), &image).map_err(input)
    };
    let range = if baked {
        let frames = BakedFrames::open(source, &scene).map_err(input)?;
        let range = parse_frames(request.frames.as_deref(), frames.frame_count().saturating_sub(1))?;
        for frame in range.clone() {
            shoot(frame, &frames.positions(frame), frames.time(frame))?;
        }
        range
    } else {
        let range = parse_frames(request.frames.as_deref(), scene.frame_count)?;
        let mut baker = bake::Baker::new(&scene).map_err(input)?;
        loop {
            let (frame, sim) = (baker.frame(), baker.simulator());
            if range.contains(&frame) {
                shoot(frame, sim.positions(), sim.time())?;
            }
            if frame >= *range.end() {
                break range;
            }
            baker.advance().map_err(|e| Failure::Internal(e.to_string()))?;
        }
    };
    println!(
        "{} frames ({}..{}) of '{}' under '{}' in {}: median {:.0} ms/frame at {width}x{height} on {}",
        times_ms.len(),
        range.start(),
        range.end(),
        scene.name,
        request.light,
        out.display(),
        bake::summary::median(&times_ms),
        gpu.adapter_name,
    );
    Ok(())
}
