//! The frames simulated so far and the playhead over them.
//!
//! Frame 0 is the initial state; frame `k` ends at `k / fps` s. Playback moves
//! the playhead at `speed` times real time over the frames that exist, looping
//! or stopping at the last; while the simulation runs and the playhead is on
//! the newest frame, it follows each new frame as it arrives.

use super::worker::Frame;

/// The stored frames and the playhead.
#[derive(Clone, Debug)]
pub struct Timeline {
    frames: Vec<Frame>,
    fps: f64,
    /// Frames the scene has (after frame 0): the length of the range.
    pub range: usize,
    /// The frame shown.
    current: usize,
    /// Fraction of a frame the playhead has moved past `current` (0..1).
    phase: f64,
    /// Whether the playhead moves by itself.
    pub playing: bool,
    /// Wrap to frame 0 after the last frame.
    pub looping: bool,
    /// Playback speed, times real time (0.1..4).
    pub speed: f64,
    /// Play the body's motion alone over the whole range (PAPER Fig. 10b):
    /// the playhead runs past the simulated frames and the cloth is hidden.
    pub body_only: bool,
}

impl Timeline {
    /// An empty timeline for a scene of `range` frames at `fps`.
    pub fn new(fps: f64, range: usize) -> Self {
        Timeline {
            frames: Vec::new(),
            fps,
            range,
            current: 0,
            phase: 0.0,
            playing: false,
            looping: true,
            speed: 1.0,
            body_only: false,
        }
    }

    /// Drops every frame and starts again from `first` (frame 0).
    pub fn restart(&mut self, first: Frame) {
        self.frames.clear();
        self.frames.push(first);
        self.current = 0;
        self.phase = 0.0;
    }

    /// Puts `frames` (frame 0 first) in place of the stored ones, the
    /// playhead on the same frame where it can be.
    pub fn replace(&mut self, frames: Vec<Frame>) {
        self.frames = frames;
        self.current = self.current.min(self.end());
        self.phase = 0.0;
    }

    /// Drops the frames after `frame` (simulating again from it).
    pub fn truncate_after(&mut self, frame: usize) {
        self.frames.truncate(frame + 1);
        self.current = self.current.min(self.end());
    }

    /// Appends the next simulated frame; the playhead follows it when it was
    /// on the newest frame and not playing back.
    pub fn push(&mut self, frame: Frame) {
        let following = !self.playing && !self.body_only && self.current + 1 == self.frames.len();
        self.frames.push(frame);
        if following {
            self.current = self.frames.len() - 1;
        }
    }

    /// Frames stored (frame 0 included).
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// True before the first frame arrives.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The newest frame's number.
    pub fn last(&self) -> usize {
        self.frames.len().saturating_sub(1)
    }

    /// The last frame the playhead can reach: the newest simulated frame, or
    /// the end of the range when previewing the body alone.
    pub fn end(&self) -> usize {
        if self.body_only { self.range.max(self.last()) } else { self.last() }
    }

    /// Leaves body-only preview with the playhead back on a simulated frame.
    pub fn set_body_only(&mut self, body_only: bool) {
        self.body_only = body_only;
        self.current = self.current.min(self.end());
    }

    /// The frame shown.
    pub fn current(&self) -> usize {
        self.current
    }

    /// The simulated frame shown, if any is stored (in body-only preview,
    /// the newest at or before the playhead; its cloth is not drawn).
    pub fn shown(&self) -> Option<&Frame> {
        self.frames.get(self.current.min(self.last()))
    }

    /// Frame `index`, if stored.
    pub fn frame(&self, index: usize) -> Option<&Frame> {
        self.frames.get(index)
    }

    /// The newest frame, if any.
    pub fn newest(&self) -> Option<&Frame> {
        self.frames.last()
    }

    /// Time of frame `index`, s.
    pub fn time_of(&self, index: usize) -> f64 {
        index as f64 / self.fps
    }

    /// Moves the playhead to `index` (clamped to [`Self::end`]).
    pub fn seek(&mut self, index: usize) {
        self.current = index.min(self.end());
        self.phase = 0.0;
    }

    /// One frame forward (or back with `-1`), wrapping when looping.
    pub fn step(&mut self, by: isize) {
        let count = self.end() as isize + 1;
        let next = self.current as isize + by;
        self.current = if self.looping { next.rem_euclid(count) } else { next.clamp(0, count - 1) } as usize;
        self.phase = 0.0;
    }

    /// Advances the playhead by `elapsed_s` of real time when playing.
    pub fn tick(&mut self, elapsed_s: f64) {
        if !self.playing || self.end() == 0 {
            return;
        }
        self.phase += elapsed_s.max(0.0) * self.speed * self.fps;
        while self.phase >= 1.0 {
            self.phase -= 1.0;
            if self.current < self.end() {
                self.current += 1;
            } else if self.looping {
                self.current = 0;
            } else {
                self.playing = false;
                self.phase = 0.0;
                return;
            }
        }
    }

    /// Every stored frame, in order.
    pub fn frames(&self) -> &[Frame] {
        &self.frames
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::app::worker::Settings;
    use crate::bake::FrameRecord;
    use crate::sim::snapshot::Snapshot;

    fn frame(k: usize) -> Frame {
        Frame {
            positions: Arc::new(Vec::new()),
            record: FrameRecord { frame: k, ..Default::default() },
            state: Arc::new(Snapshot::default()),
            settings: Arc::new(Settings::default()),
            baked: false,
            contact_force_n: Arc::new(Vec::new()),
        }
    }

    fn filled(count: usize) -> Timeline {
        let mut timeline = Timeline::new(30.0, 100);
        timeline.restart(frame(0));
        for k in 1..count {
            timeline.push(frame(k));
        }
        timeline
    }

    #[test]
    fn the_playhead_follows_new_frames_only_from_the_newest() {
        let mut timeline = filled(5);
        assert_eq!(timeline.current(), 4, "followed every frame");
        timeline.seek(2);
        timeline.push(frame(5));
        assert_eq!(timeline.current(), 2, "a scrubbed playhead stays put");
    }

    #[test]
    fn playback_moves_at_the_frame_rate_times_the_speed_and_loops() {
        let mut timeline = filled(10);
        timeline.seek(0);
        timeline.playing = true;
        timeline.tick(0.1);
        assert_eq!(timeline.current(), 3, "0.1 s at 30 fps");
        timeline.speed = 2.0;
        timeline.tick(0.1);
        assert_eq!(timeline.current(), 9);
        timeline.tick(1.0 / 60.0);
        assert_eq!(timeline.current(), 0, "wrapped after one more frame at 2× speed");
    }

    #[test]
    fn without_looping_playback_stops_on_the_last_frame() {
        let mut timeline = filled(4);
        timeline.seek(0);
        (timeline.looping, timeline.playing) = (false, true);
        timeline.tick(1.0);
        assert_eq!(timeline.current(), 3);
        assert!(!timeline.playing);
        timeline.step(1);
        assert_eq!(timeline.current(), 3, "stepping stops at the end too");
        timeline.step(-5);
        assert_eq!(timeline.current(), 0);
    }

    #[test]
    fn body_only_preview_plays_the_whole_range_past_the_simulated_frames() {
        let mut timeline = filled(3);
        timeline.set_body_only(true);
        timeline.seek(50);
        assert_eq!(timeline.current(), 50);
        assert_eq!(timeline.shown().unwrap().record.frame, 2, "the newest simulated frame");
        timeline.step(60);
        assert_eq!(timeline.current(), 9, "wrapped around the 100-frame range");
        timeline.set_body_only(false);
        assert_eq!(timeline.current(), 2, "back on a simulated frame");
    }

    #[test]
    fn restart_keeps_only_the_first_frame() {
        let mut timeline = filled(6);
        timeline.restart(frame(0));
        assert_eq!((timeline.len(), timeline.current()), (1, 0));
        assert_eq!(timeline.time_of(15), 0.5);
    }
}
