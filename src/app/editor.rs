//! The editor's state and what its controls do: the scene being edited, the
//! simulation worker, the timeline, the light rig, the camera, exports and
//! messages. Drawing is in [`super::panels`]; this module owns no GPU and no
//! window, so UI tests drive it directly.

mod actions;
mod camera;
mod compare;
mod history;
mod jobs;
mod runs;
mod scene_edits;

pub use self::actions::Action;
pub use self::compare::{Compare, Pinned};
pub use self::history::{Document, History};
pub use self::runs::FrameKind;

use std::path::{Path, PathBuf};
use std::sync::mpsc::Receiver;
use std::time::Instant;

use super::dialog::Browse;
use super::job::Job;
use super::orbit::CameraControl;
use super::reference::Reference;
use super::timeline::Timeline;
use super::worker::{Command, Frame, Worker};
use crate::io::atomic::write_file;
use crate::render::{LightRig, OrbitCamera};
use crate::scene::Scene;
use crate::scene::file::{MeshSpec, SceneFile};
use crate::scene::preset::Preset;
use crate::sim::fabric::Fabric;
use crate::stage::figure::FigurePath;
use crate::stage::fit_map::FitMap;

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

/// The Export panel's choices for PNG frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageChoices {
    /// Width and height, pixels; `None`: the viewport's.
    pub size: Option<(u32, u32)>,
    /// Through the view composed on screen (else the scene's camera).
    pub through_view: bool,
    /// Every simulated frame (else the one shown).
    pub all_frames: bool,
}

impl Default for ImageChoices {
    fn default() -> Self {
        ImageChoices { size: Some((1920, 1080)), through_view: true, all_frames: true }
    }
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
    /// Where the figure goes over the range (a following camera tracks it).
    pub figure: FigurePath,
    /// The viewport's width over its height (set by the panels).
    pub viewport_aspect: f32,
    /// Bumped whenever the drawn scene must be rebuilt (new scene, new look).
    pub generation: u64,
    /// Messages to show.
    pub messages: Vec<Message>,
    /// The scene file as last opened or saved (every setting in it): the
    /// scene is unsaved while the document differs from it.
    saved: SceneFile,
    /// Undo and redo.
    pub history: History,
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
    loading: Option<(scene_edits::Loading, Receiver<Result<Scene, String>>)>,
    /// The scene file of the edit being resolved in the background: the
    /// panels show it and later edits build on it, so a second edit made
    /// before the first is loaded does not undo it.
    edited: Option<SceneFile>,
    /// The window should close (set once the user confirmed).
    pub quit: bool,
    /// What waits for the user's answer on unsaved changes.
    pub pending: Option<Pending>,
    /// The Help ▸ Keyboard window is open.
    pub show_keyboard: bool,
    /// The example scenes, read when File ▸ Examples first opens.
    pub examples: Option<Vec<super::examples::Example>>,
    /// The frames of the last bake that completed, kept while another runs.
    last_bake: Option<Vec<Frame>>,
    /// The fit map colouring the cloth, if any.
    pub fit_map: Option<FitMap>,
    /// What PNG frames are exported as.
    pub images: ImageChoices,
    /// The viewport's size, physical pixels (set by the panels).
    pub viewport_pixels: [u32; 2],
    /// The result pinned as A, if any.
    pub pinned: Option<Pinned>,
    /// What the viewport shows of A and B.
    pub compare: Compare,
    /// When the last frames of the running simulation arrived.
    arrivals: std::collections::VecDeque<Instant>,
    /// The overlay shows the engineering detail under its first line.
    pub show_details: bool,
}

/// An action that would lose unsaved changes, waiting for the user to say
/// whether to save them first.
#[derive(Clone, Debug, PartialEq)]
pub enum Pending {
    /// Close the window.
    Quit,
    /// Open this scene file.
    Open(PathBuf),
    /// Read the scene file again from disk.
    Reload,
    /// Start an untitled scene.
    New,
}

impl Editor {
    /// An editor on `scene`, its worker started.
    pub fn new(scene: Scene) -> Editor {
        let timeline = Timeline::new(scene.fps, scene.frame_count);
        let rigs = LightRig::built_in();
        let mut paths = PathFields::default();
        if let Some(source) = &scene.source {
            paths.scene = source.display().to_string();
        }
        let base_effort = (scene.steps_per_frame, scene.solver.tolerance);
        let worker = Worker::start(scene.clone());
        let time_step_s = finest_time_step(&scene);
        let simulated_fabrics = scene.garments.iter().map(|g| g.fabric.clone()).collect();
        let saved = scene.to_file();
        let history = History::new(Document { file: saved.clone(), quality: Quality::Balanced });
        let figure = FigurePath::new(&scene);
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
            figure,
            viewport_aspect: 1.5,
            generation: 0,
            messages: Vec::new(),
            saved,
            history,
            paths,
            export: None,
            browse: None,
            reference: None,
            reference_job: None,
            loading: None,
            edited: None,
            quit: false,
            pending: None,
            show_keyboard: false,
            examples: None,
            last_bake: None,
            fit_map: None,
            images: ImageChoices::default(),
            viewport_pixels: [1280, 720],
            pinned: None,
            compare: Compare::B,
            arrivals: Default::default(),
            show_details: false,
        };
        editor.fill_paths();
        editor
    }

    fn fill_paths(&mut self) {
        if let Some(source) = &self.scene.source {
            self.paths.scene = source.display().to_string();
        }
        self.paths.export = match &self.scene.file.export.folder {
            Some(folder) => self.base_dir().join(folder).display().to_string(),
            None => format!("out/{}", self.scene.name),
        };
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

    /// Sends the selected garment's edited fabric (its `parameter` changed)
    /// to the simulation, if valid, and records the edit.
    pub fn fabric_changed(&mut self, parameter: &str) {
        if self.send_fabric() {
            let name = self.scene.garments.get(self.garment).map_or("", |g| g.name.as_str());
            let label = format!("{parameter} of {name}");
            self.commit(&label);
        }
    }

    /// Sends the selected garment's fabric to the simulation; false (and a
    /// message) when a value is out of range.
    fn send_fabric(&mut self) -> bool {
        let g = self.garment;
        let Some(garment) = self.scene.garments.get(g) else { return false };
        match garment.fabric.validate() {
            Ok(()) => {
                self.worker.send(Command::SetFabric { garment: g, fabric: Box::new(garment.fabric.clone()) });
                self.forget_reference();
            }
            Err(e) => {
                self.tell(format!("garment '{}': {e}", garment.name), true);
                return false;
            }
        }
        let finest = finest_time_step(&self.scene);
        if finest != self.time_step_s {
            self.time_step_s = finest;
            self.base_effort.0 = steps_for(self.scene.frame_duration(), finest);
            self.set_effort(self.quality);
        }
        true
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
                    if self.send_fabric() {
                        self.commit(&format!("preset {reference}"));
                    }
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

    /// Sets the simulation's effort from the next frame on, as an edit.
    pub fn set_quality(&mut self, quality: Quality) {
        self.set_effort(quality);
        self.commit(&format!("quality {}", quality.label()));
    }

    /// Sets the simulation's effort from the next frame on.
    fn set_effort(&mut self, quality: Quality) {
        self.quality = quality;
        let (steps_per_frame, tolerance) = quality.effort(self.base_effort.0, self.base_effort.1);
        self.scene.steps_per_frame = steps_per_frame;
        self.scene.solver.tolerance = tolerance;
        self.worker.send(Command::SetEffort { steps_per_frame, tolerance });
    }

    /// The window asks to close: yes unless there are unsaved changes, in
    /// which case the user is asked first.
    pub fn request_quit(&mut self) -> bool {
        if self.quit || !self.dirty() {
            return true;
        }
        self.pending = Some(Pending::Quit);
        false
    }

    /// Does `action` now, or, with unsaved changes, asks the user first.
    pub fn unless_unsaved(&mut self, action: Pending) {
        match self.dirty() {
            true => self.pending = Some(action),
            false => self.carry_out(action),
        }
    }

    /// Does `action` (the user answered, or nothing was unsaved).
    pub fn carry_out(&mut self, action: Pending) {
        self.pending = None;
        match action {
            Pending::Quit => self.quit = true,
            Pending::Open(path) => self.open_scene_now(path),
            Pending::Reload => match self.scene.source.clone() {
                Some(path) => self.open_scene_now(path),
                None => self.tell("this scene has no file to reload: save it first", true),
            },
            Pending::New => self.new_scene(),
        }
    }

    /// The window's title: `drape — SCENE`, with `•` while unsaved.
    pub fn title(&self) -> String {
        format!("drape — {}{}", self.scene.name, if self.dirty() { " •" } else { "" })
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
