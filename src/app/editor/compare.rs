//! A/B compare: the designer pins the current result as A, changes the
//! fabric, and sees A beside the new result B (or toggles between them) at
//! the same frame, through the same camera.

use super::Editor;
use crate::app::worker::Frame;
use crate::scene::Scene;

/// A result kept to compare the current one with.
pub struct Pinned {
    /// Its frames, frame 0 first.
    pub frames: Vec<Frame>,
    /// The scene as it was (its garments' looks and fabrics).
    pub scene: Scene,
    /// What it was, in a few words ("cotton", "cotton, edited").
    pub label: String,
    /// Tells one pin from the next, for what is drawn of it.
    pub id: u64,
}

impl Pinned {
    /// The frame of A at the playhead's `frame` (its newest when it has fewer).
    pub fn frame(&self, frame: usize) -> Option<&Frame> {
        self.frames.get(frame.min(self.frames.len().saturating_sub(1)))
    }
}

/// What the viewport shows while a result is pinned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compare {
    /// The current result (B) alone.
    B,
    /// The pinned result (A) alone.
    A,
    /// A on the left, B on the right.
    SideBySide,
}

impl Editor {
    /// Pins the frames simulated so far as A.
    pub fn pin_a(&mut self) {
        if self.timeline.len() < 2 {
            return self.tell("nothing to pin yet: Simulate or Bake first", false);
        }
        let id = self.pinned.as_ref().map_or(1, |p| p.id + 1);
        let label = self.result_label();
        self.tell(format!("pinned as A: {label}; change the fabric and simulate to compare"), false);
        let pinned = Pinned { frames: self.timeline.frames().to_vec(), scene: self.scene.clone(), label, id };
        self.pinned = Some(pinned);
        self.compare = Compare::SideBySide;
    }

    /// Drops A.
    pub fn unpin(&mut self) {
        self.pinned = None;
        self.compare = Compare::B;
    }

    /// Shows A, then B, then both side by side, then A again.
    pub fn next_compare(&mut self) {
        if self.pinned.is_none() {
            return self.tell("pin a result as A first (Pin A)", false);
        }
        self.compare = match self.compare {
            Compare::A => Compare::B,
            Compare::B => Compare::SideBySide,
            Compare::SideBySide => Compare::A,
        };
    }

    /// What the current result is: the selected garment's preset, and
    /// whether its fabric was changed from it.
    pub fn result_label(&self) -> String {
        let Some(garment) = self.scene.garments.get(self.garment) else { return String::new() };
        let edited = garment.fabric != garment.preset.fabric;
        format!("{}{}", garment.preset.name, if edited { ", edited" } else { "" })
    }
}
