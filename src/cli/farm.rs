//! `drape sweep` and `drape farm run | task | status | collect`: variants of
//! a scene baked by a scheduler (Slurm job arrays) or on this machine.

use std::path::{Path, PathBuf};
use std::process::Command;

use drape::bake::resume::ResumeLog;
use drape::farm::FarmError;
use drape::farm::layout::{BAKE, Entry, FAILED, KEY, PARTIAL, VariantState, read_manifest, state, write_sweep};
use drape::farm::reference::{ERROR_FILE, measure};
use drape::farm::report::{contact_sheet, csv_text, markdown, table};
use drape::farm::sweep::Sweep;
use drape::io::atomic::write_file;
use drape::render::Gpu;
use drape::render::lights::LightRig;
use drape::scene::Scene;
use drape::stage::offscreen::write_png;
use std::sync::atomic::AtomicBool;

use super::bake::run_bake;
use crate::{Failure, input};

/// `drape sweep SPEC --out DIR`.
pub fn run_sweep(spec: &Path, out: &Path) -> Result<(), Failure> {
    let sweep = Sweep::load(spec).map_err(input)?;
    let entries = write_sweep(&sweep, out).map_err(input)?;
    for entry in &entries {
        println!("{}  {}  {}  {}", entry.folder, &entry.key[..12], state(out, entry).word(), entry.label);
    }
    println!("{} variants in {}", entries.len(), out.display());
    Ok(())
}

/// Where `farm run` runs the tasks.
pub enum Runner {
    /// An sbatch job array, with these extra sbatch arguments.
    Slurm(Vec<String>),
    /// This machine, this many tasks at a time.
    Local(usize),
}

/// `drape farm run DIR --slurm | --local [-j N]`: the variants not finished
/// (nor failed, unless `retry_failed`) as tasks.
pub fn run_farm(dir: &Path, runner: &Runner, retry_failed: bool) -> Result<(), Failure> {
    let entries = read_manifest(dir).map_err(input)?;
    if retry_failed {
        for entry in &entries {
            let _ = std::fs::remove_file(entry.dir(dir).join(FAILED));
        }
    }
    let todo: Vec<&Entry> =
        entries.iter().filter(|e| matches!(state(dir, e), VariantState::Pending | VariantState::Started)).collect();
    if todo.is_empty() {
        println!("nothing to run: every variant is finished or failed (`drape farm status {}`)", dir.display());
        return Ok(());
    }
    match runner {
        Runner::Slurm(extra) => submit(dir, &todo, extra),
        Runner::Local(jobs) => run_locally(dir, &todo, (*jobs).max(1)),
    }
}

/// Writes the array script and submits it; prints the job id.
fn submit(dir: &Path, todo: &[&Entry], extra: &[String]) -> Result<(), Failure> {
    let sweep = Sweep::load(&dir.join("sweep.toml")).map_err(input)?;
    let dir = std::fs::canonicalize(dir).map_err(|e| input(format!("{}: {e}", dir.display())))?;
    let exe = std::env::current_exe().map_err(|e| Failure::Internal(e.to_string()))?;
    let logs = dir.join("logs");
    std::fs::create_dir_all(&logs).map_err(|e| input(format!("{}: {e}", logs.display())))?;
    let indices: Vec<String> = todo.iter().map(|e| e.index.to_string()).collect();
    let mut script = format!(
        "#!/bin/bash\n# Written by `drape farm run --slurm`: one array task per variant not yet finished.\n\
         #SBATCH --job-name=drape-farm\n#SBATCH --array={}\n#SBATCH --cpus-per-task={}\n",
        indices.join(","),
        sweep.slurm.cpus_per_task
    );
    if let Some(mem) = &sweep.slurm.mem {
        script += &format!("#SBATCH --mem={mem}\n");
    }
    if let Some(time) = &sweep.slurm.time {
        script += &format!("#SBATCH --time={time}\n");
    }
    script += &format!(
        "#SBATCH --requeue\n#SBATCH --open-mode=append\n#SBATCH --output={}/%a.log\n\
         exec {} --threads {} farm task {} \"$SLURM_ARRAY_TASK_ID\"\n",
        logs.display(),
        shell_word(&exe.display().to_string()),
        sweep.slurm.cpus_per_task,
        shell_word(&dir.display().to_string())
    );
    let path = dir.join("farm.sbatch");
    write_file(&path, |out| std::io::Write::write_all(out, script.as_bytes())).map_err(input)?;
    let output = Command::new("sbatch")
        .arg("--parsable")
        .args(extra)
        .arg(&path)
        .output()
        .map_err(|e| input(format!("cannot run sbatch ({e}): is this a Slurm submit host? `--local` runs here")))?;
    if !output.status.success() {
        return Err(input(format!(
            "sbatch refused {}: {}",
            path.display(),
            String::from_utf8_lossy(&output.stderr).trim()
        )));
    }
    let job = String::from_utf8_lossy(&output.stdout).trim().split(';').next().unwrap_or_default().to_owned();
    let jobs = dir.join("jobs.txt");
    let mut known = std::fs::read_to_string(&jobs).unwrap_or_default();
    known += &format!("{job}\n");
    write_file(&jobs, |out| std::io::Write::write_all(out, known.as_bytes())).map_err(input)?;
    println!("submitted job {job}: {} tasks (logs in {})", todo.len(), logs.display());
    Ok(())
}

/// A path quoted for bash.
fn shell_word(text: &str) -> String {
    format!("'{}'", text.replace('\'', r"'\''"))
}

/// Runs the tasks here, `jobs` at a time, each with cores / `jobs` threads;
/// each task's output goes to its folder's `task.log`.
fn run_locally(dir: &Path, todo: &[&Entry], jobs: usize) -> Result<(), Failure> {
    let exe = std::env::current_exe().map_err(|e| Failure::Internal(e.to_string()))?;
    let cores = std::thread::available_parallelism().map_or(1, usize::from);
    let threads = (cores / jobs).max(1);
    let mut queue = todo.iter();
    let mut running: Vec<(usize, std::process::Child)> = Vec::new();
    let (mut finished, mut failed) = (0, 0);
    loop {
        while running.len() < jobs {
            let Some(entry) = queue.next() else { break };
            let log = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(entry.dir(dir).join("task.log"))
                .map_err(|e| input(format!("{}: {e}", entry.dir(dir).display())))?;
            let child = Command::new(&exe)
                .args(["--threads", &threads.to_string(), "farm", "task"])
                .arg(dir)
                .arg(entry.index.to_string())
                .stdout(log.try_clone().map_err(|e| Failure::Internal(e.to_string()))?)
                .stderr(log)
                .spawn()
                .map_err(|e| Failure::Internal(format!("cannot start a task: {e}")))?;
            running.push((entry.index, child));
        }
        if running.is_empty() {
            break;
        }
        // Whichever task ends first frees its slot for the next one.
        let (index, status) = next_to_end(&mut running)?;
        if status.success() {
            finished += 1;
        } else {
            failed += 1;
            eprintln!(
                "variant {index} failed ({status}): see {}",
                dir.join(format!("v{index:04}")).join("task.log").display()
            );
        }
    }
    println!("{finished} variants baked, {failed} failed, in {}", dir.display());
    if failed > 0 { Err(Failure::Internal(format!("{failed} variants failed"))) } else { Ok(()) }
}

/// Waits until one of the `running` tasks ends; removes it and returns its
/// variant and exit status.
fn next_to_end(running: &mut Vec<(usize, std::process::Child)>) -> Result<(usize, std::process::ExitStatus), Failure> {
    loop {
        for k in 0..running.len() {
            if let Some(status) = running[k].1.try_wait().map_err(|e| Failure::Internal(e.to_string()))? {
                return Ok((running.remove(k).0, status));
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

/// `drape farm task DIR INDEX`: bakes one variant into its `bake.partial`
/// (resumed if a checkpoint is there), then renames it to `bake`. Does
/// nothing for a finished or failed variant; a simulation that stops, or a
/// scene that cannot be read, is recorded in `failed.txt`.
pub fn run_task(dir: &Path, index: usize) -> Result<(), Failure> {
    let entries = read_manifest(dir).map_err(input)?;
    let entry = entries
        .get(index)
        .ok_or_else(|| input(format!("{}: no variant {index} (0..{})", dir.display(), entries.len())))?;
    match state(dir, entry) {
        VariantState::Finished => {
            println!("variant {index} is already finished");
            return Ok(());
        }
        VariantState::Failed(reason) => {
            println!("variant {index} failed before, not retried (`drape farm run --retry-failed`): {reason}");
            return Ok(());
        }
        VariantState::Started | VariantState::Pending => {}
    }
    let folder = entry.dir(dir);
    let partial = folder.join(PARTIAL);
    let resume = ResumeLog::has_checkpoint(&partial);
    println!("variant {index} ({}): {}", entry.label, if resume { "resuming" } else { "baking" });
    let baked = run_bake(&folder.join("scene.toml"), &partial, entry.frames, resume);
    let measured = baked.and_then(|()| if entry.reference { measure_error(&folder, &partial) } else { Ok(()) });
    match measured {
        Ok(()) => finish(&folder, &partial, &entry.key).map_err(input),
        // Stopped by the scheduler (SIGTERM) or Ctrl-C: the next task resumes.
        Err(Failure::Cancelled(reason)) => Err(Failure::Cancelled(reason)),
        // A simulation that stops, or a scene this node cannot read, would
        // fail the same way again: recorded, not retried.
        Err(Failure::Internal(reason) | Failure::Input(reason)) => {
            let text = format!("{reason}\n");
            write_file(&folder.join(FAILED), |out| std::io::Write::write_all(out, text.as_bytes())).map_err(input)?;
            Err(Failure::Internal(reason))
        }
        Err(other) => Err(other),
    }
}

/// Runs the variant's reference and writes its error into the bake.
fn measure_error(folder: &Path, partial: &Path) -> Result<(), Failure> {
    let scene = Scene::load(&folder.join("scene.toml")).map_err(input)?;
    let cancel = AtomicBool::new(false);
    println!("measuring the error against the 16x reference");
    let error = measure(&scene, partial, &cancel).map_err(Failure::Internal)?;
    let text = serde_json::to_string_pretty(&error).map_err(|e| Failure::Internal(e.to_string()))?;
    write_file(&partial.join(ERROR_FILE), |out| std::io::Write::write_all(out, text.as_bytes())).map_err(input)
}

/// Marks a complete bake with its key and moves it into place.
fn finish(folder: &Path, partial: &Path, key: &str) -> Result<(), FarmError> {
    let marked = partial.join(KEY);
    write_file(&marked, |out| std::io::Write::write_all(out, key.as_bytes()))
        .map_err(|e| FarmError::io(&marked, e.source))?;
    let bake = folder.join(BAKE);
    if bake.exists() {
        std::fs::remove_dir_all(&bake).map_err(|e| FarmError::io(&bake, e))?;
    }
    std::fs::rename(partial, &bake).map_err(|e| FarmError::io(&bake, e))
}

/// `drape farm status DIR`: each variant's state, with Slurm's view of the
/// tasks of the jobs submitted from DIR when `squeue` is there.
pub fn run_status(dir: &Path) -> Result<(), Failure> {
    let entries = read_manifest(dir).map_err(input)?;
    let queued = slurm_states(dir);
    let mut counts = std::collections::BTreeMap::new();
    for entry in &entries {
        let now = state(dir, entry);
        let word = match (&now, queued.get(&entry.index)) {
            (VariantState::Pending | VariantState::Started, Some(slurm)) => slurm.to_lowercase(),
            _ => now.word().to_owned(),
        };
        let reason = match &now {
            VariantState::Failed(reason) => format!(": {reason}"),
            _ => String::new(),
        };
        println!("{}  {:<10} {}{reason}", entry.folder, word, entry.label);
        *counts.entry(word).or_insert(0) += 1;
    }
    let totals: Vec<String> = counts.iter().map(|(word, n)| format!("{n} {word}")).collect();
    println!("{} variants: {}", entries.len(), totals.join(", "));
    Ok(())
}

/// Array task index → Slurm state, for the jobs listed in DIR/jobs.txt
/// (empty without `squeue` or jobs).
fn slurm_states(dir: &Path) -> std::collections::HashMap<usize, String> {
    let jobs = std::fs::read_to_string(dir.join("jobs.txt")).unwrap_or_default();
    let ids: Vec<&str> = jobs.lines().filter(|l| !l.trim().is_empty()).collect();
    if ids.is_empty() {
        return Default::default();
    }
    let Ok(output) = Command::new("squeue").args(["-h", "-r", "-o", "%i %T", "-j", &ids.join(",")]).output() else {
        return Default::default();
    };
    String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter_map(|line| {
            let (id, state) = line.split_once(' ')?;
            let index = id.rsplit_once('_')?.1.parse().ok()?;
            Some((index, state.trim().to_owned()))
        })
        .collect()
}

/// `drape farm collect DIR`: `report.csv`, `report.md` and
/// `contact_sheet.png` (frame `frame` of every variant under `rig`) in `out`
/// (default DIR).
pub fn run_collect(dir: &Path, frame: usize, rig: &str, out: Option<&Path>) -> Result<(), Failure> {
    let entries = read_manifest(dir).map_err(input)?;
    let out = out.map_or_else(|| dir.to_owned(), Path::to_owned);
    std::fs::create_dir_all(&out).map_err(|e| input(format!("{}: {e}", out.display())))?;
    let rows = table(dir, &entries).map_err(input)?;
    let csv = csv_text(&rows).map_err(|e| Failure::Internal(e.to_string()))?;
    write_file(&out.join("report.csv"), |w| std::io::Write::write_all(w, &csv)).map_err(input)?;
    let md = markdown(&rows);
    write_file(&out.join("report.md"), |w| std::io::Write::write_all(w, md.as_bytes())).map_err(input)?;
    print!("{md}");
    let rig = LightRig::find(rig).map_err(input)?;
    let gpu = Gpu::headless().map_err(|e| Failure::Internal(e.to_string()))?;
    let sheet = contact_sheet(&gpu, dir, &entries, frame, &rig).map_err(input)?;
    let png: PathBuf = out.join("contact_sheet.png");
    write_png(&png, &sheet).map_err(input)?;
    println!("wrote {}, {} and {}", out.join("report.csv").display(), out.join("report.md").display(), png.display());
    Ok(())
}
