//! The editor's scene file work: opening, re-resolving after an edit (in the
//! background, keeping the current scene when that fails), saving.

use std::path::{Path, PathBuf};
use std::sync::mpsc::channel;

use super::{Editor, Quality, RunState, finest_time_step};
use crate::app::browse::{Browse, Purpose};
use crate::app::timeline::Timeline;
use crate::app::worker::Command;
use crate::io::atomic::write_file;
use crate::scene::Scene;
use crate::scene::file::{MeshSpec, SceneFile};

impl Editor {
    /// The folder relative paths in the scene are resolved against.
    pub fn base_dir(&self) -> PathBuf {
        self.scene.source.as_deref().and_then(Path::parent).map(Path::to_owned).unwrap_or_default()
    }

    /// Opens the scene file at `path` in the background; the current scene
    /// stays until it has loaded, and stays when it fails.
    pub fn open_scene(&mut self, path: PathBuf) {
        self.start_loading(move || Scene::load(&path).map_err(|e| e.to_string()));
    }

    /// Applies `edit` to the scene file and resolves it again in the
    /// background (new garment mesh, body, transform, collision settings); on
    /// failure the current scene stays and the error is shown.
    pub fn edit_scene(&mut self, edit: impl FnOnce(&mut SceneFile)) {
        // Only an edit still loading leaves a file behind (every load's end
        // drops it).
        let mut file = self.edited.take().unwrap_or_else(|| self.scene.to_file());
        edit(&mut file);
        let path = self.scene.source.clone().unwrap_or_else(|| PathBuf::from(format!("{}.toml", self.scene.name)));
        let resolved = file.clone();
        self.start_loading(move || Scene::resolve(resolved, &path).map_err(|e| e.to_string()));
        self.edited = Some(file);
        self.dirty = true;
    }

    /// The scene file as the panels show it: with the edit being loaded, if
    /// any.
    pub fn scene_file(&self) -> &SceneFile {
        self.edited.as_ref().unwrap_or(&self.scene.file)
    }

    /// Replaces the selected garment's mesh with the OBJ at `path`.
    pub fn use_garment_mesh(&mut self, path: PathBuf) {
        let g = self.garment;
        self.edit_scene(|file| {
            if let Some(spec) = file.garments.get_mut(g) {
                spec.mesh = MeshSpec::Obj(path);
            }
        });
    }

    /// Replaces the first body with the FBX or motion cache at `path`.
    pub fn use_body(&mut self, path: PathBuf) {
        if self.scene.file.bodies.is_empty() {
            return self.tell("this scene has no body to replace", true);
        }
        self.edit_scene(|file| {
            if let Some(body) = file.bodies.first_mut() {
                body.file = path;
                // Mesh and stack names belong to the file replaced.
                (body.parts, body.exclude) = (None, Vec::new());
                body.stack = body.stack.take().filter(|_| body.motion.is_some());
            }
        });
    }

    /// Keeps (`keep`) or leaves out the first body's mesh `name`.
    pub fn keep_body_mesh(&mut self, name: &str, keep: bool) {
        self.edit_scene(|file| {
            let Some(body) = file.bodies.first_mut() else { return };
            body.exclude.retain(|m| m != name);
            if let Some(parts) = &mut body.parts {
                parts.retain(|m| m != name);
                if keep {
                    parts.push(name.to_owned());
                }
            } else if !keep {
                body.exclude.push(name.to_owned());
            }
        });
    }

    /// Plays the first body's animation stack `name` (of its motion file when it has one).
    pub fn use_stack(&mut self, name: String) {
        self.edit_scene(|file| {
            if let Some(body) = file.bodies.first_mut() {
                body.stack = Some(name);
            }
        });
    }

    /// Drives the first body with the motion of the FBX at `path`.
    pub fn use_motion(&mut self, path: PathBuf) {
        if self.scene.file.bodies.is_empty() {
            return self.tell("this scene has no body to drive", true);
        }
        self.edit_scene(|file| {
            if let Some(body) = file.bodies.first_mut() {
                body.motion = Some(path);
                body.stack = None;
            }
        });
    }

    /// Opens a file dialog for `purpose`, starting where `current` (a path
    /// field's text) points, else in the scene's folder.
    pub fn browse(&mut self, purpose: Purpose, current: &str) {
        let base = self.base_dir();
        let current = Path::new(current.trim());
        let start = if current.as_os_str().is_empty() { base } else { base.join(current) };
        let folder = if start.is_dir() { start } else { start.parent().map(Path::to_owned).unwrap_or_default() };
        self.browse = Some(Browse::open(purpose, &folder));
    }

    pub(super) fn start_loading(&mut self, load: impl FnOnce() -> Result<Scene, String> + Send + 'static) {
        let (sender, receiver) = channel();
        std::thread::spawn(move || {
            let _ = sender.send(load());
        });
        self.loading = Some(receiver);
        self.edited = None;
    }

    /// True while a scene is being loaded.
    pub fn is_loading(&self) -> bool {
        self.loading.is_some()
    }

    /// Waits for a scene being loaded (tests).
    pub fn finish_loading(&mut self) {
        self.edited = None;
        if let Some(Ok(result)) = self.loading.take().map(|receiver| receiver.recv()) {
            self.loaded(result);
        }
    }

    pub(super) fn poll_loading(&mut self) {
        let Some(receiver) = &self.loading else { return };
        match receiver.try_recv() {
            Ok(result) => {
                (self.loading, self.edited) = (None, None);
                self.loaded(result);
            }
            Err(std::sync::mpsc::TryRecvError::Empty) => {}
            Err(std::sync::mpsc::TryRecvError::Disconnected) => {
                (self.loading, self.edited) = (None, None);
                self.tell("loading the scene failed unexpectedly", true);
            }
        }
    }

    pub(super) fn loaded(&mut self, result: Result<Scene, String>) {
        match result {
            Ok(scene) => {
                let opened_other = scene.source != self.scene.source;
                self.simulated_fabrics = scene.garments.iter().map(|g| g.fabric.clone()).collect();
                self.base_effort = (scene.steps_per_frame, scene.solver.tolerance);
                self.time_step_s = finest_time_step(&scene);
                self.quality = Quality::Balanced;
                self.timeline = Timeline::new(scene.fps, scene.frame_count);
                self.scene = scene;
                self.forget_reference();
                self.worker.send(Command::Reset(Box::new(self.scene.clone())));
                self.run = RunState::Idle;
                self.generation += 1;
                if opened_other {
                    self.camera.frame_all();
                    self.dirty = false;
                    self.paths.export = format!("out/{}", self.scene.name);
                }
                self.fill_paths();
                if let Some(source) = &self.scene.source {
                    self.paths.scene = source.display().to_string();
                }
            }
            Err(e) => self.tell(e, true),
        }
    }

    /// Writes the scene file, with every current setting, to `path`.
    pub fn save_scene(&mut self, path: &Path) {
        let text = match toml::to_string_pretty(&self.scene.to_file()) {
            Ok(text) => text,
            Err(e) => return self.tell(format!("cannot write the scene: {e}"), true),
        };
        match write_file(path, |out| std::io::Write::write_all(out, text.as_bytes())) {
            Ok(()) => {
                self.dirty = false;
                self.tell(format!("saved {}", path.display()), false);
            }
            Err(e) => self.tell(e.to_string(), true),
        }
    }
}
