//! The benchmark's pictures, drawn with plotters as PNG and SVG: speed
//! against error (the Pareto front marked), strain over time, and the time
//! of each pipeline stage.

use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;

use super::BenchResult;
use super::accuracy::{AccuracyPoint, SceneSweep};
use super::soak::SoakReport;
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

/// A drawing backend's pixel, x right and y down.
type Pixel = (i32, i32);

/// The outline of the `shape`-th tolerance's marker (as [`draw_markers`]
/// draws it) around the pixel `(x, y)`, for the legend.
fn marker_outline(shape: usize, (x, y): Pixel) -> Vec<Pixel> {
    let corners: Vec<(f64, f64)> = match shape % 3 {
        0 => {
            (0..=16).map(|k| std::f64::consts::TAU * k as f64 / 16.0).map(|a| (5.0 * a.cos(), 5.0 * a.sin())).collect()
        }
        1 => vec![(0.0, -7.0), (6.1, 3.5), (-6.1, 3.5), (0.0, -7.0)],
        _ => vec![(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0), (-5.0, -5.0)],
    };
    corners.into_iter().map(|(dx, dy)| (x + dx.round() as i32, y + dy.round() as i32)).collect()
}

/// The speed-against-error chart's axes: log10 ms per frame, log10 error.
type LogLogChart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws the `shape`-th tolerance's marker (circle, triangle, square, about
/// 10 px across) at each point with its style.
fn draw_markers<DB: DrawingBackend>(
    chart: &mut LogLogChart<'_, DB>,
    shape: usize,
    points: impl Iterator<Item = ((f64, f64), ShapeStyle)>,
) -> Result<(), String> {
    let drawn = match shape % 3 {
        0 => chart.draw_series(points.map(|(at, style)| EmptyElement::at(at) + Circle::new((0, 0), 5, style))),
        1 => chart.draw_series(points.map(|(at, style)| EmptyElement::at(at) + TriangleMarker::new((0, 0), 7, style))),
        _ => chart
            .draw_series(points.map(|(at, style)| EmptyElement::at(at) + Rectangle::new([(-5, -5), (5, 5)], style))),
    };
    drawn.map(|_| ()).map_err(|e| e.to_string())
}

/// The distinct tolerances of the sweeps, loosest first.
fn tolerances(sweeps: &[SceneSweep]) -> Vec<f64> {
    let mut all: Vec<f64> = sweeps.iter().flat_map(|(_, points)| points.iter().map(|p| p.tolerance)).collect();
    all.sort_by(|a, b| b.total_cmp(a));
    all.dedup();
    all
}

/// Speed against error of accuracy sweeps, one curve per scene: ms per frame
/// against the contact-window error, every run a marker (its shape the
/// tolerance, filled on the Pareto front), each steps-per-frame group labelled
/// once, the Pareto front a line.
pub fn speed_against_error(dir: &Path, sweeps: &[SceneSweep]) -> Result<(), PlotError> {
    fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, sweeps: &[SceneSweep]) -> Result<(), String> {
        let all = || sweeps.iter().flat_map(|(_, points)| points);
        let tolerances = tolerances(sweeps);
        let shape_of = |p: &AccuracyPoint| tolerances.iter().position(|&t| t == p.tolerance).unwrap_or(0);
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let caption = "Speed against error (Pareto front: line and filled markers)";
        let mut chart = chart_builder(root, caption, 80)
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
            for shape in 0..tolerances.len() {
                let marked = points.iter().filter(|p| shape_of(p) == shape).map(|p| {
                    let style = if p.pareto { color.filled() } else { color.stroke_width(1) };
                    (at(p), style)
                });
                draw_markers(&mut chart, shape, marked)?;
            }
            chart
                .draw_series(steps_labels(points).map(|p| {
                    let text = format!("{}×", p.steps_per_frame);
                    EmptyElement::at(at(p)) + Text::new(text, (-10, -26), ("sans-serif", LABEL_PX))
                }))
                .map_err(|e| e.to_string())?;
        }
        for (n, tolerance) in tolerances.iter().enumerate() {
            chart
                .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())
                .map_err(|e| e.to_string())?
                .label(format!("tolerance {tolerance:.0e}"))
                .legend(move |(x, y)| PathElement::new(marker_outline(n, (x + 12, y)), BLACK.stroke_width(1)));
        }
        legend(&mut chart, SeriesLabelPosition::LowerRight)
    }
    write_chart(dir, "speed_against_error", &|root| draw(root, sweeps), &|root| draw(root, sweeps))
}

/// The fastest run of each steps-per-frame group, where the group's "N×"
/// label goes.
fn steps_labels(points: &[AccuracyPoint]) -> impl Iterator<Item = &AccuracyPoint> {
    points.iter().filter(move |p| {
        !points.iter().any(|q| q.steps_per_frame == p.steps_per_frame && q.ms_per_frame < p.ms_per_frame)
    })
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

/// The soak over time: the cloth's energy averaged over each motion cycle
/// (above) and the process's resident memory (below).
pub fn soak_over_time(dir: &Path, report: &SoakReport) -> Result<(), PlotError> {
    fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, report: &SoakReport) -> Result<(), String> {
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let (upper, lower) = root.split_vertically(SIZE.1 / 2);
        let cycles = report.cycle_energy_j.len().max(2);
        let energy = report.cycle_energy_j.iter().copied();
        let (low, high) = energy.clone().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), e| (l.min(e), h.max(e)));
        let pad = ((high - low) * 0.2).max(high.abs() * 0.02).max(1e-6);
        let mut top = chart_builder(&upper, "Cloth energy, mean over each walk cycle", 80)
            .build_cartesian_2d(1usize..cycles, (low - pad)..(high + pad))
            .map_err(|e| e.to_string())?;
        top.configure_mesh()
            .x_desc("cycle")
            .y_desc("kinetic + gravitational (J)")
            .label_style(("sans-serif", LABEL_PX))
            .draw()
            .map_err(|e| e.to_string())?;
        let line = energy.enumerate().map(|(k, e)| (k + 1, e));
        top.draw_series(LineSeries::new(line, BLUE.stroke_width(2))).map_err(|e| e.to_string())?;
        let frames = report.samples.len().max(2);
        let most = report.samples.iter().map(|s| s.resident_mib).fold(1.0, f64::max) * 1.2;
        let mut bottom = chart_builder(&lower, "Resident memory of the process", 80)
            .build_cartesian_2d(1usize..frames, 0.0..most)
            .map_err(|e| e.to_string())?;
        bottom
            .configure_mesh()
            .x_desc("frame")
            .y_desc("MiB")
            .label_style(("sans-serif", LABEL_PX))
            .draw()
            .map_err(|e| e.to_string())?;
        let memory = report.samples.iter().map(|s| (s.frame, s.resident_mib));
        bottom.draw_series(LineSeries::new(memory, RED.stroke_width(2))).map_err(|e| e.to_string())?;
        Ok(())
    }
    write_chart(dir, "soak", &|root| draw(root, report), &|root| draw(root, report))
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

#[cfg(test)]
mod tests {
    use super::*;

    fn run(steps_per_frame: u32, tolerance: f64, ms_per_frame: f64) -> AccuracyPoint {
        AccuracyPoint {
            steps_per_frame,
            tolerance,
            ms_per_frame,
            contact_error: 0.01,
            end_error: None,
            max_strain: 0.01,
            pareto: false,
        }
    }

    #[test]
    fn each_tolerance_gets_one_marker_and_each_step_group_one_label_at_its_fastest_run() {
        let points = vec![run(1, 1e-3, 40.0), run(1, 1e-2, 38.0), run(2, 1e-3, 80.0), run(2, 1e-4, 90.0)];
        let sweeps = vec![("a".to_owned(), points.clone()), ("b".to_owned(), vec![run(1, 1e-2, 5.0)])];
        assert_eq!(tolerances(&sweeps), [1e-2, 1e-3, 1e-4]);
        let labelled: Vec<(u32, f64)> = steps_labels(&points).map(|p| (p.steps_per_frame, p.ms_per_frame)).collect();
        assert_eq!(labelled, [(1, 38.0), (2, 80.0)]);
    }

    #[test]
    fn marker_outlines_are_closed_and_about_ten_pixels_across() {
        for shape in 0..3 {
            let outline = marker_outline(shape, (100, 50));
            assert_eq!(outline.first(), outline.last(), "shape {shape} is closed");
            let width = outline.iter().map(|p| p.0).max().unwrap() - outline.iter().map(|p| p.0).min().unwrap();
            assert!((10..=13).contains(&width), "shape {shape} is {width} px wide");
        }
    }
}
