//! What a sweep gave: one table of every variant's bake summary (CSV and
//! Markdown) and a contact sheet, one labelled tile per variant at a chosen
//! frame, the picture designers compare fabrics on.

use std::path::Path;

use image::{Rgba, RgbaImage};

use super::FarmError;
use super::layout::{BAKE, Entry, VariantState, state};
use super::reference::{ERROR_FILE, ReferenceError};
use crate::bake::summary::BakeSummary;
use crate::render::lights::LightRig;
use crate::render::{Gpu, RenderError};
use crate::scene::Scene;
use crate::stage::baked::BakedFrames;
use crate::stage::legend::draw_caption;
use crate::stage::offscreen::OffscreenStage;

/// One variant's line of the table.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Row {
    /// Variant number.
    pub index: usize,
    /// Its label.
    pub label: String,
    /// finished / failed / started / pending.
    pub state: String,
    /// Frames baked.
    pub frames: Option<usize>,
    /// Simulation time per frame, median, ms.
    pub ms_per_frame: Option<f64>,
    /// Largest stretch-edge strain, unitless.
    pub max_strain: Option<f64>,
    /// Largest strain of the free cloth (away from pins and glue), unitless.
    pub max_free_strain: Option<f64>,
    /// Intersections the independent checker found, over all frames.
    pub intersections: Option<u64>,
    /// Steps taken again.
    pub rollbacks: Option<u64>,
    /// Mean error against the 16× reference (relative RMS), when measured.
    pub reference_error: Option<f64>,
    /// Why it stopped, if it did.
    pub stopped: String,
}

/// The table of the sweep folder `dir`: one row per variant, in order.
pub fn table(dir: &Path, entries: &[Entry]) -> Result<Vec<Row>, FarmError> {
    entries.iter().map(|entry| row(dir, entry)).collect()
}

fn row(dir: &Path, entry: &Entry) -> Result<Row, FarmError> {
    let now = state(dir, entry);
    let mut row = Row {
        index: entry.index,
        label: entry.label.clone(),
        state: now.word().to_owned(),
        frames: None,
        ms_per_frame: None,
        max_strain: None,
        max_free_strain: None,
        intersections: None,
        rollbacks: None,
        reference_error: None,
        stopped: match &now {
            VariantState::Failed(reason) => reason.clone(),
            _ => String::new(),
        },
    };
    if now == VariantState::Finished {
        let path = entry.dir(dir).join(BAKE).join("summary.json");
        let text = std::fs::read_to_string(&path).map_err(|e| FarmError::io(&path, e))?;
        let summary: BakeSummary = serde_json::from_str(&text)
            .map_err(|e| FarmError::Folder { dir: dir.to_owned(), problem: format!("{}: {e}", path.display()) })?;
        row.frames = Some(summary.frames);
        row.ms_per_frame = Some(summary.ms_per_frame_median);
        row.max_strain = Some(summary.max_strain);
        row.max_free_strain = Some(summary.max_free_strain);
        row.intersections = Some(summary.intersections_total as u64);
        row.rollbacks = Some(summary.rollbacks as u64);
        let measured = std::fs::read_to_string(entry.dir(dir).join(BAKE).join(ERROR_FILE)).ok();
        row.reference_error =
            measured.and_then(|text| serde_json::from_str::<ReferenceError>(&text).ok()).map(|e| e.mean);
    }
    Ok(row)
}

/// The table as CSV.
pub fn csv_text(rows: &[Row]) -> Result<Vec<u8>, csv::Error> {
    let mut out = csv::Writer::from_writer(Vec::new());
    for row in rows {
        out.serialize(row)?;
    }
    out.into_inner().map_err(|e| csv::Error::from(e.into_error()))
}

/// The table as Markdown.
pub fn markdown(rows: &[Row]) -> String {
    let mut text = String::from(
        "| # | variant | state | frames | ms/frame | max strain | max free strain | intersections | rollbacks | error vs reference |\n\
         |---:|---|---|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    let number = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or("-".to_owned(), f);
    for r in rows {
        let state = if r.stopped.is_empty() { r.state.clone() } else { format!("{}: {}", r.state, r.stopped) };
        text += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.index,
            r.label,
            state.replace('|', "/"),
            r.frames.map_or("-".into(), |f| f.to_string()),
            number(r.ms_per_frame, &|v| format!("{v:.1}")),
            number(r.max_strain, &|v| format!("{:.2} %", v * 100.0)),
            number(r.max_free_strain, &|v| format!("{:.2} %", v * 100.0)),
            r.intersections.map_or("-".into(), |v| v.to_string()),
            r.rollbacks.map_or("-".into(), |v| v.to_string()),
            number(r.reference_error, &|v| format!("{v:.2e}")),
        );
    }
    text
}

/// Size of one contact-sheet tile, pixels.
pub const TILE: (u32, u32) = (480, 360);

/// The contact sheet: each variant at `frame` (its last frame if it has
/// fewer), drawn under `rig`, in a grid of about square shape, each tile
/// captioned with its number and label; a variant without a complete bake
/// is a dark tile saying so.
pub fn contact_sheet(
    gpu: &Gpu,
    dir: &Path,
    entries: &[Entry],
    frame: usize,
    rig: &LightRig,
) -> Result<RgbaImage, FarmError> {
    let columns = (entries.len() as f64).sqrt().ceil().max(1.0) as u32;
    let rows = (entries.len() as u32).div_ceil(columns);
    let mut sheet = RgbaImage::from_pixel(columns * TILE.0, rows * TILE.1, Rgba([20, 20, 20, 255]));
    for (k, entry) in entries.iter().enumerate() {
        let mut tile = match state(dir, entry) {
            VariantState::Finished => render_tile(gpu, dir, entry, frame, rig)?,
            other => blank_tile(other.word()),
        };
        draw_caption(&mut tile, &format!("{}  {}", entry.index, entry.label), 28.0);
        let (x, y) = ((k as u32 % columns) * TILE.0, (k as u32 / columns) * TILE.1);
        image::imageops::replace(&mut sheet, &tile, i64::from(x), i64::from(y));
    }
    Ok(sheet)
}

/// A dark tile with `word` across its middle.
fn blank_tile(word: &str) -> RgbaImage {
    let mut tile = RgbaImage::from_pixel(TILE.0, TILE.1, Rgba([45, 45, 45, 255]));
    let mut band = RgbaImage::from_pixel(TILE.0, 40, Rgba([45, 45, 45, 255]));
    draw_caption(&mut band, word, 40.0);
    image::imageops::replace(&mut tile, &band, 0, i64::from(TILE.1 / 2 - 20));
    tile
}

fn render_tile(gpu: &Gpu, dir: &Path, entry: &Entry, frame: usize, rig: &LightRig) -> Result<RgbaImage, FarmError> {
    let folder = entry.dir(dir);
    let problem = |problem: String| FarmError::Folder { dir: folder.clone(), problem };
    let scene = Scene::load(&folder.join("scene.toml")).map_err(|e| problem(e.to_string()))?;
    let baked = BakedFrames::open(&folder.join(BAKE), &scene).map_err(|e| problem(e.to_string()))?;
    let k = frame.min(baked.frame_count().saturating_sub(1));
    let draw = |e: RenderError| problem(e.to_string());
    let mut stage = OffscreenStage::new(gpu, &scene, TILE.0, TILE.1, rig.clone()).map_err(draw)?;
    stage.render(&baked.positions(k), baked.time(k)).map_err(draw)
}
