//! A bench run's files: its tables (CSV, Markdown) and charts (PNG + SVG),
//! for the standard suites, the speed-against-error sweep and the soak. Kept
//! apart from the measurements so that the charts (`plots.rs`) can read
//! their types without those modules reading the charts.

use std::fmt::Write as _;
use std::path::Path;

use super::accuracy::{self, SceneSweep};
use super::plots::PlotError;
use super::soak::SoakReport;
use super::{BenchResult, Suite};
use crate::io::atomic::{WriteError, write_file};

/// Writes `bench.csv`, `bench.md` and the charts (`strain_over_time` and
/// `time_per_stage`, PNG and SVG) into `dir`; when the results span several
/// suites (`--suite all`), each suite's charts also go into `dir/SUITE/`.
pub fn write_results(dir: &Path, results: &[BenchResult]) -> Result<(), PlotError> {
    let mut suites: Vec<Suite> = results.iter().flat_map(|r| r.suites.iter().copied()).collect();
    suites.sort_by_key(|suite| suite.name());
    suites.dedup();
    if suites.len() > 1 {
        for suite in suites {
            let part: Vec<BenchResult> = results.iter().filter(|r| r.suites.contains(&suite)).cloned().collect();
            write_charts(&dir.join(suite.name()), &part)?;
        }
    }
    std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_owned(), source })?;
    write_file(&dir.join("bench.csv"), |w| std::io::Write::write_all(w, super::csv(results).as_bytes()))?;
    let tables = format!(
        "{}\n{}\n{}\n{}\n![strain over time](strain_over_time.png)\n\n![time per stage](time_per_stage.png)\n",
        super::markdown_table(results),
        super::collision_table(results),
        super::constraints_table(results),
        super::scaling_table(results)
    );
    write_file(&dir.join("bench.md"), |w| std::io::Write::write_all(w, tables.as_bytes()))?;
    write_charts(dir, results)
}

/// Writes the `strain_over_time` and `time_per_stage` charts of `results` into `dir`.
fn write_charts(dir: &Path, results: &[BenchResult]) -> Result<(), PlotError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_owned(), source })?;
    super::plots::strain_over_time(dir, results)?;
    super::plots::time_per_stage(dir, results)
}

/// Writes `accuracy.csv`, `accuracy.md` (one table per scene) and the
/// `speed_against_error` chart (one curve per scene, PNG and SVG) into `dir`.
pub fn write_accuracy(dir: &Path, sweeps: &[SceneSweep]) -> Result<(), PlotError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_owned(), source })?;
    write_file(&dir.join("accuracy.csv"), |w| std::io::Write::write_all(w, accuracy::csv(sweeps).as_bytes()))?;
    let mut report = String::new();
    for (scene, points) in sweeps {
        let _ = writeln!(report, "### {scene}\n\n{}", accuracy::markdown_table(points));
    }
    report += "![speed against error](speed_against_error.png)\n";
    write_file(&dir.join("accuracy.md"), |w| std::io::Write::write_all(w, report.as_bytes()))?;
    super::plots::speed_against_error(dir, sweeps)
}

/// Writes `report`'s `soak.md`, `soak.csv` and the chart `soak.png` / `.svg` into `dir`.
pub fn write_soak(report: &SoakReport, dir: &Path) -> Result<(), PlotError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_owned(), source })?;
    let (md, csv) = (report.markdown(), report.csv());
    write_file(&dir.join("soak.md"), |w| std::io::Write::write_all(w, md.as_bytes()))?;
    write_file(&dir.join("soak.csv"), |w| std::io::Write::write_all(w, csv.as_bytes()))?;
    super::plots::soak_over_time(dir, report)
}
