//! The simulation worker: a thread that owns the simulation, so the editor's
//! UI thread never waits on physics.
//!
//! The UI sends [`Command`]s (simulate, pause, bake, cancel, reset, live
//! parameter changes) and receives [`Event`]s (each finished frame with its
//! record, bake progress, failures). Frames are whole: the UI only ever sees
//! the state at the end of a frame, never a step in progress.

use std::sync::Arc;
use std::sync::mpsc::{Receiver, Sender, TryRecvError, channel};
use std::thread::JoinHandle;

use nalgebra::Vector3;

use crate::bake::{Baker, FrameRecord};
use crate::scene::Scene;
use crate::sim::fabric::Fabric;

/// What the UI asks of the worker.
#[derive(Debug)]
pub enum Command {
    /// Start over from frame 0 of this scene (with the editor's current
    /// parameters in it). Stops any run.
    Reset(Box<Scene>),
    /// Run frame after frame from the current state, live, until paused or
    /// the scene's last frame.
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
    /// Change the solver's effort from the next frame on.
    SetEffort {
        /// Solver steps per frame.
        steps_per_frame: u32,
        /// Linear-solver tolerance, unitless.
        tolerance: f64,
    },
}

/// A finished frame.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Every garment's positions, concatenated in scene order, m.
    pub positions: Arc<Vec<Vector3<f64>>>,
    /// What happened during the frame (frame 0: only the checker's count).
    pub record: FrameRecord,
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
}

impl WorkerLoop {
    fn new(inbox: Receiver<Command>, outbox: Sender<Event>, scene: Scene) -> Self {
        WorkerLoop { inbox, outbox, scene, baker: None, run: Run::Idle }
    }

    fn run(mut self) {
        self.restart();
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
                self.restart();
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
                self.restart();
                if self.baker.is_some() {
                    self.run = Run::Baking;
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
                if let Some(baker) = &mut self.baker {
                    baker.set_effort(steps_per_frame, tolerance);
                }
            }
        }
    }

    /// Back to frame 0 of the scene, idle.
    fn restart(&mut self) {
        self.run = Run::Idle;
        match Baker::new(&self.scene) {
            Ok(baker) => {
                let frame = Frame {
                    positions: Arc::new(baker.simulator().positions().to_vec()),
                    record: FrameRecord { intersections: baker.initial_check(), ..Default::default() },
                };
                self.baker = Some(baker);
                self.emit(Event::Restarted(frame));
            }
            Err(e) => {
                self.baker = None;
                self.emit(Event::Stopped(Stop::Failed(e.to_string())));
            }
        }
    }

    /// Simulates one frame of the current run.
    fn advance(&mut self) {
        let Some(baker) = &mut self.baker else {
            self.run = Run::Idle;
            return;
        };
        if baker.frame() >= self.scene.frame_count {
            self.run = Run::Idle;
            self.emit(Event::Stopped(Stop::Finished));
            return;
        }
        match baker.advance() {
            Ok(record) => {
                let positions = Arc::new(baker.simulator().positions().to_vec());
                let done = record.frame;
                self.emit(Event::Frame(Frame { positions, record }));
                if self.run == Run::Baking {
                    self.emit(Event::BakeProgress { done, total: self.scene.frame_count });
                }
            }
            Err(e) => {
                self.run = Run::Idle;
                self.emit(Event::Stopped(Stop::Failed(e.to_string())));
            }
        }
    }
}
