//! The editor's scene file work: opening, re-resolving after an edit (in the
//! background, keeping the current scene when that fails), saving.

use std::path::{Path, PathBuf};
use std::sync::mpsc::channel;

use super::{Editor, Pending, Quality, RunState, finest_time_step};
use crate::app::dialog::{Browse, Purpose};
use crate::app::timeline::Timeline;
use crate::app::worker::Command;
use crate::io::atomic::write_file;
use crate::scene::Scene;
use crate::scene::file::{BodySpec, MeshSpec, SceneFile};
use crate::stage::figure::FigurePath;

/// The scene File ▸ New starts from.
const NEW_SCENE: &str = r#"
description = "A new scene: load a garment OBJ and a body FBX in the Scene panel."
[time]
fps = 30.0
duration_s = 4.0
[[garment]]
name = "garment"
preset = "cotton"
mesh = { grid = { size_m = 1.0, resolution = 40 } }
translation_m = [0.0, 1.0, 0.0]
self_collision = true
[[collider]]
name = "ground"
shape = "plane"
"#;

/// What a scene being loaded is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Loading {
    /// Another scene file, opened: a new document.
    Open,
    /// The same scene after an edit (or an undo).
    Edit,
}

impl Editor {
    /// The folder relative paths in the scene are resolved against.
    pub fn base_dir(&self) -> PathBuf {
        self.scene.source.as_deref().and_then(Path::parent).map(Path::to_owned).unwrap_or_default()
    }

    /// Opens the scene file at `path` in the background (asking first when
    /// there are unsaved changes); the current scene stays until it has
    /// loaded, and stays when it fails.
    pub fn open_scene(&mut self, path: PathBuf) {
        self.unless_unsaved(Pending::Open(path));
    }

    /// Starts an untitled scene: a square of cotton over the ground, to
    /// load a garment and a body into.
    pub(super) fn new_scene(&mut self) {
        let base = std::env::current_dir().unwrap_or_default();
        let scene = Scene::parse(NEW_SCENE, "untitled", &base, "new scene").map_err(|e| e.to_string());
        self.loaded(Loading::Open, scene);
        self.paths.scene.clear();
    }

    /// Opens the scene file at `path` in the background, unsaved changes or not.
    pub(super) fn open_scene_now(&mut self, path: PathBuf) {
        self.start_loading(Loading::Open, move || Scene::load(&path).map_err(|e| e.to_string()));
    }

    /// Applies `edit` (named `label` in the history) to the scene file and
    /// resolves it again in the background (new garment mesh, body,
    /// transform, collision settings); on failure the current scene stays,
    /// every field as it was, and the error is shown.
    pub fn edit_scene(&mut self, label: &str, edit: impl FnOnce(&mut SceneFile)) {
        // Only an edit still loading leaves a file behind (every load's end
        // drops it).
        let mut file = self.edited.take().unwrap_or_else(|| self.scene.to_file());
        edit(&mut file);
        self.resolve(file);
        self.commit(label);
    }

    /// Resolves `file` as the scene in the background (an edit, or undo).
    pub(super) fn resolve(&mut self, file: SceneFile) {
        let path = self.scene.source.clone().unwrap_or_else(|| PathBuf::from(format!("{}.toml", self.scene.name)));
        let resolved = file.clone();
        self.start_loading(Loading::Edit, move || Scene::resolve(resolved, &path).map_err(|e| e.to_string()));
        self.edited = Some(file);
    }

    /// The scene file as the panels show it: with the edit being loaded, if
    /// any.
    pub fn scene_file(&self) -> &SceneFile {
        self.edited.as_ref().unwrap_or(&self.scene.file)
    }

    /// Replaces the selected garment's mesh with the OBJ at `path`.
    pub fn use_garment_mesh(&mut self, path: PathBuf) {
        let g = self.garment;
        self.edit_scene("load garment OBJ", |file| {
            if let Some(spec) = file.garments.get_mut(g) {
                spec.mesh = MeshSpec::Obj(path);
            }
        });
    }

    /// Replaces the first body with the FBX or motion cache at `path` (or
    /// adds it to a scene without one).
    pub fn use_body(&mut self, path: PathBuf) {
        self.edit_scene("load body", |file| {
            if file.bodies.is_empty() {
                file.bodies.push(BodySpec::new(path));
            } else if let Some(body) = file.bodies.first_mut() {
                body.file = path;
                // Mesh and stack names belong to the file replaced.
                (body.parts, body.exclude) = (None, Vec::new());
                body.stack = body.stack.take().filter(|_| body.motion.is_some());
            }
        });
    }

    /// Keeps (`keep`) or leaves out the first body's mesh `name`.
    pub fn keep_body_mesh(&mut self, name: &str, keep: bool) {
        let label = format!("{} body mesh {name}", if keep { "keep" } else { "leave out" });
        self.edit_scene(&label, |file| {
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
        self.edit_scene("animation stack", |file| {
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
        self.edit_scene("use motion", |file| {
            if let Some(body) = file.bodies.first_mut() {
                body.motion = Some(path);
                body.stack = None;
            }
        });
    }

    /// Opens a file dialog for `purpose` in the folder of `current` (a path
    /// field's text: a scene path as typed, relative to the working folder;
    /// any other relative to the scene's folder), else in the scene's folder.
    pub fn browse(&mut self, purpose: Purpose, current: &str) {
        let base = self.base_dir();
        let current = Path::new(current.trim());
        let start = match purpose {
            Purpose::OpenScene | Purpose::SaveScene | Purpose::ExportFolder => current.to_owned(),
            _ => base.join(current),
        };
        let folder = if start.is_dir() { start } else { start.parent().map(Path::to_owned).unwrap_or_default() };
        let folder = [folder, base].into_iter().find(|f| f.is_dir()).unwrap_or_else(|| PathBuf::from("."));
        self.browse = Some(Browse::open(purpose, &folder));
    }

    pub(super) fn start_loading(
        &mut self,
        kind: Loading,
        load: impl FnOnce() -> Result<Scene, String> + Send + 'static,
    ) {
        let (sender, receiver) = channel();
        std::thread::spawn(move || {
            let _ = sender.send(load());
        });
        self.loading = Some((kind, receiver));
        self.edited = None;
    }

    /// True while a scene is being loaded.
    pub fn is_loading(&self) -> bool {
        self.loading.is_some()
    }

    /// Waits for a scene being loaded (tests).
    pub fn finish_loading(&mut self) {
        if let Some((kind, receiver)) = self.loading.take() {
            let result = receiver.recv().unwrap_or_else(|_| Err("loading the scene failed unexpectedly".into()));
            self.edited = None;
            self.loaded(kind, result);
        }
    }

    pub(super) fn poll_loading(&mut self) {
        let Some((kind, receiver)) = &self.loading else { return };
        let kind = *kind;
        let result = match receiver.try_recv() {
            Ok(result) => result,
            Err(std::sync::mpsc::TryRecvError::Empty) => return,
            Err(std::sync::mpsc::TryRecvError::Disconnected) => Err("loading the scene failed unexpectedly".into()),
        };
        (self.loading, self.edited) = (None, None);
        self.loaded(kind, result);
    }

    pub(super) fn loaded(&mut self, kind: Loading, result: Result<Scene, String>) {
        let scene = match result {
            Ok(scene) => scene,
            Err(e) => {
                // Nothing changed: the fields show the scene as it is.
                if kind == Loading::Edit {
                    self.drop_last_step();
                }
                self.fill_paths();
                return self.tell(e, true);
            }
        };
        self.simulated_fabrics = scene.garments.iter().map(|g| g.fabric.clone()).collect();
        self.time_step_s = finest_time_step(&scene);
        self.timeline = Timeline::new(scene.fps, scene.frame_count);
        self.figure = FigurePath::new(&scene);
        self.scene = scene;
        self.last_bake = None;
        if kind == Loading::Open {
            self.base_effort = (self.scene.steps_per_frame, self.scene.solver.tolerance);
            self.quality = Quality::Balanced;
        }
        self.forget_reference();
        self.worker.send(Command::Reset(Box::new(self.scene.clone())));
        self.run = RunState::Idle;
        self.generation += 1;
        if kind == Loading::Open {
            self.camera.frame_all();
            self.saved = self.scene.to_file();
            self.forget_history();
            self.unpin();
        }
        self.fill_paths();
    }

    /// Writes the scene file, with every current setting, to `path`.
    pub fn save_scene(&mut self, path: &Path) {
        let text = match toml::to_string_pretty(&self.scene.to_file()) {
            Ok(text) => text,
            Err(e) => return self.tell(format!("cannot write the scene: {e}"), true),
        };
        match write_file(path, |out| std::io::Write::write_all(out, text.as_bytes())) {
            Ok(()) => {
                self.saved = self.scene.to_file();
                self.tell(format!("saved {}", path.display()), false);
            }
            Err(e) => self.tell(e.to_string(), true),
        }
    }
}
