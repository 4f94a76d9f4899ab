//! Baking: running a scene frame by frame, with a record of each frame (time
//! per stage, solver iterations, strain, contacts), into a folder of exports.

pub mod output;
pub mod resume;
pub mod summary;
pub mod writer;

use std::sync::atomic::{AtomicBool, Ordering};

use nalgebra::Vector3;

use crate::metrics::intersections::{Checker, Intersections};
use crate::scene::Scene;
use crate::sim::adaptive::{RollbackCauses, Stepper, Unrecoverable};
use crate::sim::fabric::Fabric;
use crate::sim::pin_reach::Unreachable;
use crate::sim::snapshot::{Snapshot, SnapshotError};
use crate::sim::step::{StageTimings, TuningError};
use crate::sim::{SimError, Simulator};

/// What happened during one frame.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameRecord {
    /// Frame number (1 is the first simulated frame).
    pub frame: usize,
    /// Simulated time at the end of the frame, s.
    pub time_s: f64,
    /// Solver steps taken.
    pub steps: u32,
    /// Wall time per stage, summed over the frame's steps.
    pub timings: StageTimings,
    /// Conjugate-gradient iterations, summed over the steps.
    pub cg_iterations: u32,
    /// Cholesky factors built for the solves, summed over the steps.
    pub factorizations: u32,
    /// Steps rolled back and retried at half the length (the safety net).
    pub rollbacks: u32,
    /// Why they were rolled back.
    pub rollback_causes: RollbackCauses,
    /// Shortest step taken in the frame, s.
    pub shortest_step_s: f64,
    /// Longest step taken in the frame, s.
    pub longest_step_s: f64,
    /// Steps longer than the nominal one rolled back for their error or
    /// their strain and retried shorter.
    pub long_steps_rejected: u32,
    /// Newton iterations of the inextensibility projection, summed over the steps.
    pub projection_iterations: u32,
    /// Their conjugate-gradient iterations, summed over the steps.
    pub projection_cg_iterations: u32,
    /// Steps whose projection missed its tolerance and fell back to clamping.
    pub projection_fallbacks: u32,
    /// Largest stretch (l − l₀) / l₀ of a stretch spring at the end of the frame.
    pub max_strain: f64,
    /// The same over the stretch springs not pinned at both ends: the
    /// cloth's own strain, which the solver controls.
    #[serde(default)]
    pub max_free_strain: f64,
    /// Two pins further apart at the end of the frame than the cloth between
    /// them may reach, when any are: the strain limits cannot be met there
    /// ([`crate::sim::pin_reach`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limits_unreachable: Option<Unreachable>,
    /// Mean stretch strain at the end of the frame.
    pub mean_strain: f64,
    /// Mean speed of the cloth's particles over the frame: each one's
    /// displacement since the previous frame's end over the frame's
    /// duration, averaged, m/s. A cloth that has come to rest reads ~0.
    #[serde(default)]
    pub mean_speed_m_per_s: f64,
    /// Most particle-collider contacts in one of the frame's steps.
    pub contacts: u32,
    /// Triangle-pair contacts found by the collision pipeline, summed over steps.
    pub triangle_contacts: u32,
    /// Elementary collision tests run, summed over steps.
    pub collision_tests: u64,
    /// The tests the same pairs would need without representative triangles.
    pub collision_tests_without_ownership: u64,
    /// Steps that needed rigid impact zones.
    pub impact_zone_steps: u32,
    /// Crossings the collision pipeline left unresolved, summed over steps.
    pub unresolved_crossings: u32,
    /// What the independent checker found at the end of the frame.
    pub intersections: Intersections,
}

impl FrameRecord {
    /// The frame's free strain beyond what its pins force: `max_free_strain`
    /// less the least strain over the limit that pins further apart than
    /// the cloth between them may reach force on some edge
    /// ([`Unreachable::forced_strain`]), unitless. What the solver answers
    /// for: within the limit and a point where it meets the limits as far as
    /// the pins allow. (Pins 1 cm beyond reach do not explain an edge at
    /// seven times its length.)
    pub fn free_strain_beyond_pins(&self) -> f64 {
        self.max_free_strain - self.limits_unreachable.map_or(0.0, |u| u.forced_strain)
    }
}

/// Runs a scene one frame at a time, checking every frame with the
/// independent intersection checker.
pub struct Baker {
    sim: Simulator,
    stepper: Stepper,
    frame_s: f64,
    /// The independent checker, until [`Baker::take_checker`] hands it on.
    checker: Option<Checker>,
    steps_per_frame: u32,
    frame: usize,
    /// Whether the bake was taken up from a checkpoint ([`Baker::resume_at`]):
    /// its state at `frame` was handed on before.
    resumed: bool,
    /// The particles' positions at the end of the last frame, m.
    last_positions: Vec<Vector3<f64>>,
}

/// Why a bake stopped.
#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// The scene could not be turned into a simulation.
    #[error("cannot start the simulation: {0}")]
    Start(#[from] SimError),
    /// A step failed; frames before it are kept.
    #[error("the simulation stopped at frame {frame}: {source}")]
    Step {
        /// The frame that could not be completed.
        frame: usize,
        /// Why.
        source: Unrecoverable,
    },
    /// Output could not be written.
    #[error(transparent)]
    Write(#[from] crate::io::atomic::WriteError),
    /// The simulation's state could not be saved for `--resume`.
    #[error("cannot save the state for --resume: {0}")]
    Snapshot(#[from] SnapshotError),
}

impl Baker {
    /// A baker at frame 0 of `scene`.
    pub fn new(scene: &Scene) -> Result<Self, BakeError> {
        let sim = scene.simulator()?;
        let checker = Checker::new(sim.cloth().triangles.clone(), &scene.colliders, &scene.mesh_colliders);
        let stepper = Stepper::new(scene.step_duration(), scene.adaptive_settings());
        Ok(Baker {
            last_positions: sim.positions().to_vec(),
            sim,
            stepper,
            frame_s: scene.frame_duration(),
            checker: Some(checker),
            steps_per_frame: scene.steps_per_frame,
            frame: 0,
            resumed: false,
        })
    }

    /// Takes the bake up at the end of frame `frame`, from the state `snapshot`
    /// a baker of the same scene had there ([`Simulator::snapshot`]).
    pub fn resume_at(&mut self, frame: usize, snapshot: &Snapshot) -> Result<(), SnapshotError> {
        self.check_time(frame, snapshot)?;
        self.sim.resume_from(snapshot)?;
        self.last_positions.copy_from_slice(self.sim.positions());
        (self.frame, self.resumed) = (frame, true);
        Ok(())
    }

    /// Simulates again from the end of frame `frame`, whose state a run
    /// of the same cloth kept ([`Simulator::state`]), with this baker's
    /// settings.
    pub fn restart_from(&mut self, frame: usize, state: &Snapshot) -> Result<(), SnapshotError> {
        self.check_time(frame, state)?;
        self.sim.restart_from(state)?;
        self.last_positions.copy_from_slice(self.sim.positions());
        self.frame = frame;
        Ok(())
    }

    /// Refuses a state that is not at the end of frame `frame`.
    fn check_time(&self, frame: usize, snapshot: &Snapshot) -> Result<(), SnapshotError> {
        let expected = frame as f64 * self.frame_s;
        match (snapshot.time_s - expected).abs() > 1e-6 * self.frame_s.max(expected) {
            true => Err(SnapshotError::Mismatch {
                saved: format!("t = {} s", snapshot.time_s),
                expected: format!("the end of frame {frame}, t = {expected} s"),
            }),
            false => Ok(()),
        }
    }

    /// The independent checker's count on the current state (none once the
    /// checker is taken).
    pub fn initial_check(&self) -> Intersections {
        self.check()
    }

    /// Hands the independent checker to whoever checks the frames from now
    /// on (`drape bake`'s writer thread, beside the next frame's
    /// simulation); the records of the frames after that leave the
    /// intersections at zero.
    pub fn take_checker(&mut self) -> Option<Checker> {
        self.checker.take()
    }

    fn check(&self) -> Intersections {
        self.checker.as_ref().map(|c| c.check(self.sim.positions(), self.sim.time())).unwrap_or_default()
    }

    /// Gives garment `garment` a new fabric from the next step on (blended in,
    /// see [`Simulator::set_fabric`]).
    pub fn set_fabric(&mut self, garment: usize, fabric: Fabric) -> Result<(), TuningError> {
        self.sim.set_fabric(garment, fabric)
    }

    /// Runs the next frames with `steps_per_frame` solver steps (≥ 1) and
    /// linear-solver `tolerance` (unitless).
    pub fn set_effort(&mut self, steps_per_frame: u32, tolerance: f64) {
        self.steps_per_frame = steps_per_frame.max(1);
        self.stepper = Stepper::new(self.frame_s / f64::from(self.steps_per_frame), self.stepper.settings());
        self.sim.set_solver_tolerance(tolerance);
    }

    /// The mean force each particle took from the colliders over the frames
    /// since the last call, N (per frame: the impulses over its duration).
    pub fn take_contact_forces(&mut self, frames: usize) -> Vec<f32> {
        let duration = self.frame_s * frames.max(1) as f64;
        self.sim.take_contact_impulses().iter().map(|j| (j / duration) as f32).collect()
    }

    /// The simulation in its current state.
    pub fn simulator(&self) -> &Simulator {
        &self.sim
    }

    /// The last completed frame (0 before any).
    pub fn frame(&self) -> usize {
        self.frame
    }

    /// Simulates the next frame.
    pub fn advance(&mut self) -> Result<FrameRecord, BakeError> {
        let frame = self.frame + 1;
        let mut record = FrameRecord { frame, ..Default::default() };
        let advance = self
            .stepper
            .advance(&mut self.sim, self.steps_per_frame, |step| {
                record.timings.add(&step.timings);
                record.cg_iterations += step.solver.iterations;
                record.factorizations += step.factorizations;
                record.contacts = record.contacts.max(step.contacts);
                record.projection_iterations += step.projection.newton_iterations;
                record.projection_cg_iterations += step.projection.cg_iterations;
                record.projection_fallbacks += u32::from(step.projection.fell_back);
                record.max_strain = step.max_strain;
                record.max_free_strain = step.max_free_strain;
                record.mean_strain = step.mean_strain;
                let c = &step.collision;
                record.triangle_contacts += c.contacts;
                record.collision_tests += c.tests;
                record.collision_tests_without_ownership += c.tests_without_ownership;
                record.impact_zone_steps += u32::from(c.zone_rounds > 0);
                record.unresolved_crossings += c.unresolved;
            })
            .map_err(|source| BakeError::Step { frame, source })?;
        record.steps = advance.steps;
        record.rollbacks = advance.rollbacks;
        record.rollback_causes = advance.causes;
        record.limits_unreachable = self.sim.unreachable_limits();
        record.shortest_step_s = advance.shortest_step_s;
        record.longest_step_s = advance.longest_step_s;
        record.long_steps_rejected = advance.long_steps_rejected;
        record.mean_speed_m_per_s = mean_speed(&self.last_positions, self.sim.positions(), self.frame_s);
        self.last_positions.copy_from_slice(self.sim.positions());
        record.time_s = self.sim.time();
        record.intersections = self.check();
        self.frame = frame;
        Ok(record)
    }
}

/// Mean over the particles of their speed from `before` to `after` over
/// `duration_s` s, m/s (0 for none).
fn mean_speed(before: &[Vector3<f64>], after: &[Vector3<f64>], duration_s: f64) -> f64 {
    let travelled: f64 = before.iter().zip(after).map(|(a, b)| (b - a).norm()).sum();
    travelled / (before.len().max(1) as f64 * duration_s)
}

/// Runs `scene` for `frames` frames, handing each finished frame to `on_frame`,
/// and stopping early when `cancel` is set. Returns the records of the frames
/// done and, if a step failed, the error that stopped it.
pub fn run(
    scene: &Scene,
    frames: usize,
    cancel: &AtomicBool,
    on_frame: impl FnMut(&Simulator, &FrameRecord) -> Result<(), BakeError>,
) -> Result<(Vec<FrameRecord>, Option<BakeError>), BakeError> {
    run_from(&mut Baker::new(scene)?, frames, cancel, on_frame)
}

/// Like [`run`], from wherever `baker` is: a baker at frame 0 hands its
/// initial state to `on_frame` first; a resumed one goes on with its next
/// frame. The records returned are those of the frames run here.
pub fn run_from(
    baker: &mut Baker,
    frames: usize,
    cancel: &AtomicBool,
    mut on_frame: impl FnMut(&Simulator, &FrameRecord) -> Result<(), BakeError>,
) -> Result<(Vec<FrameRecord>, Option<BakeError>), BakeError> {
    if baker.frame() == 0 && !baker.resumed {
        let initial = baker.initial_check();
        on_frame(baker.simulator(), &FrameRecord { intersections: initial, ..Default::default() })?;
    }
    let mut records = Vec::with_capacity(frames.saturating_sub(baker.frame()));
    while baker.frame() < frames && !cancel.load(Ordering::Relaxed) {
        match baker.advance() {
            Ok(record) => {
                on_frame(baker.simulator(), &record)?;
                records.push(record);
            }
            Err(failure @ BakeError::Step { .. }) => return Ok((records, Some(failure))),
            Err(other) => return Err(other),
        }
    }
    Ok((records, None))
}
