//! The bake's frames finished on a thread of their own: each frame is
//! checked by the independent intersection checker, and its OBJ, its
//! point-cache samples and its record are written, in frame order, while the
//! simulation goes on with the next frames. About once a second, and where
//! Ctrl-C stopped the bake, the writer also puts everything on disk and
//! writes the checkpoint `--resume` goes on from, with the simulation's
//! state at the end of that frame.
//!
//! Done in line, this cost `skirt_walk` about 20 ms of its ~60 ms of wall
//! time per frame: 15 ms writing, most of it waiting for the four syncs of
//! a checkpoint, and 4 ms checking (`drape bake`, temporary timers,
//! 2026-12-03). A checkpoint holds the solver's state, the kept factor's
//! blocks too: 9.3 MB for `drape_table`, which a checkpoint after every
//! frame wrote and synced six times a second.
//!
//! The writer's thread, and the one-thread pool its checks run on, take the
//! least priority (on Linux), so that they run on what the simulation leaves
//! idle rather than between its parallel tasks: `drape_table`'s simulation
//! went from 60.5-65.3 to 57.4-59.5 ms per frame median inside `drape bake`
//! (2026-12-05).
//!
//! The simulation runs at most [`QUEUE`] frames ahead of the disk, so memory
//! stays bounded when the disk is slower than the solver. A killed bake
//! loses the frames after its last checkpoint, at most about a second of
//! work and the queue, and `--resume` simulates them again (the same bits).

use std::path::{Path, PathBuf};
use std::sync::mpsc::{SyncSender, sync_channel};
use std::thread::{Scope, ScopedJoinHandle};
use std::time::{Duration, Instant};

use nalgebra::Vector3;

use super::FrameRecord;
use super::output::BakeFolder;
use crate::io::atomic::WriteError;
use crate::metrics::intersections::Checker;
use crate::sim::snapshot::Snapshot;

/// Finished frames that may wait for the writer.
const QUEUE: usize = 4;

/// Gives the calling thread the least scheduling priority (nice 19), on Linux
/// where each thread has its own: the checks and the writing then run on
/// whatever the simulation leaves idle, and the queue bounds how far behind
/// they fall. Elsewhere the priority is the process's, and left alone.
fn yield_to_the_simulation() {
    #[cfg(target_os = "linux")]
    // SAFETY: setpriority reads and writes no memory of ours; on Linux,
    // PRIO_PROCESS with id 0 names the calling thread. A failure leaves the
    // priority as it was, which is harmless.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, 0, 19);
    }
}

/// Wall time between two checkpoints.
const CHECKPOINT_EVERY: Duration = Duration::from_secs(1);

/// A finished frame, as the writer needs it.
pub struct FinishedFrame {
    /// Frame number (0: the initial state).
    pub frame: usize,
    /// Simulated time at the end of the frame, s.
    pub time_s: f64,
    /// Every garment's positions, concatenated, m.
    pub positions: Vec<Vector3<f64>>,
    /// The frame's record (none for frame 0).
    pub record: Option<FrameRecord>,
    /// The simulation's state after the frame, when a checkpoint is due
    /// ([`FrameWriter::checkpoint_due`]).
    pub snapshot: Option<Snapshot>,
}

/// What the writer is asked to do.
enum Job {
    /// Check and write a frame (and its checkpoint, with a snapshot).
    Frame(Box<FinishedFrame>),
    /// Write the checkpoint of the last frame written, which had none.
    Checkpoint { frame: usize, snapshot: Box<Snapshot> },
}

/// What the writer gives back: the folder, and the frames' records with
/// what the checker found.
type Written<'a> = (BakeFolder<'a>, Vec<FrameRecord>);

/// The writer thread of a bake folder.
pub struct FrameWriter<'scope, 'a> {
    /// The bake folder, for errors.
    dir: PathBuf,
    queue: Option<SyncSender<Job>>,
    thread: Option<ScopedJoinHandle<'scope, Result<Written<'a>, WriteError>>>,
    /// When the last frame with a snapshot was handed over.
    last_checkpoint: Option<Instant>,
    /// The last frame handed over, if it had no snapshot.
    unsaved: Option<usize>,
}

impl<'scope, 'a: 'scope> FrameWriter<'scope, 'a> {
    /// Starts checking frames with `checker` (the scene's, taken from its
    /// [`super::Baker`]) and writing them to `folder` on a thread of `scope`;
    /// `fingerprint` is the scene's, for the checkpoints.
    pub fn start<'env>(
        scope: &'scope Scope<'scope, 'env>,
        mut folder: BakeFolder<'a>,
        checker: Checker,
        fingerprint: u32,
    ) -> Self {
        let dir = folder.dir().to_owned();
        let (queue, jobs) = sync_channel::<Job>(QUEUE);
        let thread = scope.spawn(move || {
            yield_to_the_simulation();
            // The checks' parallel loops run on a pool of their own, which
            // yields too, rather than among the simulation's tasks.
            let pool = rayon::ThreadPoolBuilder::new().num_threads(1).start_handler(|_| yield_to_the_simulation());
            let pool = pool.build().ok();
            let check = |positions: &[Vector3<f64>], t: f64| match &pool {
                Some(pool) => pool.install(|| checker.check(positions, t)),
                None => checker.check(positions, t),
            };
            let mut records = Vec::new();
            for job in jobs {
                match job {
                    Job::Frame(mut f) => {
                        folder.write_frame(f.frame, f.time_s, &f.positions)?;
                        if let Some(record) = &mut f.record {
                            record.intersections = check(&f.positions, f.time_s);
                            folder.add_record(record)?;
                        }
                        if let Some(snapshot) = f.snapshot {
                            folder.checkpoint(f.frame, fingerprint, snapshot)?;
                        }
                        records.extend(f.record);
                    }
                    Job::Checkpoint { frame, snapshot } => folder.checkpoint(frame, fingerprint, *snapshot)?,
                }
            }
            Ok((folder, records))
        });
        FrameWriter { dir, queue: Some(queue), thread: Some(thread), last_checkpoint: None, unsaved: None }
    }

    /// Whether the next frame handed over should carry the simulation's
    /// snapshot for a checkpoint: the first frame, and then one every
    /// [`CHECKPOINT_EVERY`] of wall time.
    pub fn checkpoint_due(&self) -> bool {
        self.last_checkpoint.is_none_or(|at| at.elapsed() >= CHECKPOINT_EVERY)
    }

    /// Hands `frame` to the writer, waiting while [`QUEUE`] frames wait. An
    /// error is the writer's: it stopped at a frame it could not write, and
    /// writes nothing more.
    pub fn send(&mut self, frame: FinishedFrame) -> Result<(), WriteError> {
        if frame.snapshot.is_some() {
            (self.last_checkpoint, self.unsaved) = (Some(Instant::now()), None);
        } else {
            self.unsaved = Some(frame.frame);
        }
        self.hand_over(Job::Frame(Box::new(frame)))
    }

    /// The last frame handed over, if it went without a snapshot: a bake
    /// that ends there gives [`Self::checkpoint`] its state.
    pub fn unsaved_frame(&self) -> Option<usize> {
        self.unsaved
    }

    /// Has the writer write the checkpoint of `frame`, the last handed
    /// over, with `snapshot`, the simulation's state at its end.
    pub fn checkpoint(&mut self, frame: usize, snapshot: Snapshot) -> Result<(), WriteError> {
        self.unsaved = None;
        self.hand_over(Job::Checkpoint { frame, snapshot: Box::new(snapshot) })
    }

    fn hand_over(&mut self, job: Job) -> Result<(), WriteError> {
        if self.queue.as_ref().is_some_and(|queue| queue.send(job).is_ok()) {
            return Ok(());
        }
        // The writer hung up: it stopped at an error, which it returns.
        match self.join() {
            Err(error) => Err(error),
            Ok(_) => Err(stopped(&self.dir)),
        }
    }

    /// Waits until every frame handed over is written, and gives back the
    /// folder and the frames' records, completed with the checker's counts.
    pub fn finish(mut self) -> Result<Written<'a>, WriteError> {
        self.join()
    }

    fn join(&mut self) -> Result<Written<'a>, WriteError> {
        self.queue = None;
        let thread = self.thread.take().ok_or_else(|| stopped(&self.dir))?;
        thread.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    }
}

/// What the writer of the bake in `dir` says when asked for more after it stopped.
fn stopped(dir: &Path) -> WriteError {
    WriteError { path: dir.to_owned(), source: std::io::Error::other("the bake's writer stopped at an earlier error") }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::bake::resume;
    use crate::io::obj::read_obj;
    use crate::scene::Scene;
    use crate::sim::Simulator;

    const SUNK: usize = 2;

    /// A small cloth 0.5 m above the ground.
    fn small_scene() -> Scene {
        let text = "[time]\nduration_s = 0.2\n[[garment]]\nname = \"cloth\"\npreset = \"cotton\"\n\
                    mesh = { grid = { size_m = 0.2, resolution = 4 } }\ntranslation_m = [0.0, 0.5, 0.0]\n\
                    [[collider]]\nname = \"ground\"\nshape = \"plane\"\n";
        Scene::parse(text, "writer", Path::new("."), "writer").expect("a valid scene")
    }

    fn checker(scene: &Scene, sim: &Simulator) -> Checker {
        Checker::new(sim.cloth().triangles.clone(), &scene.colliders, &scene.mesh_colliders)
    }

    /// Frame `k`: the start positions raised by `k` cm, and frame `SUNK`'s
    /// sunk 1 m, through the ground.
    fn frame(sim: &Simulator, k: usize) -> FinishedFrame {
        let lift = Vector3::new(0.0, if k == SUNK { -1.0 } else { 0.01 * k as f64 }, 0.0);
        FinishedFrame {
            frame: k,
            time_s: k as f64 / 30.0,
            positions: sim.positions().iter().map(|p| p + lift).collect(),
            record: (k > 0).then(|| FrameRecord { frame: k, ..Default::default() }),
            snapshot: Some(sim.snapshot().expect("a snapshot")),
        }
    }

    /// Writes frames 0 to `last` into `dir`, with snapshots at every third
    /// frame, and, when `end_with_checkpoint`, the last frame's checkpoint.
    fn write_frames(dir: &Path, last: usize, end_with_checkpoint: bool) -> (Scene, u32, Vec<FrameRecord>) {
        let scene = small_scene();
        let sim = scene.simulator().expect("a simulator");
        let fingerprint = resume::fingerprint(&scene, &sim);
        let folder = BakeFolder::create(dir, &scene).expect("a bake folder");
        let (folder, records) = std::thread::scope(|scope| {
            let mut writer = FrameWriter::start(scope, folder, checker(&scene, &sim), fingerprint);
            for k in 0..=last {
                let mut f = frame(&sim, k);
                if !k.is_multiple_of(3) {
                    f.snapshot = None;
                }
                writer.send(f).expect("written");
            }
            assert_eq!(writer.unsaved_frame(), (!last.is_multiple_of(3)).then_some(last));
            if end_with_checkpoint && let Some(k) = writer.unsaved_frame() {
                writer.checkpoint(k, sim.snapshot().expect("a snapshot")).expect("written");
            }
            writer.finish()
        })
        .expect("all written");
        assert_eq!(folder.dir(), dir);
        for k in (0..=last).filter(|&k| k != SUNK) {
            let obj = read_obj(&dir.join(format!("frame_{k:04}.obj"))).expect("a whole frame");
            let expected = sim.positions()[0].y + 0.01 * k as f64;
            assert!((obj.mesh.positions[0].y - expected).abs() < 1e-6, "frame {k} holds its own positions");
        }
        for record in &records {
            let through = record.intersections.collider_pairs > 0;
            assert_eq!(through, record.frame == SUNK, "the checker's count of frame {}", record.frame);
        }
        (scene, fingerprint, records)
    }

    #[test]
    fn every_frame_handed_over_is_on_disk_with_its_checkpoint_once_finished() {
        let dir = tempfile::tempdir().expect("a folder");
        let last = 3 * QUEUE + 1;
        let (scene, fingerprint, _) = write_frames(dir.path(), last, true);
        let (_, checkpoint, records) = BakeFolder::reopen(dir.path(), &scene, fingerprint).expect("resumable");
        assert_eq!(checkpoint.frame, last, "the checkpoint is the last frame's");
        assert_eq!(records.iter().map(|r| r.frame).collect::<Vec<_>>(), (1..=last).collect::<Vec<_>>());
        let every_triangle = scene.cloth().triangles.len() as u32;
        assert_eq!(
            records[SUNK - 1].intersections.collider_pairs,
            every_triangle,
            "the records on disk carry the counts"
        );
    }

    /// Frames after the last checkpoint are on disk, but `--resume` goes on
    /// from the checkpoint, with the records up to it.
    #[test]
    fn a_bake_that_stops_between_checkpoints_resumes_from_the_last() {
        let dir = tempfile::tempdir().expect("a folder");
        let last = 3 * QUEUE + 2;
        let (scene, fingerprint, written) = write_frames(dir.path(), last, false);
        assert_eq!(written.len(), last, "every frame is written and checked");
        let (_, checkpoint, records) = BakeFolder::reopen(dir.path(), &scene, fingerprint).expect("resumable");
        assert_eq!(checkpoint.frame, 3 * QUEUE);
        assert_eq!(records.len(), 3 * QUEUE, "the records cut back to the checkpoint's");
    }

    #[test]
    fn a_frame_that_cannot_be_written_stops_the_writer_with_its_error() {
        let scene = small_scene();
        let sim = scene.simulator().expect("a simulator");
        let dir = tempfile::tempdir().expect("a folder");
        let folder = BakeFolder::create(dir.path(), &scene).expect("a bake folder");
        std::fs::remove_dir_all(dir.path()).expect("the folder removed");
        let named_frame_0 =
            |e: &WriteError| e.path.ends_with("frame_0000.obj") && e.source.kind() == std::io::ErrorKind::NotFound;
        std::thread::scope(|scope| {
            let mut writer = FrameWriter::start(scope, folder, checker(&scene, &sim), 0);
            // The writer fails at frame 0; the queue holds at most QUEUE more.
            let error = (0..QUEUE + 2).find_map(|k| writer.send(frame(&sim, k)).err()).expect("an error");
            assert!(named_frame_0(&error), "{error}");
            let again = writer.send(frame(&sim, QUEUE + 2)).expect_err("a stopped writer");
            assert!(again.to_string().contains("stopped at an earlier error"), "{again}");
            assert!(writer.finish().is_err());
        });
        std::thread::scope(|scope| {
            let folder = BakeFolder::create(dir.path(), &scene).expect("a bake folder");
            std::fs::remove_dir_all(dir.path()).expect("the folder removed");
            let mut writer = FrameWriter::start(scope, folder, checker(&scene, &sim), 0);
            writer.send(frame(&sim, 0)).expect("queued");
            let error = writer.finish().err().expect("an error");
            assert!(named_frame_0(&error), "finish reports it: {error}");
        });
    }
}
