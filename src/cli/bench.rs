//! `drape bench`: the suites, the speed-against-error sweep and the soak,
//! with their tables and charts.

use std::path::{Path, PathBuf};

use drape::bench;
use drape::bench::accuracy::ErrorMeasure;
use drape::scene::Scene;

use crate::{Failure, input, load_scene};

/// Sweeps each scene over `steps` × `tolerances`, prints each table, and
/// writes the results (one chart, a curve per scene) to `out`.
pub(crate) fn run_accuracy(
    scenes: &[(PathBuf, ErrorMeasure)],
    steps: &[u32],
    tolerances: &[f64],
    frames: Option<usize>,
    out: Option<&Path>,
) -> Result<(), Failure> {
    if let Some(bad) = steps.iter().find(|&&s| s == 0) {
        return Err(Failure::Input(format!("--steps: {bad} steps per frame is not a positive count")));
    }
    if let Some(bad) = tolerances.iter().find(|t| !(t.is_finite() && **t > 0.0 && **t < 1.0)) {
        return Err(Failure::Input(format!("--tolerances: {bad} is not between 0 and 1")));
    }
    let mut sweeps = Vec::new();
    let mut failures = Vec::new();
    for (path, measure) in scenes {
        let scene = Scene::load(path).map_err(input)?;
        match bench::accuracy::sweep(&scene, steps, tolerances, frames, *measure, |line| eprintln!("{line}")) {
            Ok(points) => {
                println!("{}\n{}", scene.name, bench::accuracy::markdown_table(&points));
                sweeps.push((scene.name, points));
            }
            Err(failure) => {
                eprintln!("{}: the reference run failed ({failure}); no sweep", scene.name);
                failures.push(format!("{}: {failure}", scene.name));
            }
        }
    }
    if let Some(dir) = out
        && !sweeps.is_empty()
    {
        bench::report::write_accuracy(dir, &sweeps).map_err(input)?;
        println!("wrote {}", dir.display());
    }
    match failures.is_empty() {
        true => Ok(()),
        false => Err(Failure::Internal(failures.join("; "))),
    }
}

/// `drape bench --suite S`: runs the suite's cases, prints the tables and,
/// with `out`, writes the CSV, Markdown and charts (exit 2 if a case stopped).
pub(crate) fn run_bench(suite: bench::Suite, frames: Option<usize>, out: Option<&Path>) -> Result<(), Failure> {
    let log = |line: &str| eprintln!("{line}");
    let results = bench::run(suite, frames, log).map_err(|e| Failure::Internal(e.to_string()))?;
    if !results.is_empty() {
        println!("{}", bench::markdown_table(&results));
        println!("{}", bench::collision_table(&results));
        println!("{}", bench::constraints_table(&results));
        if suite == bench::Suite::Scaling {
            println!("{}", bench::scaling_table(&results));
        }
        if let Some(dir) = out {
            bench::report::write_results(dir, &results).map_err(input)?;
        }
    }
    if matches!(suite, bench::Suite::Accuracy | bench::Suite::All) {
        let scenes = bench::ACCURACY_SCENES.map(|(name, measure)| (bench::standard_scene(name), measure));
        let (steps, tolerances) = (bench::ACCURACY_STEPS, bench::ACCURACY_TOLERANCES);
        run_accuracy(&scenes, &steps, &tolerances, frames, out.map(|d| d.join("accuracy")).as_deref())?;
    }
    if matches!(suite, bench::Suite::Peers | bench::Suite::All) {
        // Blender's frames are kept for inspection: in --out, or the system's temporary folder.
        let dir = out.map_or_else(|| std::env::temp_dir().join("drape-peers"), |d| d.join("peers"));
        let comparisons = bench::peers::compare(&dir, frames, log).map_err(|e| Failure::Internal(e.to_string()))?;
        let table = bench::peers::markdown_table(&comparisons);
        println!("{table}");
        if out.is_some() {
            let path = dir.join("peers.md");
            drape::io::atomic::write_file(&path, |w| std::io::Write::write_all(w, table.as_bytes())).map_err(input)?;
        }
    }
    if suite == bench::Suite::Soak {
        run_soak(frames, out)?;
    }
    if let Some(dir) = out {
        println!("wrote {}", dir.display());
    }
    let stopped: Vec<&str> = results.iter().filter(|r| r.summary.stopped.is_some()).map(|r| r.case.as_str()).collect();
    if !stopped.is_empty() {
        return Err(Failure::Internal(format!("{} stopped early (see above)", stopped.join(", "))));
    }
    Ok(())
}

/// The soak benchmark on `skirt_walk_loop`: 20,000 steps, or `frames` frames.
fn run_soak(frames: Option<usize>, out: Option<&Path>) -> Result<(), Failure> {
    let scene = load_scene(&bench::standard_scene("skirt_walk_loop"))?;
    let steps = frames.map_or(bench::soak::SOAK_STEPS, |f| f * scene.steps_per_frame as usize);
    let report =
        bench::soak::run(&scene, steps, |line| eprintln!("{line}")).map_err(|e| Failure::Internal(e.to_string()))?;
    println!("{}", report.markdown());
    if let Some(dir) = out {
        bench::report::write_soak(&report, dir).map_err(input)?;
    }
    Ok(())
}
