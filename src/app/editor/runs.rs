//! Running the simulation from the editor: live (on past the scene's range
//! for as long as the designer tunes), baking (the last complete bake kept
//! until a new one completes), simulating again from the frame shown, and
//! which frames are stale (simulated with other settings than the current).

use std::time::Instant;

use super::{Editor, RunState};
use crate::app::worker::{Command, Event, Frame, Settings, Stop, live_frames};

/// The simulation's rate is measured over this much wall time, s.
const RATE_WINDOW_S: f64 = 2.0;

/// What a frame on the timeline is, for its colour in the cache bar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameKind {
    /// Baked from frame 0 with the current settings.
    Baked,
    /// Simulated live with the current settings.
    Simulated,
    /// Simulated with other settings than the current ones.
    Stale,
}

impl Editor {
    /// Runs the simulation live from the newest frame, on past the scene's
    /// range (the body holds its last pose or cycles) until paused.
    pub fn simulate(&mut self) {
        let cap = live_frames(&self.scene);
        if self.timeline.last() >= cap {
            let text = format!("the timeline holds {cap} frames, as many as memory allows: Reset or re-simulate");
            return self.tell(text, false);
        }
        self.timeline.playing = false;
        self.timeline.set_body_only(false);
        self.timeline.seek(self.timeline.last());
        self.worker.send(Command::Simulate);
        self.run = RunState::Live;
    }

    /// Drops the frames after the one shown and simulates live from it with
    /// the current settings.
    pub fn resimulate_from_here(&mut self) {
        let k = self.timeline.current().min(self.timeline.last());
        let Some(frame) = self.timeline.frame(k) else { return };
        let state = frame.state.clone();
        if self.run != RunState::Idle {
            self.worker.send(Command::Pause);
        }
        self.timeline.truncate_after(k);
        self.worker.send(Command::RestartFrom { frame: k, state });
        self.simulate();
    }

    /// Pauses a live run (or cancels a bake).
    pub fn pause(&mut self) {
        self.worker.send(Command::Pause);
    }

    /// Bakes the whole range from frame 0 (the last complete bake stays
    /// until this one completes).
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

    /// Frames of animation simulated per second of wall time over the last
    /// `RATE_WINDOW_S` seconds, while the simulation runs.
    pub fn simulation_rate(&self) -> Option<f64> {
        let (first, last) = (self.arrivals.front()?, self.arrivals.back()?);
        let span = last.duration_since(*first).as_secs_f64();
        (self.run != RunState::Idle && span > 0.0).then(|| (self.arrivals.len() - 1) as f64 / span)
    }

    fn note_arrival(&mut self) {
        let now = Instant::now();
        self.arrivals.push_back(now);
        while self.arrivals.front().is_some_and(|t| now.duration_since(*t).as_secs_f64() > RATE_WINDOW_S) {
            self.arrivals.pop_front();
        }
    }

    /// The settings the next frame is simulated with.
    pub fn current_settings(&self) -> Settings {
        Settings::of(&self.scene)
    }

    /// What each stored frame is, in order.
    pub fn frame_kinds(&self) -> Vec<FrameKind> {
        let current = self.current_settings();
        self.timeline.frames().iter().map(|f| kind(f, &current)).collect()
    }

    /// Whether the frame shown was simulated with other settings.
    pub fn shown_is_stale(&self) -> bool {
        let current = self.current_settings();
        self.timeline.shown().is_some_and(|f| kind(f, &current) == FrameKind::Stale)
    }

    pub(super) fn on_event(&mut self, event: Event) {
        match event {
            Event::Restarted(frame) => self.timeline.restart(frame),
            Event::Frame(frame) => {
                self.note_arrival();
                self.timeline.push(frame);
            }
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
            Event::Stopped(stop) => self.stopped(stop),
            Event::Refused(reason) => self.tell(reason, true),
        }
    }

    fn stopped(&mut self, stop: Stop) {
        let was = std::mem::replace(&mut self.run, RunState::Idle);
        let baking = matches!(was, RunState::Baking { .. });
        match stop {
            Stop::Finished if baking => {
                self.last_bake = Some(self.timeline.frames().to_vec());
                self.tell(format!("baked {} frames", self.timeline.last()), false);
            }
            Stop::Finished => {
                let text =
                    format!("stopped at frame {}: the timeline holds as many as memory allows", self.timeline.last());
                self.tell(text, false);
            }
            Stop::ByUser if baking => self.bake_cancelled(),
            Stop::ByUser => {}
            Stop::Failed(reason) => self.tell(format!("simulation stopped: {reason}"), true),
        }
    }

    /// A cancelled bake gives the timeline back to the last complete bake,
    /// if any (the simulation goes on from its end); else its own frames stay.
    fn bake_cancelled(&mut self) {
        let reached = self.timeline.last();
        let Some(previous) = self.last_bake.clone() else {
            return self.tell(format!("bake cancelled: frames 0 to {reached} are kept"), false);
        };
        self.timeline.replace(previous);
        if let Some(newest) = self.timeline.newest() {
            let (frame, state) = (self.timeline.last(), newest.state.clone());
            self.worker.send(Command::RestartFrom { frame, state });
        }
        self.tell(format!("bake cancelled at frame {reached}: the previous bake is back"), false);
    }
}

/// What `frame` is, given the `current` settings.
fn kind(frame: &Frame, current: &Settings) -> FrameKind {
    match (*frame.settings == *current, frame.baked) {
        (false, _) => FrameKind::Stale,
        (true, true) => FrameKind::Baked,
        (true, false) => FrameKind::Simulated,
    }
}
