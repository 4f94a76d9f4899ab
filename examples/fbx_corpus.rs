//! drape's FBX reader over a corpus of files written by the real
//! applications (the ufbx project's `data/` folder): how many files load,
//! and how far each evaluated mesh is from the OBJ the source application
//! exported at the same frame. docs/fbx.md quotes its output.
//!
//!     cargo run --release --example fbx_corpus -- UFBX_DATA_DIR CHECKS.tsv
//!
//! `CHECKS.tsv` lists the reference checks, one per line: FBX file, OBJ
//! file (both relative to the folder above `UFBX_DATA_DIR`), time in
//! seconds or `static`, and a stack name (or nothing) in columns 1, 2, 3
//! and 6; only rows whose 7th column starts with `[default]` are run
//! (`tools/ufbx_checks.tsv` lists every check of the ufbx corpus). A mesh passes
//! within 0.01 % of its bounding-box diagonal.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use clap::Parser;
use drape::body::Body;
use drape::io::fbx::{BodyOptions, FbxError, read_body};
use drape::metrics::pose_error::{compare, read_reference};

/// The command line.
#[derive(Parser)]
struct Args {
    /// The corpus folder (every `.fbx` under it is loaded).
    data: PathBuf,
    /// The reference checks (TSV).
    checks: PathBuf,
    /// Print every failing check and file.
    #[arg(long)]
    verbose: bool,
}

/// Largest deviation accepted, % of a mesh's bounding-box diagonal.
const TOLERANCE_PERCENT: f64 = 0.01;

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    load_every_file(&args.data, args.verbose);
    let checks = std::fs::read_to_string(&args.checks).with_context(|| args.checks.display().to_string())?;
    let root = args.data.parent().unwrap_or(Path::new("."));
    run_checks(root, &checks, args.verbose);
    Ok(())
}

/// The format class of a file, from its name: `7x binary`, `6x ascii`...
fn class_of(path: &Path) -> String {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let format = if name.contains("_ascii") { "ascii" } else { "binary" };
    let version = name.split('_').find_map(|w| w.parse::<u32>().ok().filter(|v| (1000..10_000).contains(v)));
    match version {
        Some(v) if v >= 7000 => format!("7.x {format}"),
        Some(v) => format!("{}.x {format}", v / 1000),
        None => format!("other {format}"),
    }
}

/// The application that wrote a file, from its name in the corpus
/// (`maya_...`, `max_...`), or `synthetic` for files made by hand.
fn application_of(path: &Path) -> &'static str {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let known = ["maya", "max", "motionbuilder", "blender", "marvelous", "zbrush", "revit", "houdini", "modo", "unity"];
    known.into_iter().find(|app| name.starts_with(app)).unwrap_or("synthetic")
}

/// Loads every FBX file: counts per class of loaded / refused / panicked, and the slowest.
fn load_every_file(data: &Path, verbose: bool) {
    let mut files = Vec::new();
    collect(data, &mut files);
    files.sort();
    let mut table: BTreeMap<String, [usize; 6]> = BTreeMap::new();
    let mut slowest = (0.0, PathBuf::new());
    for path in &files {
        let started = Instant::now();
        let result = std::panic::catch_unwind(|| read_body(path, &BodyOptions::default()));
        let seconds = started.elapsed().as_secs_f64();
        if seconds > slowest.0 {
            slowest = (seconds, path.clone());
        }
        let fuzz = path.components().any(|c| c.as_os_str() == "fuzz");
        let class = match (fuzz, class_of(path)) {
            (true, _) => "fuzz".to_owned(),
            (false, c) if c.starts_with("7.x") => format!("{c}, {}", application_of(path)),
            (false, c) => c,
        };
        let row = table.entry(class).or_default();
        row[0] += 1;
        match result {
            Ok(Ok(_)) => row[1] += 1,
            Ok(Err(FbxError::NoMesh { .. })) => row[2] += 1,
            Ok(Err(FbxError::VertexCache { .. })) => row[3] += 1,
            Ok(Err(e)) => {
                row[4] += 1;
                if verbose && !fuzz {
                    println!("refused: {e}");
                }
            }
            Err(_) => {
                row[5] += 1;
                println!("PANIC: {}", path.display());
            }
        }
    }
    println!(
        "| files | count | load | no polygon mesh | vertex cache | other errors | panics | load, of files with a mesh |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for (class, [n, ok, no_mesh, cache, other, panics]) in &table {
        let rest = n - no_mesh - cache;
        let rate = 100.0 * *ok as f64 / rest.max(1) as f64;
        println!("| {class} | {n} | {ok} | {no_mesh} | {cache} | {other} | {panics} | {rate:.1} % |");
    }
    println!("slowest: {:.3} s, {}", slowest.0, slowest.1.display());
}

fn collect(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            collect(&path, out);
        } else if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("fbx")) {
            out.push(path);
        }
    }
}

/// One reference check.
struct Check {
    fbx: PathBuf,
    obj: PathBuf,
    time_s: Option<f64>,
    stack: Option<String>,
    /// Why the check is not one drape should pass, if it is not.
    out_of_scope: Option<&'static str>,
}

/// Why a check asks for something else than evaluating the file as its
/// application shows it (from the check's notes), if it does.
fn out_of_scope(notes: &str) -> Option<&'static str> {
    [
        ("subdivides", "the reference is a subdivision surface"),
        ("EXPECTED_TO_FAIL", "the reference is in converted axes"),
        ("NO_EXTRAPOLATION", "the reference holds curves outside their keys"),
    ]
    .into_iter()
    .find(|(key, _)| notes.contains(key))
    .map(|(_, why)| why)
}

fn parse_checks(root: &Path, text: &str) -> Vec<Check> {
    text.lines()
        .skip(1)
        .filter_map(|line| {
            let c: Vec<&str> = line.split('\t').collect();
            if c.len() < 7 || !c[6].starts_with("[default]") {
                return None;
            }
            Some(Check {
                fbx: root.join(c[0]),
                obj: root.join(c[1]),
                time_s: c[2].parse().ok(),
                stack: Some(c[5].to_owned()).filter(|s| !s.is_empty()),
                out_of_scope: out_of_scope(c[6]),
            })
        })
        .collect()
}

/// The stack whose name contains `part` (as ufbx's tests choose it).
fn stack_containing(body: &Body, part: &str) -> Option<String> {
    body.stacks.iter().find(|s| s.name.contains(part)).map(|s| s.name.clone())
}

/// Runs every check: per class, checks passed and meshes within tolerance.
fn run_checks(root: &Path, text: &str, verbose: bool) {
    let mut table: BTreeMap<String, [usize; 2]> = BTreeMap::new();
    let mut skipped: BTreeMap<&str, usize> = BTreeMap::new();
    for check in parse_checks(root, text) {
        if let Some(why) = check.out_of_scope {
            *skipped.entry(why).or_default() += 1;
            continue;
        }
        let row = table.entry(class_of(&check.fbx)).or_default();
        row[0] += 1;
        let result = run_check(&check);
        if let Err(e) = &result
            && let Some(FbxError::NoMesh { .. } | FbxError::VertexCache { .. }) = e.downcast_ref::<FbxError>()
        {
            row[0] -= 1;
            *skipped.entry("drape refuses the file by design (vertex cache, or no polygon mesh)").or_default() += 1;
            continue;
        }
        match result {
            Ok(worst) if worst <= TOLERANCE_PERCENT * reference_scale(&check.obj) => row[1] += 1,
            Ok(worst) if verbose => println!("off {worst:.4} %: {} at {:?}", check.fbx.display(), check.time_s),
            Err(e) if verbose => println!("failed: {} at {:?}: {e}", check.fbx.display(), check.time_s),
            _ => {}
        }
    }
    println!("| files | reference frames | within {TOLERANCE_PERCENT} % |\n|---|---:|---:|");
    for (class, [n, ok]) in &table {
        println!("| {class} | {n} | {ok} ({:.1} %) |", 100.0 * *ok as f64 / (*n).max(1) as f64);
    }
    for (why, n) in skipped {
        println!("left out: {n} checks where {why}");
    }
}

/// How much coarser than its digits a reference is: ufbx's authors mark
/// OBJs whose application rounded positions with `ufbx:position_scale=0.1`.
fn reference_scale(obj: &Path) -> f64 {
    let text = std::fs::read_to_string(obj).unwrap_or_default();
    let scale = text.lines().take(20).find_map(|l| l.split("ufbx:position_scale=").nth(1)?.trim().parse::<f64>().ok());
    scale.filter(|s| *s > 0.0).map_or(1.0, |s| 1.0 / s)
}

/// The worst mesh of one check, % of its diagonal.
fn run_check(check: &Check) -> anyhow::Result<f64> {
    let mut body = read_body(&check.fbx, &BodyOptions::default())?;
    if let Some(part) = &check.stack {
        let name = stack_containing(&body, part).with_context(|| format!("no stack like '{part}'"))?;
        body = read_body(&check.fbx, &BodyOptions { stack: Some(name), ..Default::default() })?;
    }
    let mut positions = Vec::new();
    match (check.time_s, &body.motion) {
        (Some(t), Some(motion)) => body.pose_in_file(motion, t - motion.start_s, &mut positions),
        _ => body.static_in_file(&mut positions),
    }
    let reference = read_reference(&check.obj).map_err(anyhow::Error::msg)?;
    let errors = compare(&body, &positions, &reference);
    if std::env::var_os("FBX_CORPUS_DETAIL").is_some() {
        for e in &errors {
            println!("  {} -> {:?}: {:.5} % (ordered {})", e.reference, e.part, e.percent_of_diagonal(), e.ordered);
        }
    }
    if let Some(unmatched) = errors.iter().find(|e| e.part.is_none()) {
        anyhow::bail!("no mesh for group '{}'", unmatched.reference);
    }
    Ok(errors.iter().map(|e| e.percent_of_diagonal()).fold(0.0, f64::max))
}
