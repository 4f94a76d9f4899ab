//! `drape bake` and `drape check-bake`: a scene simulated into a bake folder
//! (resumable, checked beside the simulation), and a sequence checked by the
//! independent checker.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use indicatif::{ProgressBar, ProgressStyle};

use drape::bake::output::BakeFolder;
use drape::bake::resume::{self, ResumeError};
use drape::bake::summary::BakeSummary;
use drape::bake::writer::{FinishedFrame, FrameWriter};
use drape::bake::{self, BakeError, Baker, FrameRecord};
use drape::io::atomic::WriteError;
use drape::metrics::sequence::check_sequence;
use drape::scene::Scene;

use crate::{Failure, input, load_scene};

/// `drape bake SCENE --out DIR [--frames N] [--resume]`: simulates the scene
/// into the bake folder, or goes on after its last checkpoint (`resume`).
pub(crate) fn run_bake(path: &Path, out: &Path, frames: Option<usize>, resume: bool) -> Result<(), Failure> {
    let scene = load_scene(path)?;
    let frames = frames.map_or(scene.frame_count, |n| n.min(scene.frame_count));
    let cancel = Arc::new(AtomicBool::new(false));
    let flag = cancel.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)).map_err(|e| Failure::Internal(e.to_string()))?;

    let again = || format!("`drape bake {} --out {} --resume` goes on from there", path.display(), out.display());
    let (mut baker, folder, mut records, fingerprint) = start_bake(&scene, out, frames, resume)?;
    let bar = ProgressBar::new(frames as u64).with_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} frames  {msg}  eta {eta}")
            .unwrap_or(ProgressStyle::default_bar()),
    );
    bar.set_position(baker.frame() as u64);
    let write_failed =
        |e: WriteError| input(format!("{e}\nthe finished frames are kept in {}; {}", out.display(), again()));
    let clock = std::time::Instant::now();
    let checker = baker.take_checker().ok_or_else(|| Failure::Internal("the bake has no checker".to_owned()))?;
    let (new_records, failure, folder) = std::thread::scope(|scope| {
        let mut writer = FrameWriter::start(scope, folder, checker, fingerprint);
        let ran = bake::run_from(&mut baker, frames, &cancel, |sim, record| {
            let checkpoint = writer.checkpoint_due();
            writer.send(FinishedFrame {
                frame: record.frame,
                time_s: sim.time(),
                positions: sim.positions().to_vec(),
                record: (record.frame > 0).then(|| record.clone()),
                snapshot: checkpoint.then(|| sim.snapshot()).transpose()?,
            })?;
            if record.frame > 0 {
                let ms = record.timings.total().as_secs_f64() * 1e3;
                bar.set_message(format!("{ms:.1} ms/frame, strain {:.2} %", record.max_strain * 100.0));
                bar.set_position(record.frame as u64);
            }
            Ok(())
        });
        // A bake cancelled between checkpoints saves where it stopped; a
        // complete one drops its working files, and one that failed
        // mid-frame goes on from its last checkpoint.
        let ran = ran.and_then(|(records, failure)| {
            let cancelled = failure.is_none() && baker.frame() < frames;
            if let (true, Some(frame)) = (cancelled, writer.unsaved_frame()) {
                writer.checkpoint(frame, baker.simulator().snapshot()?)?;
            }
            Ok((records, failure))
        });
        let written = writer.finish();
        let (_, failure) = ran.map_err(|e| match e {
            BakeError::Start(_) => input(e),
            BakeError::Write(e) => write_failed(e),
            BakeError::Step { .. } | BakeError::Snapshot(_) => Failure::Internal(e.to_string()),
        })?;
        let (folder, checked_records) = written.map_err(write_failed)?;
        Ok::<_, Failure>((checked_records, failure, folder))
    })?;
    bar.finish_and_clear();
    let wall_ms = clock.elapsed().as_secs_f64() * 1e3;
    let simulated = new_records.len();
    records.extend(new_records);

    let cancelled = cancel.load(Ordering::Relaxed) && records.len() < frames;
    let stopped = match (&failure, cancelled) {
        (Some(e), _) => Some(e.to_string()),
        (None, true) => Some("cancelled (Ctrl-C)".to_owned()),
        (None, false) => None,
    };
    let mut summary = BakeSummary::new(&scene, &records, frames, stopped);
    summary.ms_per_frame_wall = (simulated > 0).then(|| wall_ms / simulated as f64);
    folder.finish(&summary).map_err(input)?;
    print_bake_summary(&summary, &scene, out);
    match (failure, cancelled) {
        (Some(e), _) => Err(Failure::Internal(format!("{e} (frames before it are in {})", out.display()))),
        (None, true) => Err(Failure::Cancelled(format!(
            "cancelled: {} whole frames kept in {}; {}",
            records.len() + 1,
            out.display(),
            again()
        ))),
        (None, false) => Ok(()),
    }
}

/// The baker, the bake folder, the records of the frames already finished
/// and the scene's fingerprint: at frame 0 in a new folder, or, with
/// `resume`, after the last finished frame of the bake in `out`.
fn start_bake<'a>(
    scene: &'a Scene,
    out: &Path,
    frames: usize,
    resume: bool,
) -> Result<(Baker, BakeFolder<'a>, Vec<FrameRecord>, u32), Failure> {
    let mut baker = Baker::new(scene).map_err(input)?;
    let fingerprint = resume::fingerprint(scene, baker.simulator());
    if !resume {
        return Ok((baker, BakeFolder::create(out, scene).map_err(input)?, Vec::new(), fingerprint));
    }
    let (folder, checkpoint, records) = BakeFolder::reopen(out, scene, fingerprint).map_err(input)?;
    if checkpoint.frame > frames {
        let held =
            format!("{} holds {} finished frames, more than the {frames} asked for", out.display(), checkpoint.frame);
        return Err(input(format!("{held}: resume with --frames {} or more", checkpoint.frame)));
    }
    baker
        .resume_at(checkpoint.frame, &checkpoint.snapshot)
        .map_err(|source| input(ResumeError::State { dir: out.to_owned(), source }))?;
    println!("resuming the bake in {} after frame {}", out.display(), checkpoint.frame);
    Ok((baker, folder, records, fingerprint))
}

/// Prints a bake's last lines: speed, effort, strain, contacts, rollbacks.
fn print_bake_summary(summary: &BakeSummary, scene: &Scene, out: &Path) {
    println!(
        "{} frames of '{}' in {}: median {:.1} ms/frame of simulation{} on {} threads, {:.1} CG iterations/step, \
         max strain {:.2} % ({:.2} % where not pinned at both ends), at most {} particle-collider and {} triangle contacts",
        summary.frames,
        scene.name,
        out.display(),
        summary.ms_per_frame_median,
        summary
            .ms_per_frame_wall
            .map_or(String::new(), |ms| format!(" ({ms:.1} ms/frame with the checks and the writing)")),
        summary.threads,
        summary.cg_iterations_per_step_mean,
        summary.max_strain * 100.0,
        summary.max_free_strain * 100.0,
        summary.contacts_max,
        summary.triangle_contacts_max,
    );
    if let Some((frame, worst)) = &summary.limits_unreachable {
        println!(
            "{} of {} frames end with the strain limits out of reach of the pins; the worst, frame {frame}: {worst}; \
             beyond what the pins force, the largest strain not between pins is {:.2} % (frame {})",
            summary.frames_limits_unreachable,
            summary.frames - 1,
            summary.max_free_strain_reachable * 100.0,
            summary.max_free_strain_reachable_frame
        );
    }
    println!(
        "the cloth moves {:.1} mm/s on average over the last second (0 when it has come to rest)",
        summary.mean_speed_last_second_m_per_s * 1e3
    );
    if summary.steps_per_frame_mean < f64::from(summary.steps_per_frame) {
        println!(
            "{:.2} steps/frame on average of the {} nominal: longer steps while the cloth was calm \
             ({} taken again shorter; [solver] long_step_error = {})",
            summary.steps_per_frame_mean, summary.steps_per_frame, summary.long_steps_rejected, summary.long_step_error
        );
    }
    if summary.rollbacks > 0 {
        let causes = summary.rollback_causes.phrases().join(", ");
        println!("{} steps rolled back and retried halved ({causes})", summary.rollbacks);
    }
}

/// The scene a bake folder's summary names, if it still exists. Only that
/// field is read, so a summary from another version of drape still works.
pub(crate) fn scene_of_bake(dir: &Path) -> Option<PathBuf> {
    let text = std::fs::read_to_string(dir.join("summary.json")).ok()?;
    let summary: serde_json::Value = serde_json::from_str(&text).ok()?;
    summary.get("scene_file")?.as_str().map(PathBuf::from).filter(|p| p.is_file())
}

/// `drape check-bake DIR [--scene SCENE] [--json FILE]`: the independent
/// checker over every frame of an OBJ sequence (exit 3 when it finds any).
pub(crate) fn run_check_bake(dir: &Path, scene: Option<&Path>, json: Option<&Path>) -> Result<(), Failure> {
    let scene_path = scene.map(Path::to_owned).or_else(|| scene_of_bake(dir));
    let scene = match &scene_path {
        Some(path) => {
            println!("colliders from {}", path.display());
            Some(Scene::load(path).map_err(input)?)
        }
        None => {
            println!("no scene given: checking the cloth against itself only");
            None
        }
    };
    let checks = check_sequence(dir, scene.as_ref().map(Scene::obstacles), |c, _| {
        let i = &c.intersections;
        if i.pairs() + i.penetrating_vertices > 0 {
            println!(
                "frame {:>5} ({}): {} cloth-cloth pairs, {} cloth-collider triangles, {} vertices inside",
                c.frame, c.file, i.cloth_pairs, i.collider_pairs, i.penetrating_vertices
            );
        }
    })
    .map_err(input)?;
    if let Some(path) = json {
        let text = serde_json::to_string_pretty(&checks).map_err(|e| Failure::Internal(e.to_string()))?;
        drape::io::atomic::write_file(path, |out| std::io::Write::write_all(out, text.as_bytes())).map_err(input)?;
    }
    let bad = checks.iter().filter(|c| c.intersections.pairs() + c.intersections.penetrating_vertices > 0).count();
    let pairs: u32 = checks.iter().map(|c| c.intersections.pairs()).sum();
    let inside: u32 = checks.iter().map(|c| c.intersections.penetrating_vertices).sum();
    let verdict = format!(
        "{} frames checked: {bad} with problems ({pairs} intersecting triangle pairs, {inside} penetrating vertices in all)",
        checks.len()
    );
    match bad {
        0 => {
            println!("{verdict}");
            Ok(())
        }
        _ => Err(Failure::Found(verdict)),
    }
}
