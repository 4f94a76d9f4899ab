//! The editor's state and what its controls do: the scene being edited, the
//! simulation worker, the timeline, the light rig, the camera, exports and
//! messages. Drawing is in [`super::panels`]; this module owns no GPU and no
//! window, so UI tests drive it directly.

mod jobs;
mod scene_edits;

use std::path::{Path, PathBuf};
use std::sync::mpsc::Receiver;
use std::time::Instant;

use super::browse::Browse;
use super::job::Job;
use super::orbit::CameraControl;
use super::reference::Reference;
use super::timeline::Timeline;
use super::worker::{Command, Event, Stop, Worker};
use crate::io::atomic::write_file;
use crate::render::{LightRig, OrbitCamera};
use crate::scene::Scene;
use crate::scene::file::{MeshSpec, SceneFile};
use crate::scene::preset::Preset;
use crate::sim::fabric::Fabric;

/// The simulation's effort, one choice for designers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quality {
    /// Half the scene's steps, loose solves: fast feedback while tuning.
    Preview,
    /// The scene's own steps and tolerance.
    Balanced,
    /// Twice the steps, tight solves: for the final bake.
    Final,
}

impl Quality {
    /// Every choice, fastest first.
    pub const ALL: [Quality; 3] = [Quality::Preview, Quality::Balanced, Quality::Final];

    /// Label in the UI.
    pub fn label(self) -> &'static str {
        match self {
            Quality::Preview => "Preview",
            Quality::Balanced => "Balanced",
            Quality::Final => "Final",
        }
    }

    /// Steps per frame and linear-solver tolerance for a scene whose own
    /// setting is `steps` steps at `tolerance`.
    pub fn effort(self, steps: u32, tolerance: f64) -> (u32, f64) {
        match self {
            Quality::Preview => (steps.div_ceil(2).max(1), (tolerance * 10.0).min(0.05)),
            Quality::Balanced => (steps, tolerance),
            Quality::Final => (steps * 2, tolerance * 0.1),
        }
    }
}

/// The shortest time step the scene's fabrics ask for, s.
fn finest_time_step(scene: &Scene) -> f64 {
    scene.garments.iter().map(|g| g.fabric.time_step_s).fold(f64::INFINITY, f64::min)
}

/// Steps per frame of `frame_s` that keep each step at or below `step_s`.
fn steps_for(frame_s: f64, step_s: f64) -> u32 {
    let steps = (frame_s / step_s * (1.0 - 1e-9)).ceil();
    if steps.is_finite() { steps.clamp(1.0, 10_000.0) as u32 } else { 1 }
}

/// What the simulation worker is doing, as the UI knows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RunState {
    /// Waiting.
    Idle,
    /// Simulating live.
    Live,
    /// Baking the whole range; `done` of `total` frames.
    Baking {
        /// Frames finished.
        done: usize,
        /// Frames in the bake.
        total: usize,
        /// When the bake started.
        started: Instant,
    },
}

/// A message for the user: an error stays until dismissed.
#[derive(Clone, Debug)]
pub struct Message {
    /// What happened (with the file and the reason, for errors).
    pub text: String,
    /// True for errors.
    pub error: bool,
    /// When it was posted.
    pub at: Instant,
}

/// Text fields of file paths in the panels.
#[derive(Clone, Debug, Default)]
pub struct PathFields {
    /// Scene file to open or save.
    pub scene: String,
    /// Garment OBJ of the selected garment.
    pub garment: String,
    /// Body FBX or motion cache of the first body.
    pub body: String,
    /// Motion from another file for the first body.
    pub motion: String,
    /// Fabric parameter file to load or save.
    pub fabric: String,
    /// Export folder.
    pub export: String,
}

/// The editor.
pub struct Editor {
    /// The scene as edited (its garments carry the live fabrics).
    pub scene: Scene,
    /// Its steps per frame and tolerance as loaded (Balanced quality).
    base_effort: (u32, f64),
    /// The fabrics' shortest time step, s (a change sets the steps per frame).
    time_step_s: f64,
    worker: Worker,
    /// The frames simulated so far and the playhead.
    pub timeline: Timeline,
    /// What the worker is doing.
    pub run: RunState,
    /// The last bake's progress: frames done of the total.
    pub bake_progress: Option<(usize, usize)>,
    /// Each garment's fabric as the worker confirmed it is simulating.
    pub simulated_fabrics: Vec<Fabric>,
    /// The garment the fabric panel edits.
    pub garment: usize,
    /// The simulation's effort.
    pub quality: Quality,
    /// The light rigs to choose from.
    pub rigs: Vec<LightRig>,
    /// The rig in use (index into `rigs`).
    pub rig: usize,
    /// The viewport camera.
    pub camera: CameraControl,
    /// The scene's own framing of the viewport (set by the viewport).
    pub framed: Option<OrbitCamera>,
    /// Bumped whenever the drawn scene must be rebuilt (new scene, new look).
    pub generation: u64,
    /// Messages to show.
    pub messages: Vec<Message>,
    /// Changes since the scene was opened or saved.
    pub dirty: bool,
    /// The path fields of the panels.
    pub paths: PathFields,
    /// An export in progress (its result: the folder).
    pub export: Option<Job<PathBuf>>,
    /// An open file dialog.
    pub browse: Option<Browse>,
    /// The reference run the simulated frames are compared with.
    pub reference: Option<Reference>,
    /// A reference run in progress.
    pub reference_job: Option<Job<Reference>>,
    /// A scene being loaded or re-resolved in the background.
    loading: Option<Receiver<Result<Scene, String>>>,
    /// The scene file of the edit being resolved in the background: the
    /// panels show it and later edits build on it, so a second edit made
    /// before the first is loaded does not undo it.
    edited: Option<SceneFile>,
    /// The window should close (set once the user confirmed).
    pub quit: bool,
    /// Asking whether to discard unsaved changes.
    pub confirm_quit: bool,
}

impl Editor {
    /// An editor on `scene`, its worker started.
    pub fn new(scene: Scene) -> Editor {
        let timeline = Timeline::new(scene.fps, scene.frame_count);
        let rigs = LightRig::built_in();
        let mut paths = PathFields { export: format!("out/{}", scene.name), ..Default::default() };
        if let Some(source) = &scene.source {
            paths.scene = source.display().to_string();
        }
        let base_effort = (scene.steps_per_frame, scene.solver.tolerance);
        let worker = Worker::start(scene.clone());
        let time_step_s = finest_time_step(&scene);
        let simulated_fabrics = scene.garments.iter().map(|g| g.fabric.clone()).collect();
        let mut editor = Editor {
            scene,
            base_effort,
            time_step_s,
            worker,
            timeline,
            run: RunState::Idle,
            bake_progress: None,
            simulated_fabrics,
            garment: 0,
            quality: Quality::Balanced,
            rigs,
            rig: 0,
            camera: CameraControl::default(),
            framed: None,
            generation: 0,
            messages: Vec::new(),
            dirty: false,
            paths,
            export: None,
            browse: None,
            reference: None,
            reference_job: None,
            loading: None,
            edited: None,
            quit: false,
            confirm_quit: false,
        };
        editor.fill_paths();
        editor
    }

    fn fill_paths(&mut self) {
        self.garment = self.garment.min(self.scene.garments.len().saturating_sub(1));
        self.paths.garment = match self.scene.file.garments.get(self.garment).map(|g| &g.mesh) {
            Some(MeshSpec::Obj(obj)) => obj.display().to_string(),
            _ => String::new(),
        };
        self.paths.body = self.scene.file.bodies.first().map(|b| b.file.display().to_string()).unwrap_or_default();
        self.paths.motion = self
            .scene
            .file
            .bodies
            .first()
            .and_then(|b| b.motion.as_ref())
            .map(|m| m.display().to_string())
            .unwrap_or_default();
    }

    /// The light rig in use.
    pub fn light_rig(&self) -> &LightRig {
        &self.rigs[self.rig.min(self.rigs.len() - 1)]
    }

    /// Posts a message (errors stay until dismissed).
    pub fn tell(&mut self, text: impl Into<String>, error: bool) {
        self.messages.push(Message { text: text.into(), error, at: Instant::now() });
    }

    /// Takes in what the worker, a loader and an export reported; advances
    /// playback and the turntable by `elapsed_s` of real time.
    pub fn update(&mut self, elapsed_s: f64) {
        for event in self.worker.events() {
            self.on_event(event);
        }
        self.poll_loading();
        self.poll_export();
        self.poll_reference();
        self.timeline.tick(elapsed_s);
        self.camera.tick(elapsed_s as f32);
        self.messages.retain(|m| m.error || m.at.elapsed().as_secs_f64() < 6.0);
    }

    /// True while something moves on screen by itself (the UI repaints).
    pub fn is_animating(&self) -> bool {
        self.run != RunState::Idle
            || self.timeline.playing
            || self.camera.turntable_period_s.is_some()
            || self.loading.is_some()
            || self.export.is_some()
            || self.reference_job.is_some()
    }

    fn on_event(&mut self, event: Event) {
        match event {
            Event::Restarted(frame) => self.timeline.restart(frame),
            Event::Frame(frame) => self.timeline.push(frame),
            Event::BakeProgress { done, total } => {
                let started = match self.run {
                    RunState::Baking { started, .. } => started,
                    _ => Instant::now(),
                };
                self.run = RunState::Baking { done, total, started };
                self.bake_progress = Some((done, total));
            }
            Event::FabricSet { garment, fabric } => {
                if let Some(f) = self.simulated_fabrics.get_mut(garment) {
                    *f = *fabric;
                }
            }
            Event::Stopped(stop) => {
                let was_baking = matches!(self.run, RunState::Baking { .. });
                self.run = RunState::Idle;
                match stop {
                    Stop::Finished if was_baking => self.tell(format!("baked {} frames", self.timeline.last()), false),
                    Stop::Finished | Stop::ByUser => {}
                    Stop::Failed(reason) => self.tell(format!("simulation stopped: {reason}"), true),
                }
            }
            Event::Refused(reason) => self.tell(reason, true),
        }
    }

    /// Runs the simulation live from the current state.
    pub fn simulate(&mut self) {
        if self.timeline.last() >= self.scene.frame_count {
            self.tell("the last frame is reached: Reset to simulate again", false);
            return;
        }
        self.timeline.playing = false;
        self.timeline.seek(self.timeline.last());
        self.worker.send(Command::Simulate);
        self.run = RunState::Live;
    }

    /// Pauses a live run (or cancels a bake).
    pub fn pause(&mut self) {
        self.worker.send(Command::Pause);
    }

    /// Bakes the whole range from frame 0.
    pub fn bake(&mut self) {
        self.timeline.playing = false;
        self.worker.send(Command::Bake);
        let total = self.scene.frame_count;
        self.run = RunState::Baking { done: 0, total, started: Instant::now() };
    }

    /// Back to frame 0 with the current parameters.
    pub fn reset(&mut self) {
        self.timeline.playing = false;
        self.worker.send(Command::Reset(Box::new(self.scene.clone())));
        self.run = RunState::Idle;
    }

    /// Estimated seconds left in a bake, from its pace so far.
    pub fn bake_time_left_s(&self) -> Option<f64> {
        match self.run {
            RunState::Baking { done, total, started } if done > 0 => {
                Some(started.elapsed().as_secs_f64() / done as f64 * (total - done.min(total)) as f64)
            }
            _ => None,
        }
    }

    /// Sends the selected garment's edited fabric to the simulation, if valid.
    pub fn fabric_changed(&mut self) {
        let g = self.garment;
        let Some(garment) = self.scene.garments.get(g) else { return };
        match garment.fabric.validate() {
            Ok(()) => {
                self.worker.send(Command::SetFabric { garment: g, fabric: Box::new(garment.fabric.clone()) });
                self.dirty = true;
                self.forget_reference();
            }
            Err(e) => return self.tell(format!("garment '{}': {e}", garment.name), true),
        }
        let finest = finest_time_step(&self.scene);
        if finest != self.time_step_s {
            self.time_step_s = finest;
            self.base_effort.0 = steps_for(self.scene.frame_duration(), finest);
            self.set_quality(self.quality);
        }
    }

    /// Gives the selected garment a built-in preset (or a preset file).
    pub fn choose_preset(&mut self, reference: &str) {
        let base = self.base_dir();
        match Preset::resolve(reference, &base, &toml::Table::new()) {
            Ok(preset) => {
                let g = self.garment;
                if let (Some(garment), Some(spec)) =
                    (self.scene.garments.get_mut(g), self.scene.file.garments.get_mut(g))
                {
                    garment.fabric = preset.fabric.clone();
                    spec.preset = reference.to_owned();
                    spec.fabric = toml::Table::new();
                    garment.preset = preset;
                    self.generation += 1;
                    self.fabric_changed();
                }
            }
            Err(e) => self.tell(e.to_string(), true),
        }
    }

    /// Saves the selected garment's fabric as a parameter file at `path`.
    pub fn save_fabric(&mut self, path: &Path) {
        let Some(garment) = self.scene.garments.get(self.garment) else { return };
        let mut preset = garment.preset.clone();
        preset.fabric = garment.fabric.clone();
        preset.name = path.file_stem().map_or(preset.name, |s| s.to_string_lossy().into_owned());
        let text = preset.to_toml();
        match write_file(path, |out| std::io::Write::write_all(out, text.as_bytes())) {
            Ok(()) => self.tell(format!("saved {}", path.display()), false),
            Err(e) => self.tell(e.to_string(), true),
        }
    }

    /// Sets the simulation's effort from the next frame on.
    pub fn set_quality(&mut self, quality: Quality) {
        self.quality = quality;
        let (steps_per_frame, tolerance) = quality.effort(self.base_effort.0, self.base_effort.1);
        self.scene.steps_per_frame = steps_per_frame;
        self.scene.solver.tolerance = tolerance;
        self.worker.send(Command::SetEffort { steps_per_frame, tolerance });
        self.dirty = true;
    }

    /// The window asks to close: yes unless there are unsaved changes, in
    /// which case the user is asked first.
    pub fn request_quit(&mut self) -> bool {
        if self.dirty && !self.quit {
            self.confirm_quit = true;
            false
        } else {
            true
        }
    }

    /// Waits until the worker reports (tests and scripted use): returns false
    /// after `timeout` without news.
    pub fn wait_for_worker(&mut self, timeout: std::time::Duration) -> bool {
        match self.worker.next_event(timeout) {
            Some(event) => {
                self.on_event(event);
                true
            }
            None => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_is_split_into_steps_no_longer_than_the_time_step() {
        assert_eq!(steps_for(1.0 / 30.0, 1.0 / 60.0), 2, "exact division needs no extra step");
        assert_eq!(steps_for(1.0 / 30.0, 0.01), 4);
        assert_eq!(steps_for(1.0 / 30.0, 1.0), 1);
    }

    #[test]
    fn quality_maps_to_fewer_or_more_steps_and_looser_or_tighter_solves() {
        let (steps, tolerance) = Quality::Preview.effort(4, 1e-3);
        assert_eq!(steps, 2);
        assert!((tolerance - 1e-2).abs() < 1e-12);
        assert_eq!(Quality::Preview.effort(1, 0.1), (1, 0.05), "never looser than 5 %");
        assert_eq!(Quality::Balanced.effort(4, 1e-3), (4, 1e-3));
        let (steps, tolerance) = Quality::Final.effort(4, 1e-3);
        assert_eq!(steps, 8);
        assert!((tolerance - 1e-4).abs() < 1e-12);
    }
}
