//! Animation curves as FBX evaluates them: keys with constant, linear or
//! cubic (Bézier in time and value) segments, and what the curve does
//! before its first and after its last key (extrapolation).

/// FBX time unit: ticks per second (files before FBX 8000).
pub const TICKS_PER_SECOND: f64 = 46_186_158_000.0;

/// How a segment goes from its key to the next one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// Holds this key's value until the next key.
    ConstantPrevious,
    /// Takes the next key's value as soon as the segment starts.
    ConstantNext,
    /// Straight line to the next key.
    Linear,
    /// Cubic Bézier through the keys' tangent handles.
    Cubic,
}

/// A tangent handle: the control point's offset from its key.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Handle {
    /// Time offset, s (positive for both handles: the left one points back).
    pub dt_s: f64,
    /// Value offset (the left handle's is subtracted from the key).
    pub dv: f64,
}

/// One key.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Key {
    /// Time, s.
    pub time_s: f64,
    /// Value at the key.
    pub value: f64,
    /// How the segment after this key is drawn.
    pub interpolation: Interpolation,
    /// Incoming handle (towards the previous key).
    pub left: Handle,
    /// Outgoing handle (towards the next key).
    pub right: Handle,
}

/// What a curve does outside its keys.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExtrapolationMode {
    /// Holds the end key's value.
    #[default]
    Constant,
    /// Repeats the keyed span (a cycle).
    Repeat,
    /// Repeats the keyed span, each cycle offset by its change in value.
    RepeatRelative,
    /// Repeats the keyed span forwards and backwards in turn.
    Mirror,
    /// Goes on along the end key's tangent.
    KeepSlope,
}

/// Extrapolation at one end of a curve.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Extrapolation {
    /// What happens.
    pub mode: ExtrapolationMode,
    /// How many cycles the repeating modes make before holding; `None`: no end.
    pub repetitions: Option<u32>,
}

/// One animated value.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Curve {
    /// Keys in increasing time.
    pub keys: Vec<Key>,
    /// Before the first key.
    pub pre: Extrapolation,
    /// After the last key.
    pub post: Extrapolation,
}

impl Curve {
    /// A curve through `points` (time s, value) with `interpolation`
    /// (cubic segments get flat tangents), held constant outside.
    pub fn through(points: &[(f64, f64)], interpolation: Interpolation) -> Curve {
        let keys = points
            .iter()
            .map(|&(time_s, value)| Key {
                time_s,
                value,
                interpolation,
                left: Handle::default(),
                right: Handle::default(),
            })
            .collect();
        let mut curve = Curve { keys, ..Default::default() };
        curve.set_flat_handles();
        curve
    }

    /// Handles at a third of each segment, flat: cubic segments ease in and out.
    fn set_flat_handles(&mut self) {
        for i in 0..self.keys.len() {
            let before = i.checked_sub(1).map(|p| self.keys[i].time_s - self.keys[p].time_s);
            let after = self.keys.get(i + 1).map(|n| n.time_s - self.keys[i].time_s);
            self.keys[i].left = Handle { dt_s: before.unwrap_or(0.0) / 3.0, dv: 0.0 };
            self.keys[i].right = Handle { dt_s: after.unwrap_or(0.0) / 3.0, dv: 0.0 };
        }
    }

    /// Lowest and highest key value; `None` without keys.
    pub fn value_range(&self) -> Option<(f64, f64)> {
        let first = self.keys.first()?.value;
        Some(self.keys.iter().fold((first, first), |(l, h), k| (l.min(k.value), h.max(k.value))))
    }

    /// The value at `t_s` (the file's timeline, s); `None` for a curve without keys.
    pub fn value_at(&self, t_s: f64) -> Option<f64> {
        let (first, last) = (self.keys.first()?, self.keys.last()?);
        if t_s < first.time_s {
            return Some(self.extrapolate(t_s, self.pre, true));
        }
        if t_s > last.time_s {
            return Some(self.extrapolate(t_s, self.post, false));
        }
        Some(self.inside(t_s))
    }

    /// The value at `t_s` within the keys.
    fn inside(&self, t_s: f64) -> f64 {
        let n = self.keys.len();
        let i = self.keys.partition_point(|k| k.time_s <= t_s).saturating_sub(1).min(n.saturating_sub(1));
        let a = &self.keys[i];
        let Some(b) = self.keys.get(i + 1) else { return a.value };
        let span = b.time_s - a.time_s;
        if t_s <= a.time_s || span <= 0.0 {
            return a.value;
        }
        let u = (t_s - a.time_s) / span;
        match a.interpolation {
            Interpolation::ConstantPrevious => a.value,
            Interpolation::ConstantNext => b.value,
            Interpolation::Linear => a.value + (b.value - a.value) * u,
            Interpolation::Cubic => bezier(a, b, u),
        }
    }

    /// The value outside the keys by `how`, before the first key (`before`) or after the last.
    fn extrapolate(&self, t_s: f64, how: Extrapolation, before: bool) -> f64 {
        let (first, last) = (self.keys[0], self.keys[self.keys.len() - 1]);
        let end = if before { first } else { last };
        match how.mode {
            ExtrapolationMode::Constant => end.value,
            ExtrapolationMode::KeepSlope => {
                let handle = if before { first.right } else { last.left };
                match handle.dt_s > 0.0 {
                    true => end.value + handle.dv * (t_s - end.time_s) / handle.dt_s,
                    false => end.value,
                }
            }
            _ => self.repeat(t_s, how, before),
        }
    }

    /// The repeating modes: the time folded into the keyed span (in whole
    /// ticks, so cycles are frame-exact), plus the relative offset.
    fn repeat(&self, t_s: f64, how: Extrapolation, before: bool) -> f64 {
        let (first, last) = (self.keys[0], self.keys[self.keys.len() - 1]);
        let end = if before { first.value } else { last.value };
        let a = (first.time_s * TICKS_PER_SECOND).round();
        let b = (last.time_s * TICKS_PER_SECOND).round();
        let span = b - a;
        if how.repetitions == Some(0) || span < 1.0 {
            return end;
        }
        let ticks = t_s * TICKS_PER_SECOND;
        let beyond = if before { a - ticks } else { ticks - b };
        let mut cycle = (beyond / span).floor();
        let mut into = beyond - cycle * span;
        if let Some(limit) = how.repetitions
            && cycle >= f64::from(limit)
        {
            cycle = f64::from(limit) - 1.0;
            into = span;
        }
        if how.mode == ExtrapolationMode::Mirror && cycle.rem_euclid(2.0) == 0.0 {
            into = span - into;
        }
        if before {
            into = span - into;
        }
        let value = self.inside((a + into) / TICKS_PER_SECOND);
        match how.mode {
            ExtrapolationMode::RepeatRelative => {
                let step = (cycle + 1.0) * (last.value - first.value);
                if before { value - step } else { value + step }
            }
            _ => value,
        }
    }
}

/// The cubic Bézier segment from `a` to `b` at normalised time `u`: the
/// curve's parameter for that time is found by Newton's method (it is `u`
/// itself when both handles are a third of the segment long).
fn bezier(a: &Key, b: &Key, u: f64) -> f64 {
    let span = b.time_s - a.time_s;
    let x1 = (a.right.dt_s / span).clamp(0.0, 1.0);
    let x2 = (1.0 - b.left.dt_s / span).clamp(0.0, 1.0);
    let x = |s: f64| 3.0 * (1.0 - s) * (1.0 - s) * s * x1 + 3.0 * (1.0 - s) * s * s * x2 + s * s * s;
    let dx = |s: f64| 3.0 * (1.0 - s) * (1.0 - s) * x1 + 6.0 * (1.0 - s) * s * (x2 - x1) + 3.0 * s * s * (1.0 - x2);
    let mut s = u;
    for _ in 0..12 {
        let residual = x(s) - u;
        if residual.abs() <= 1e-15 {
            break;
        }
        let slope = dx(s);
        if slope.abs() < 1e-12 {
            break;
        }
        s = (s - residual / slope).clamp(0.0, 1.0);
    }
    let (p0, p1, p2, p3) = (a.value, a.value + a.right.dv, b.value - b.left.dv, b.value);
    let r = 1.0 - s;
    r * r * r * p0 + 3.0 * r * r * s * p1 + 3.0 * r * s * s * p2 + s * s * s * p3
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(interpolation: Interpolation) -> Curve {
        Curve::through(&[(0.0, 0.0), (1.0, 10.0), (2.0, 0.0)], interpolation)
    }

    #[test]
    fn keys_are_hit_and_ends_are_held() {
        for i in [Interpolation::ConstantPrevious, Interpolation::Linear, Interpolation::Cubic] {
            let c = curve(i);
            assert_eq!(c.value_at(1.0), Some(10.0));
            assert_eq!(c.value_at(-5.0), Some(0.0));
            assert_eq!(c.value_at(9.0), Some(0.0));
        }
        assert_eq!(Curve::default().value_at(0.0), None);
    }

    #[test]
    fn constant_holds_linear_interpolates() {
        assert_eq!(curve(Interpolation::ConstantPrevious).value_at(0.5), Some(0.0));
        assert_eq!(curve(Interpolation::ConstantNext).value_at(0.5), Some(10.0));
        assert_eq!(curve(Interpolation::Linear).value_at(0.25), Some(2.5));
    }

    #[test]
    fn a_cubic_with_third_handles_is_the_hermite_of_its_slopes() {
        // v(t) = t³ on [0, 1]: slopes 0 and 3; handles a third of the span long.
        let mut c = Curve::through(&[(0.0, 0.0), (1.0, 1.0)], Interpolation::Cubic);
        c.keys[1].left = Handle { dt_s: 1.0 / 3.0, dv: 1.0 };
        for t in [0.1, 0.5, 0.9] {
            assert!((c.value_at(t).unwrap() - t * t * t).abs() < 1e-12);
        }
    }

    #[test]
    fn weighted_handles_bend_time_and_still_reach_the_keys() {
        let mut c = Curve::through(&[(0.0, 0.0), (2.0, 4.0)], Interpolation::Cubic);
        c.keys[0].right = Handle { dt_s: 1.6, dv: 0.0 };
        c.keys[1].left = Handle { dt_s: 0.1, dv: 0.0 };
        let mid = c.value_at(1.0).unwrap();
        assert!(mid > 0.0 && mid < 2.0, "a long flat start keeps the value low at mid-time: {mid}");
        assert!((c.value_at(1.999_999).unwrap() - 4.0).abs() < 1e-3);
    }

    fn ramp(pre: ExtrapolationMode, post: ExtrapolationMode, repetitions: Option<u32>) -> Curve {
        let mut c = Curve::through(&[(0.0, 0.0), (1.0, 1.0)], Interpolation::Linear);
        c.pre = Extrapolation { mode: pre, repetitions };
        c.post = Extrapolation { mode: post, repetitions };
        c
    }

    #[test]
    fn extrapolation_repeats_mirrors_offsets_and_keeps_slopes() {
        let near = |a: Option<f64>, b: f64| (a.unwrap() - b).abs() < 1e-9;
        let repeat = ramp(ExtrapolationMode::Repeat, ExtrapolationMode::Repeat, None);
        assert!(near(repeat.value_at(1.25), 0.25) && near(repeat.value_at(-0.25), 0.75));
        let mirror = ramp(ExtrapolationMode::Mirror, ExtrapolationMode::Mirror, None);
        assert!(near(mirror.value_at(1.25), 0.75) && near(mirror.value_at(2.25), 0.25));
        assert!(near(mirror.value_at(-0.25), 0.25));
        let relative = ramp(ExtrapolationMode::RepeatRelative, ExtrapolationMode::RepeatRelative, None);
        assert!(near(relative.value_at(2.5), 2.5) && near(relative.value_at(-0.5), -0.5));
        let mut slope = Curve::through(&[(0.0, 0.0), (1.0, 1.0)], Interpolation::Cubic);
        slope.keys[1].left = Handle { dt_s: 1.0 / 3.0, dv: 1.0 / 3.0 };
        slope.post.mode = ExtrapolationMode::KeepSlope;
        assert!(near(slope.value_at(3.0), 3.0));
    }

    #[test]
    fn counted_repetitions_hold_the_end_of_the_last_cycle() {
        let twice = ramp(ExtrapolationMode::Repeat, ExtrapolationMode::Repeat, Some(2));
        assert!((twice.value_at(1.5).unwrap() - 0.5).abs() < 1e-9);
        assert!((twice.value_at(10.0).unwrap() - 1.0).abs() < 1e-9);
        let never = ramp(ExtrapolationMode::Repeat, ExtrapolationMode::Repeat, Some(0));
        assert_eq!(never.value_at(1.5), Some(1.0));
    }

    #[test]
    fn keys_a_hundred_thousand_seconds_away_are_evaluated_in_one_step() {
        let c = Curve::through(&[(-166_667.0, -5.0), (0.0, 0.0), (166_667.0, 5.0)], Interpolation::Linear);
        assert!((c.value_at(83_333.5).unwrap() - 2.5).abs() < 1e-9);
    }
}
