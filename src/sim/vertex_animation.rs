//! A deforming obstacle's motion: every vertex's position sampled at a fixed
//! frame rate (a skinned body baked frame by frame), linear in between, so a
//! step that falls inside a frame sees the body's real motion.

use nalgebra::Vector3;

/// Vertex positions per frame.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexAnimation {
    /// Frames per second of the samples.
    pub fps: f64,
    /// Scene time of the first frame, s.
    pub start_s: f64,
    /// Per frame, every vertex's position in the collider's frame, m.
    pub frames: Vec<Vec<Vector3<f64>>>,
    /// Whether the motion repeats after its last frame (a cycle whose last
    /// frame leads back to its first) instead of holding it.
    pub cycle: bool,
    /// Frames that play once before a cycle (the move from the bind pose
    /// into the motion): the cycle is the frames after them.
    pub lead_in: usize,
}

impl VertexAnimation {
    /// Vertices per frame (0 without frames).
    pub fn vertex_count(&self) -> usize {
        self.frames.first().map_or(0, Vec::len)
    }

    /// The frames around time `t_s` and the fraction of the way from the first
    /// to the second.
    fn bracket(&self, t_s: f64) -> (usize, usize, f64) {
        let n = self.frames.len();
        if n < 2 || self.fps.is_nan() || self.fps <= 0.0 {
            return (0, 0, 0.0);
        }
        let mut f = ((t_s - self.start_s) * self.fps).max(0.0);
        let first = self.lead_in.min(n - 1);
        if self.cycle {
            if f >= first as f64 {
                f = first as f64 + (f - first as f64) % (n - first) as f64;
            }
        } else if f >= (n - 1) as f64 {
            return (n - 1, n - 1, 0.0);
        }
        let i = (f.floor() as usize).min(n - 1);
        let next = if i + 1 < n { i + 1 } else { first };
        (i, next, f - i as f64)
    }

    /// Position of `vertex` at time `t_s`, m (the first frame before the
    /// start; the last after the end unless the motion cycles).
    pub fn position(&self, vertex: usize, t_s: f64) -> Vector3<f64> {
        let (a, b, s) = self.bracket(t_s);
        let at =
            |f: usize| self.frames.get(f).and_then(|frame| frame.get(vertex)).copied().unwrap_or_else(Vector3::zeros);
        if s == 0.0 { at(a) } else { at(a) * (1.0 - s) + at(b) * s }
    }

    /// Every vertex's position at `t_s` into `out`.
    pub fn positions_at(&self, t_s: f64, out: &mut Vec<Vector3<f64>>) {
        out.clear();
        out.extend((0..self.vertex_count()).map(|v| self.position(v, t_s)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sliding(cycle: bool) -> VertexAnimation {
        let frames = (0..3).map(|f| vec![Vector3::new(f as f64, 0.0, 0.0)]).collect();
        VertexAnimation { fps: 10.0, start_s: 1.0, frames, cycle, lead_in: 0 }
    }

    #[test]
    fn positions_interpolate_between_frames_and_hold_at_the_ends() {
        let a = sliding(false);
        assert!((a.position(0, 1.05).x - 0.5).abs() < 1e-12);
        assert_eq!(a.position(0, 0.0).x, 0.0);
        assert_eq!(a.position(0, 9.0).x, 2.0);
        assert!((a.position(0, 1.2).x - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_cycle_wraps_from_the_last_frame_to_the_first() {
        let a = sliding(true);
        assert!((a.position(0, 1.25).x - 1.0).abs() < 1e-12, "half way from frame 2 back to frame 0");
        assert!((a.position(0, 1.3).x - 0.0).abs() < 1e-12);
    }

    #[test]
    fn a_lead_in_plays_once_and_the_cycle_after_it_repeats() {
        let frames = (0..4).map(|f| vec![Vector3::new(f as f64, 0.0, 0.0)]).collect();
        let a = VertexAnimation { fps: 10.0, start_s: 0.0, frames, cycle: true, lead_in: 2 };
        assert!((a.position(0, 0.15).x - 1.5).abs() < 1e-12, "inside the lead-in");
        assert!((a.position(0, 0.35).x - 2.5).abs() < 1e-12, "from the last frame back to the cycle's first");
        assert_eq!(a.position(0, 0.4).x, 2.0);
        assert_eq!(a.position(0, 0.5).x, 3.0);
        assert_eq!(a.position(0, 10.0).x, 2.0, "never back into the lead-in");
    }
}
