//! Benchmarks: speed of the simulation alone (no I/O) on the standard scenes,
//! always reported with the strain it reached, as CSV and Markdown.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use crate::bake::summary::BakeSummary;
use crate::bake::{self, BakeError};
use crate::io::atomic::{WriteError, write_file};
use crate::scene::file::MeshSpec;
use crate::scene::{Scene, SceneError};

/// One measured case.
#[derive(Clone, Debug)]
pub struct BenchResult {
    /// Scene and variant, e.g. `drape_sphere N=64`.
    pub case: String,
    /// Its summary (speed, stages, solver effort, strain).
    pub summary: BakeSummary,
}

/// Why a benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// A standard scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] SceneError),
    /// A case failed.
    #[error(transparent)]
    Bake(#[from] BakeError),
}

/// Path of a standard scene: `assets/scenes/<name>.toml`, looked up in the
/// current folder, then in the source tree drape was built from.
pub fn standard_scene(name: &str) -> PathBuf {
    let relative = Path::new("assets/scenes").join(format!("{name}.toml"));
    if relative.exists() { relative } else { Path::new(env!("CARGO_MANIFEST_DIR")).join(relative) }
}

/// The core suite: `drape_sphere` at N = 64 and N = 128, self-contact off.
pub fn run_core(frames: Option<usize>, log: impl Fn(&str)) -> Result<Vec<BenchResult>, BenchError> {
    let mut results = Vec::new();
    for n in [64, 128] {
        let scene = Scene::load_edited(&standard_scene("drape_sphere"), |file| {
            if let Some(MeshSpec::Grid { resolution, .. }) = file.garments.first_mut().map(|g| &mut g.mesh) {
                *resolution = n;
            }
        })?;
        let case = format!("{} N={n}", scene.name);
        log(&format!("running {case} ..."));
        results.push(BenchResult { summary: measure(&scene, frames)?, case });
    }
    Ok(results)
}

/// Runs `scene` (the first `frames` frames, or all) and summarises it.
pub fn measure(scene: &Scene, frames: Option<usize>) -> Result<BakeSummary, BakeError> {
    let frames = frames.map_or(scene.frame_count, |n| n.min(scene.frame_count));
    let (records, failure) = bake::run(scene, frames, &AtomicBool::new(false), |_, _| Ok(()))?;
    if let Some(failure) = failure {
        return Err(failure);
    }
    Ok(BakeSummary::new(scene, &records, frames, None))
}

/// Names of the step's stages, in pipeline order.
fn stage_names() -> impl Iterator<Item = &'static str> {
    crate::sim::step::StageTimings::default().stages().into_iter().map(|(name, _)| name)
}

/// The results as a Markdown table.
pub fn markdown_table(results: &[BenchResult]) -> String {
    let mut out = String::from("| case | vertices | threads | ms/frame (median) |");
    for stage in stage_names() {
        let _ = write!(out, " {stage} |");
    }
    out += " CG it/step | max strain |\n|---|---:|---:|---:|";
    for _ in stage_names() {
        out += "---:|";
    }
    out += "---:|---:|\n";
    for r in results {
        let s = &r.summary;
        let _ = write!(out, "| {} | {} | {} | {:.2} |", r.case, s.vertices, s.threads, s.ms_per_frame_median);
        for stage in stage_names() {
            let _ = write!(out, " {:.2} |", s.stage_ms_per_frame_median.get(stage).copied().unwrap_or(0.0));
        }
        let _ = writeln!(out, " {:.1} | {:.3} % |", s.cg_iterations_per_step_mean, s.max_strain * 100.0);
    }
    out
}

/// The results as CSV, one row per case.
pub fn csv(results: &[BenchResult]) -> String {
    let mut out = String::from("case,vertices,threads,frames,steps_per_frame,ms_per_frame_median");
    for stage in stage_names() {
        let _ = write!(out, ",{stage}_ms");
    }
    out += ",cg_iterations_per_step,max_strain,contacts_max\n";
    for r in results {
        let s = &r.summary;
        let _ = write!(
            out,
            "{},{},{},{},{},{:.4}",
            r.case, s.vertices, s.threads, s.frames, s.steps_per_frame, s.ms_per_frame_median
        );
        for stage in stage_names() {
            let _ = write!(out, ",{:.4}", s.stage_ms_per_frame_median.get(stage).copied().unwrap_or(0.0));
        }
        let _ = writeln!(out, ",{:.2},{:.6},{}", s.cg_iterations_per_step_mean, s.max_strain, s.contacts_max);
    }
    out
}

/// Writes `bench.csv` and `bench.md` into `dir`.
pub fn write_results(dir: &Path, results: &[BenchResult]) -> Result<(), WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError { path: dir.to_owned(), source })?;
    write_file(&dir.join("bench.csv"), |w| std::io::Write::write_all(w, csv(results).as_bytes()))?;
    write_file(&dir.join("bench.md"), |w| std::io::Write::write_all(w, markdown_table(results).as_bytes()))
}
