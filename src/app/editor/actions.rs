//! What the menus, the toolbar and the keyboard shortcuts do, each by one
//! name, so that a key and a menu item can never do different things.

use std::path::PathBuf;

use super::{Editor, Pending, RunState};
use crate::app::dialog::Purpose;
use crate::app::orbit::ViewSide;
use crate::stage::fit_map::FitMap;

/// Something the user asks the editor to do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    /// An untitled scene (asks first when there are unsaved changes).
    New,
    /// The open-a-scene dialog.
    Open,
    /// Write the scene file (Save As when it has none).
    Save,
    /// The save-the-scene-as dialog.
    SaveAs,
    /// Read the scene file again (asks first when there are unsaved changes).
    Reload,
    /// Undo the newest edit.
    Undo,
    /// Redo the edit undone last.
    Redo,
    /// Play or pause the simulated frames.
    PlayPause,
    /// Simulate live, or pause the simulation.
    SimulateOrPause,
    /// Bake every frame from the start.
    Bake,
    /// Stop the running job: the bake, an export, a reference run.
    Cancel,
    /// The playhead to frame 0.
    FirstFrame,
    /// The playhead to the newest frame.
    LastFrame,
    /// One frame back.
    PreviousFrame,
    /// One frame on.
    NextFrame,
    /// Fit the garment and body at the current frame in the view.
    Frame,
    /// Look at the figure from one side.
    View(ViewSide),
    /// Keep the figure framed while it walks, or stop doing so.
    Follow,
    /// Close the window (asks first when there are unsaved changes).
    Quit,
    /// Colour the cloth by the next fit map (none, strain, contact).
    NextFitMap,
    /// Pin the current result as A.
    PinA,
    /// Show A, B, or both side by side, in turn.
    NextCompare,
}

impl Editor {
    /// Does `action`.
    pub fn act(&mut self, action: Action) {
        match action {
            Action::New => self.unless_unsaved(Pending::New),
            Action::Open => {
                let current = self.paths.scene.clone();
                self.browse(Purpose::OpenScene, &current);
            }
            Action::Save => self.save(),
            Action::SaveAs => {
                let current = self.paths.scene.clone();
                self.browse(Purpose::SaveScene, &current);
            }
            Action::Reload => self.unless_unsaved(Pending::Reload),
            Action::Undo => self.undo(),
            Action::Redo => self.redo(),
            Action::PlayPause => self.timeline.playing = !self.timeline.playing,
            Action::SimulateOrPause => match self.run {
                RunState::Idle => self.simulate(),
                _ => self.pause(),
            },
            Action::Bake if self.run == RunState::Idle => self.bake(),
            Action::Bake => self.tell("the simulation is running: pause it to bake", false),
            Action::Cancel => self.cancel_jobs(),
            Action::FirstFrame => self.timeline.seek(0),
            Action::LastFrame => self.timeline.seek(self.timeline.end()),
            Action::PreviousFrame => self.timeline.step(-1),
            Action::NextFrame => self.timeline.step(1),
            Action::Frame => self.frame_figure(),
            Action::View(side) => self.view_from(side),
            Action::Follow => self.camera.follow = !self.camera.follow,
            Action::NextFitMap => {
                self.fit_map = match self.fit_map {
                    None => Some(FitMap::Strain),
                    Some(FitMap::Strain) => Some(FitMap::Contact),
                    Some(FitMap::Contact) => None,
                }
            }
            Action::PinA => self.pin_a(),
            Action::NextCompare => self.next_compare(),
            Action::Quit => {
                if self.request_quit() {
                    self.quit = true;
                }
            }
        }
    }

    /// Saves to the scene's file, or asks where when it has none.
    fn save(&mut self) {
        let path = PathBuf::from(self.paths.scene.trim());
        match path.as_os_str().is_empty() {
            true => self.act(Action::SaveAs),
            false => self.save_scene(&path),
        }
    }

    /// Stops whatever runs: a bake or live run, an export, a reference run.
    fn cancel_jobs(&mut self) {
        if self.run != RunState::Idle {
            self.pause();
        }
        if self.export.is_some() {
            self.cancel_export();
        }
        if self.reference_job.is_some() {
            self.cancel_reference();
        }
    }
}
