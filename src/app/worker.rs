//! The simulation worker: a thread that owns the simulation, so the editor's
//! UI thread never waits on physics.
//!
//! The UI sends [`Command`]s (simulate, pause, bake, cancel, reset, restart
//! from a kept frame, live parameter changes) and receives [`Event`]s (each
//! finished frame with its record, the state to simulate again from it and
//! the settings it was simulated with; bake progress; failures). Frames are
//! whole: the UI only ever sees the state at the end of a frame, never a step
//! in progress. A live run goes on past the scene's range (the body holds
//! its last pose or cycles) until paused or the frames kept would fill
//! [`LIVE_CACHE_BYTES`].

use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::thread::JoinHandle;

use nalgebra::Vector3;

use crate::bake::{Baker, FrameRecord};
use crate::scene::Scene;
use crate::sim::fabric::Fabric;
use crate::sim::snapshot::Snapshot;

/// Memory the frames of a live run may take (positions, the state to
/// simulate again from each), bytes: a run stops when its next frame would
/// pass it.
pub const LIVE_CACHE_BYTES: usize = 2 << 30;
/// The most frames a live run goes to, whatever the cloth's size.
pub const LIVE_FRAMES_MAX: usize = 18_000;

/// What the UI asks of the worker.
#[derive(Debug)]
pub enum Command {
    /// Start over from frame 0 of this scene (with the editor's current
    /// parameters in it). Stops any run.
    Reset(Box<Scene>),
    /// Run frame after frame from the current state, live, until paused
    /// (past the scene's last frame too, up to [`live_frames`]).
    Simulate,
    /// Stop a live run or a bake after the frame in progress.
    Pause,
    /// Start over from frame 0 and run to the scene's last frame, reporting
    /// progress; frames stream back as they finish.
    Bake,
    /// Give garment `garment` a new fabric from the next step on (ramped).
    SetFabric {
        /// Garment index, scene order.
        garment: usize,
        /// The new parameters.
        fabric: Box<Fabric>,
    },
    /// Simulate again from the end of frame `frame`, from its kept `state`,
    /// with the current settings (stops any run).
    RestartFrom {
        /// The frame.
        frame: usize,
        /// Its state ([`Frame::state`]).
        state: Arc<Snapshot>,
    },
    /// Change the solver's effort from the next frame on.
    SetEffort {
        /// Solver steps per frame.
        steps_per_frame: u32,
        /// Linear-solver tolerance, unitless.
        tolerance: f64,
    },
}

/// The settings a frame was simulated with: it is stale once they are no
/// longer the editor's.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Settings {
    /// Each garment's fabric, scene order.
    pub fabrics: Vec<Fabric>,
    /// Solver steps per frame.
    pub steps_per_frame: u32,
    /// Linear-solver tolerance, unitless.
    pub tolerance: f64,
}

impl Settings {
    /// The settings of `scene` as it is now.
    pub fn of(scene: &Scene) -> Settings {
        Settings {
            fabrics: scene.garments.iter().map(|g| g.fabric.clone()).collect(),
            steps_per_frame: scene.steps_per_frame,
            tolerance: scene.solver.tolerance,
        }
    }
}

/// A finished frame.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Every garment's positions, concatenated in scene order, m.
    pub positions: Arc<Vec<Vector3<f64>>>,
    /// What happened during the frame (frame 0: only the checker's count).
    pub record: FrameRecord,
    /// The simulation's state at the frame's end, to simulate again from it.
    pub state: Arc<Snapshot>,
    /// The settings the frame was simulated with.
    pub settings: Arc<Settings>,
    /// Simulated by a bake (from frame 0, at one quality) rather than live.
    pub baked: bool,
    /// The mean force each particle took from the colliders during the
    /// frame, N (zero at frame 0).
    pub contact_force_n: Arc<Vec<f32>>,
}

/// What the worker tells the UI.
#[derive(Clone, Debug)]
pub enum Event {
    /// The simulation is back at frame 0 (after a reset or a bake's start).
    Restarted(Frame),
    /// A frame finished.
    Frame(Frame),
    /// A bake's progress: frames done of the total.
    BakeProgress {
        /// Frames finished.
        done: usize,
        /// Frames in the bake.
        total: usize,
    },
    /// A run stopped: the last frame, a pause, a cancel or a failure.
    Stopped(Stop),
    /// A garment's new fabric is in the simulation (blending in over the
    /// next steps).
    FabricSet {
        /// Garment index, scene order.
        garment: usize,
        /// The parameters now simulated.
        fabric: Box<Fabric>,
    },
    /// A command could not be carried out (e.g. a parameter out of range);
    /// the simulation goes on as it was.
    Refused(String),
}

/// Why a run stopped.
#[derive(Clone, Debug, PartialEq)]
pub enum Stop {
    /// The scene's last frame was reached (a bake is complete).
    Finished,
    /// Paused or cancelled by the user.
    ByUser,
    /// The simulation failed; frames before it are kept.
    Failed(String),
}

/// What the worker is doing between commands.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Run {
    Idle,
    Live,
    Baking,
}

/// The worker thread and its channels.
pub struct Worker {
    commands: Sender<Command>,
    events: Receiver<Event>,
    thread: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts a worker on `scene`; its first event is `Restarted` (frame 0)
    /// or `Stopped(Failed)` when the scene cannot be simulated.
    pub fn start(scene: Scene) -> Worker {
        let (commands, inbox) = channel();
        let (outbox, events) = channel();
        let thread = std::thread::Builder::new()
            .name("drape-simulation".into())
            .spawn(move || WorkerLoop::new(inbox, outbox, scene).run())
            .ok();
        Worker { commands, events, thread }
    }

    /// Sends a command (ignored when the worker has stopped).
    pub fn send(&self, command: Command) {
        let _ = self.commands.send(command);
    }

    /// The events that arrived since the last call, in order.
    pub fn events(&self) -> Vec<Event> {
        self.events.try_iter().collect()
    }

    /// Waits for the next event (tests and headless use).
    pub fn next_event(&self, timeout: std::time::Duration) -> Option<Event> {
        self.events.recv_timeout(timeout).ok()
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        // Closing the command channel ends the loop after the frame in progress.
        let (closed, _) = channel();
        self.commands = closed;
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// The worker thread's state.
struct WorkerLoop {
    inbox: Receiver<Command>,
    outbox: Sender<Event>,
    scene: Scene,
    baker: Option<Baker>,
    run: Run,
    /// The settings simulated now.
    settings: Arc<Settings>,
}

impl WorkerLoop {
    fn new(inbox: Receiver<Command>, outbox: Sender<Event>, scene: Scene) -> Self {
        let settings = Arc::new(Settings::of(&scene));
        WorkerLoop { inbox, outbox, scene, baker: None, run: Run::Idle, settings }
    }

    /// The frame the baker is at, with the settings it was simulated with.
    fn frame(&self, baker: &mut Baker, record: FrameRecord) -> Frame {
        let contact_force_n = Arc::new(baker.take_contact_forces(1));
        let sim = baker.simulator();
        Frame {
            positions: Arc::new(sim.positions().to_vec()),
            record,
            state: Arc::new(sim.state()),
            settings: self.settings.clone(),
            baked: self.run == Run::Baking,
            contact_force_n,
        }
    }

    fn run(mut self) {
        self.restart(Run::Idle);
        loop {
            let command = if self.run == Run::Idle {
                match self.inbox.recv() {
                    Ok(command) => Some(command),
                    Err(_) => return,
                }
            } else {
                match self.inbox.try_recv() {
                    Ok(command) => Some(command),
                    Err(TryRecvError::Empty) => None,
                    Err(TryRecvError::Disconnected) => return,
                }
            };
            match command {
                Some(command) => self.obey(command),
                None => self.advance(),
            }
        }
    }

    fn emit(&self, event: Event) {
        let _ = self.outbox.send(event);
    }

    fn obey(&mut self, command: Command) {
        match command {
            Command::Reset(scene) => {
                self.scene = *scene;
                self.restart(Run::Idle);
            }
            Command::Simulate if self.baker.is_some() => self.run = Run::Live,
            Command::Simulate => self.emit(Event::Refused("the scene could not be simulated".into())),
            Command::Pause => {
                if self.run != Run::Idle {
                    self.run = Run::Idle;
                    self.emit(Event::Stopped(Stop::ByUser));
                }
            }
            Command::Bake => {
                self.restart(Run::Baking);
                if self.baker.is_some() {
                    self.emit(Event::BakeProgress { done: 0, total: self.scene.frame_count });
                }
            }
            Command::SetFabric { garment, fabric } => {
                let Some(baker) = &mut self.baker else { return };
                match baker.set_fabric(garment, (*fabric).clone()) {
                    Ok(()) => {
                        if let Some(g) = self.scene.garments.get_mut(garment) {
                            g.fabric = (*fabric).clone();
                        }
                        self.settings = Arc::new(Settings::of(&self.scene));
                        self.emit(Event::FabricSet { garment, fabric });
                    }
                    Err(e) => self.emit(Event::Refused(e.to_string())),
                }
            }
            Command::SetEffort { steps_per_frame, tolerance } => {
                if steps_per_frame == 0 || !(tolerance > 0.0 && tolerance < 1.0) {
                    let problem = format!("steps per frame {steps_per_frame} (≥ 1), tolerance {tolerance} (0 < t < 1)");
                    self.emit(Event::Refused(format!("solver effort out of range: {problem}")));
                    return;
                }
                self.scene.steps_per_frame = steps_per_frame;
                self.scene.solver.tolerance = tolerance;
                self.settings = Arc::new(Settings::of(&self.scene));
                if let Some(baker) = &mut self.baker {
                    baker.set_effort(steps_per_frame, tolerance);
                }
            }
            Command::RestartFrom { frame, state } => self.restart_from(frame, &state),
        }
    }

    /// Simulates again from `state` at the end of `frame`, idle.
    fn restart_from(&mut self, frame: usize, state: &Snapshot) {
        self.run = Run::Idle;
        let restarted = Baker::new(&self.scene).map_err(|e| e.to_string()).and_then(|mut baker| {
            baker.restart_from(frame, state).map_err(|e| e.to_string())?;
            Ok(baker)
        });
        match restarted {
            Ok(baker) => self.baker = Some(baker),
            Err(e) => self.emit(Event::Refused(format!("cannot simulate again from frame {frame}: {e}"))),
        }
    }

    /// Back to frame 0 of the scene, to do `next` from there.
    fn restart(&mut self, next: Run) {
        self.run = next;
        match Baker::new(&self.scene) {
            Ok(mut baker) => {
                self.settings = Arc::new(Settings::of(&self.scene));
                let record = FrameRecord { intersections: baker.initial_check(), ..Default::default() };
                let frame = self.frame(&mut baker, record);
                self.baker = Some(baker);
                self.emit(Event::Restarted(frame));
            }
            Err(e) => {
                (self.baker, self.run) = (None, Run::Idle);
                self.emit(Event::Stopped(Stop::Failed(e.to_string())));
            }
        }
    }

    /// Simulates one frame of the current run.
    fn advance(&mut self) {
        let Some(mut baker) = self.baker.take() else {
            self.run = Run::Idle;
            return;
        };
        let end = match self.run {
            Run::Baking => self.scene.frame_count,
            _ => live_frames(&self.scene),
        };
        if baker.frame() >= end {
            self.baker = Some(baker);
            self.run = Run::Idle;
            self.emit(Event::Stopped(Stop::Finished));
            return;
        }
        match baker.advance() {
            Ok(record) => {
                let frame = self.frame(&mut baker, record);
                self.baker = Some(baker);
                let done = frame.record.frame;
                self.emit(Event::Frame(frame));
                if self.run == Run::Baking {
                    self.emit(Event::BakeProgress { done, total: self.scene.frame_count });
                }
            }
            Err(e) => {
                self.baker = Some(baker);
                self.run = Run::Idle;
                self.emit(Event::Stopped(Stop::Failed(e.to_string())));
            }
        }
    }
}

/// The frame a live run of `scene` stops at: its range at least, then as
/// many frames as [`LIVE_CACHE_BYTES`] holds, at most [`LIVE_FRAMES_MAX`].
pub fn live_frames(scene: &Scene) -> usize {
    let particles: usize = scene.garments.iter().map(|g| g.mesh.vertex_count()).sum();
    // Positions twice, velocities, the warm start, forces and flags, and
    // about one remembered contact per particle.
    let bytes_per_frame = particles.max(1) * (4 * 24 + 13 + 40);
    (LIVE_CACHE_BYTES / bytes_per_frame).clamp(scene.frame_count, LIVE_FRAMES_MAX.max(scene.frame_count))
}
