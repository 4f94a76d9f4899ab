//! The benchmark's pictures, drawn with plotters as PNG and SVG: speed
//! against error (the Pareto front marked), strain over time, and the time
//! of each pipeline stage.

use std::path::Path;

use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;

use super::BenchResult;
use super::accuracy::{AccuracyPoint, SceneSweep};
use crate::io::atomic::{WriteError, write_file};

/// Size of every chart, pixels.
const SIZE: (u32, u32) = (1000, 640);
/// Caption and label fonts, px.
const CAPTION_PX: u32 = 26;
const LABEL_PX: u32 = 17;

/// Why a chart could not be made.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// plotters failed to draw (e.g. no font on the system).
    #[error("cannot draw {chart}: {message}")]
    Draw {
        /// The chart's file stem.
        chart: String,
        /// What plotters said.
        message: String,
    },
    /// The chart could not be written.
    #[error(transparent)]
    Write(#[from] WriteError),
}

/// Draws a chart into a bitmap.
type DrawPng<'a> = dyn Fn(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), String> + 'a;
/// Draws the same chart as SVG.
type DrawSvg<'a> = dyn Fn(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), String> + 'a;

/// Writes `dir/<stem>.png` and `dir/<stem>.svg`, each drawn by `draw_png` /
/// `draw_svg` (the same chart on the two backends).
fn write_chart(dir: &Path, stem: &str, draw_png: &DrawPng<'_>, draw_svg: &DrawSvg<'_>) -> Result<(), PlotError> {
    let failed = |message: String| PlotError::Draw { chart: stem.to_owned(), message };
    let mut pixels = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, SIZE).into_drawing_area();
        draw_png(&root).map_err(failed)?;
        root.present().map_err(|e| failed(e.to_string()))?;
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        draw_svg(&root).map_err(failed)?;
        root.present().map_err(|e| failed(e.to_string()))?;
    }
    let image = image::RgbImage::from_raw(SIZE.0, SIZE.1, pixels)
        .ok_or_else(|| failed("the bitmap has the wrong size".into()))?;
    write_file(&dir.join(format!("{stem}.png")), |w| {
        image.write_to(w, image::ImageFormat::Png).map_err(std::io::Error::other)
    })?;
    write_file(&dir.join(format!("{stem}.svg")), |w| std::io::Write::write_all(w, svg.as_bytes()))?;
    Ok(())
}

/// A chart's frame: caption, margin and axis label areas (`y_labels` px wide).
fn chart_builder<'a, 'b, DB: DrawingBackend>(
    root: &'a DrawingArea<DB, Shift>,
    caption: &str,
    y_labels: u32,
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(root);
    builder.caption(caption, ("sans-serif", CAPTION_PX)).margin(16).x_label_area_size(48).y_label_area_size(y_labels);
    builder
}

/// The series' legend at `position`, on a light box.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(position)
        .label_font(("sans-serif", LABEL_PX))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())
}

/// The span of log10 of the positive `values`, widened by 0.1 each side
/// (the speed-against-error axes are drawn in log10 and labelled in values).
fn log10_span(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| *v > 0.0)
        .map(f64::log10)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo > hi { -3.0..0.0 } else { lo - 0.1..hi + 0.1 }
}

/// A log10 coordinate's label: the value it stands for, to 2 significant digits.
fn power_label(v: &f64) -> String {
    let value = 10f64.powf(*v);
    let digits = (1 - value.log10().floor() as i32).max(0) as usize;
    format!("{value:.digits$}")
}

/// Speed against error of accuracy sweeps, one curve per scene: ms per frame
/// against the contact-window error, every run a dot labelled with its steps
/// per frame, the Pareto front a line.
pub fn speed_against_error(dir: &Path, sweeps: &[SceneSweep]) -> Result<(), PlotError> {
    fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, sweeps: &[SceneSweep]) -> Result<(), String> {
        let all = || sweeps.iter().flat_map(|(_, points)| points);
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut chart = chart_builder(root, "Speed against error (Pareto front: line)", 80)
            .build_cartesian_2d(log10_span(all().map(|p| p.ms_per_frame)), log10_span(all().map(|p| p.contact_error)))
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("simulation time per frame (ms, median; log scale)")
            .y_desc("RMS error / cloth diagonal (contact window; log scale)")
            .x_labels(10)
            .y_labels(10)
            .x_label_formatter(&power_label)
            .y_label_formatter(&power_label)
            .label_style(("sans-serif", LABEL_PX))
            .draw()
            .map_err(|e| e.to_string())?;
        for (k, (scene, points)) in sweeps.iter().enumerate() {
            let color = Palette99::pick(k).to_rgba();
            let at = |p: &AccuracyPoint| (p.ms_per_frame.log10(), p.contact_error.log10());
            let mut front: Vec<(f64, f64)> = points.iter().filter(|p| p.pareto).map(at).collect();
            front.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(front, color.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(scene.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(2)));
            chart
                .draw_series(points.iter().map(|p| {
                    let style = if p.pareto { color.filled() } else { color.stroke_width(1) };
                    EmptyElement::at(at(p))
                        + Circle::new((0, 0), 5, style)
                        + Text::new(
                            format!("{}×, {:.0e}", p.steps_per_frame, p.tolerance),
                            (7, -14),
                            ("sans-serif", 13),
                        )
                }))
                .map_err(|e| e.to_string())?;
        }
        legend(&mut chart, SeriesLabelPosition::MiddleRight)
    }
    write_chart(dir, "speed_against_error", &|root| draw(root, sweeps), &|root| draw(root, sweeps))
}

/// The largest stretch strain at each frame end, one line per case.
pub fn strain_over_time(dir: &Path, results: &[BenchResult]) -> Result<(), PlotError> {
    fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, results: &[BenchResult]) -> Result<(), String> {
        let frames = results.iter().map(|r| r.summary.frames).max().unwrap_or(1).max(1);
        let strains = results.iter().flat_map(|r| r.summary.per_frame.iter().map(|f| f.max_strain * 100.0));
        let top = strains.fold(1.0_f64, f64::max) * 1.1;
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut chart = chart_builder(root, "Largest stretch strain at each frame end", 70)
            .build_cartesian_2d(0usize..frames, 0.0..top)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("frame")
            .y_desc("strain (%)")
            .label_style(("sans-serif", LABEL_PX))
            .draw()
            .map_err(|e| e.to_string())?;
        for (k, r) in results.iter().enumerate() {
            let color = Palette99::pick(k).to_rgba();
            let line = r.summary.per_frame.iter().map(|f| (f.frame, f.max_strain * 100.0));
            chart
                .draw_series(LineSeries::new(line, color.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(r.case.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(2)));
        }
        legend(&mut chart, SeriesLabelPosition::MiddleRight)
    }
    write_chart(dir, "strain_over_time", &|root| draw(root, results), &|root| draw(root, results))
}

/// Median ms per frame of each pipeline stage, a stacked bar per case.
pub fn time_per_stage(dir: &Path, results: &[BenchResult]) -> Result<(), PlotError> {
    fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, results: &[BenchResult]) -> Result<(), String> {
        let stages: Vec<&str> = super::stage_names().collect();
        let stage_ms = |r: &BenchResult, s: &str| r.summary.stage_ms_per_frame_median.get(s).copied().unwrap_or(0.0);
        let widest = results.iter().map(|r| stages.iter().map(|s| stage_ms(r, s)).sum::<f64>()).fold(1e-3, f64::max);
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let mut chart = chart_builder(root, "Time per stage (median ms per frame)", 40)
            .build_cartesian_2d(0.0..widest * 1.35, 0.0..results.len().max(1) as f64)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .disable_y_axis()
            .x_desc("ms per frame")
            .label_style(("sans-serif", LABEL_PX))
            .draw()
            .map_err(|e| e.to_string())?;
        for (k, stage) in stages.iter().enumerate() {
            let color = Palette99::pick(k).to_rgba();
            let bars = results.iter().enumerate().map(|(row, r)| {
                let start: f64 = stages[..k].iter().map(|s| stage_ms(r, s)).sum();
                let y = row as f64;
                Rectangle::new([(start, y + 0.2), (start + stage_ms(r, stage), y + 0.8)], color.filled())
            });
            chart
                .draw_series(bars)
                .map_err(|e| e.to_string())?
                .label(*stage)
                .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 14, y + 6)], color.filled()));
        }
        let names = results
            .iter()
            .enumerate()
            .map(|(row, r)| Text::new(r.case.clone(), (0.0, row as f64 + 0.95), ("sans-serif", LABEL_PX)));
        chart.draw_series(names).map_err(|e| e.to_string())?;
        legend(&mut chart, SeriesLabelPosition::UpperRight)
    }
    write_chart(dir, "time_per_stage", &|root| draw(root, results), &|root| draw(root, results))
}
