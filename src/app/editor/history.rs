//! Undo and redo of every edit: the document (the scene file with every
//! current setting, and the quality) before each edit, with the edit's
//! name. Changes under the same name within a moment of each other (a
//! slider being dragged) make one step. Whether the scene is unsaved is
//! whether the document differs from the one last opened or saved.

use std::time::{Duration, Instant};

use super::{Editor, Quality};
use crate::scene::file::SceneFile;
use crate::scene::preset::Preset;
use crate::sim::fabric::Fabric;

/// Changes of the same name closer together than this are one step.
const COALESCE: Duration = Duration::from_millis(800);

/// What undo and redo go back and forth between.
#[derive(Clone, Debug, PartialEq)]
pub struct Document {
    /// The scene file, every current setting in it.
    pub file: SceneFile,
    /// The simulation's effort.
    pub quality: Quality,
}

/// One step of the history: its name and the document on its other side.
#[derive(Clone, Debug)]
struct Step {
    label: String,
    document: Document,
    at: Instant,
}

/// The steps that can be undone and redone.
#[derive(Clone, Debug)]
pub struct History {
    undo: Vec<Step>,
    redo: Vec<Step>,
    /// The document as it is now, as far as the history knows.
    current: Document,
}

impl History {
    /// A history that starts at `document`.
    pub fn new(document: Document) -> History {
        History { undo: Vec::new(), redo: Vec::new(), current: document }
    }

    /// The names of the steps that can be undone (newest last) and redone (next first).
    pub fn labels(&self) -> (Vec<&str>, Vec<&str>) {
        let undo = self.undo.iter().map(|s| s.label.as_str()).collect();
        let redo = self.redo.iter().rev().map(|s| s.label.as_str()).collect();
        (undo, redo)
    }
}

impl Editor {
    /// The document as the panels show it now.
    pub fn document(&self) -> Document {
        Document { file: self.edited.clone().unwrap_or_else(|| self.scene.to_file()), quality: self.quality }
    }

    /// Records the edit just made as a step named `label` (nothing when it
    /// changed nothing); a change of the same name a moment after the last
    /// one joins its step.
    pub(super) fn commit(&mut self, label: &str) {
        let now = self.document();
        if now == self.history.current {
            return;
        }
        let joins = self.history.redo.is_empty()
            && self.history.undo.last().is_some_and(|s| s.label == label && s.at.elapsed() < COALESCE);
        match joins {
            true => {
                if let Some(step) = self.history.undo.last_mut() {
                    step.at = Instant::now();
                }
            }
            false => {
                let before = std::mem::replace(&mut self.history.current, now.clone());
                self.history.undo.push(Step { label: label.to_owned(), document: before, at: Instant::now() });
            }
        }
        self.history.current = now;
        self.history.redo.clear();
    }

    /// Forgets the newest step: its edit did not take (a file that failed to load).
    pub(super) fn drop_last_step(&mut self) {
        if let Some(step) = self.history.undo.pop() {
            self.history.current = step.document;
        }
    }

    /// Starts a new history at the current document (a scene opened or made).
    pub(super) fn forget_history(&mut self) {
        self.history = History::new(self.document());
    }

    /// Undoes the newest step.
    pub fn undo(&mut self) {
        let Some(step) = self.history.undo.pop() else { return self.tell("nothing to undo", false) };
        let now = std::mem::replace(&mut self.history.current, step.document.clone());
        self.history.redo.push(Step { label: step.label.clone(), document: now, at: Instant::now() });
        self.apply(step.document);
        self.tell(format!("undone: {}", step.label), false);
    }

    /// Redoes the step undone last.
    pub fn redo(&mut self) {
        let Some(step) = self.history.redo.pop() else { return self.tell("nothing to redo", false) };
        let now = std::mem::replace(&mut self.history.current, step.document.clone());
        self.history.undo.push(Step { label: step.label.clone(), document: now, at: Instant::now() });
        self.apply(step.document);
        self.tell(format!("redone: {}", step.label), false);
    }

    /// Whether the document differs from the scene as last opened or saved.
    pub fn dirty(&self) -> bool {
        self.document().file != self.saved || self.edited.is_some()
    }

    /// Makes `document` the editor's: fabrics and presets reach the running
    /// simulation like any change, the export folder is taken as it is;
    /// anything else resolves the scene again.
    fn apply(&mut self, document: Document) {
        if document.quality != self.quality {
            self.set_effort(document.quality);
        }
        let current = self.document().file;
        if only_live_settings_differ(&current, &document.file) {
            self.apply_fabrics(&document.file);
            self.scene.file.export = document.file.export.clone();
            self.fill_paths();
        } else if current != document.file {
            self.resolve(document.file);
        }
    }

    /// Every garment's preset and fabric from `file`, live.
    fn apply_fabrics(&mut self, file: &SceneFile) {
        let base = self.base_dir();
        for (g, spec) in file.garments.iter().enumerate() {
            let Some(garment) = self.scene.garments.get_mut(g) else { continue };
            let Ok(fabric) = Fabric::deserialize(toml::Value::Table(spec.fabric.clone())) else { continue };
            let preset_changed = self.scene.file.garments.get(g).is_some_and(|s| s.preset != spec.preset);
            if preset_changed && let Ok(preset) = Preset::resolve(&spec.preset, &base, &toml::Table::new()) {
                garment.preset = preset;
                self.generation += 1;
            }
            if let Some(own) = self.scene.file.garments.get_mut(g) {
                own.preset = spec.preset.clone();
            }
            if garment.fabric != fabric {
                garment.fabric = fabric;
                let previous = self.garment;
                self.garment = g;
                self.send_fabric();
                self.garment = previous;
            }
        }
    }
}

/// Whether two scene files differ in what changes without a restart alone:
/// their garments' fabrics and presets, the export folder.
fn only_live_settings_differ(a: &SceneFile, b: &SceneFile) -> bool {
    let blank = |file: &SceneFile| {
        let mut file = file.clone();
        file.export = Default::default();
        for g in &mut file.garments {
            g.fabric = toml::Table::new();
            g.preset = String::new();
        }
        file
    };
    blank(a) == blank(b)
}

use serde::Deserialize as _;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fabric_changes_are_told_apart_from_scene_changes() {
        let text = "[time]\nfps = 30.0\nduration_s = 1.0\n[[garment]]\nname = \"g\"\npreset = \"cotton\"\nmesh = { grid = { size_m = 1.0, resolution = 4 } }\n";
        let a: SceneFile = toml::from_str(text).unwrap();
        let mut b = a.clone();
        b.garments[0].preset = "silk".into();
        assert!(only_live_settings_differ(&a, &b));
        b.export.folder = Some("renders".into());
        assert!(only_live_settings_differ(&a, &b), "the export folder too");
        b.garments[0].translation_m[1] = 0.5;
        assert!(!only_live_settings_differ(&a, &b));
    }
}
