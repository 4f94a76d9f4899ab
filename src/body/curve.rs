//! Animation curves: keys at times with constant, linear or cubic (Hermite)
//! interpolation, as FBX stores them.

/// How the value goes from one key to the next.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Interpolation {
    /// Holds the key's value until the next key.
    Constant,
    /// Straight line to the next key.
    Linear,
    /// Cubic Hermite with the given slopes (per second) leaving this key and
    /// arriving at the next.
    Cubic {
        /// Slope leaving this key, units per second.
        right_slope: f64,
        /// Slope arriving at the next key, units per second.
        next_left_slope: f64,
    },
}

/// One animated value.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Curve {
    /// Key times, s, increasing.
    pub times_s: Vec<f64>,
    /// Key values.
    pub values: Vec<f64>,
    /// Per key, how to reach the next one.
    pub interpolation: Vec<Interpolation>,
}

impl Curve {
    /// The value at `t_s`, held constant before the first and after the last key;
    /// `None` for a curve without keys.
    pub fn value_at(&self, t_s: f64) -> Option<f64> {
        let (first, last) = (*self.times_s.first()?, *self.times_s.last()?);
        let n = self.values.len().min(self.times_s.len());
        if t_s <= first || n == 1 {
            return self.values.first().copied();
        }
        if t_s >= last {
            return self.values.get(n - 1).copied();
        }
        // The key at or before t: times are increasing.
        let i = self.times_s[..n].partition_point(|&k| k <= t_s).saturating_sub(1).min(n - 2);
        let (t0, t1, v0, v1) = (self.times_s[i], self.times_s[i + 1], self.values[i], self.values[i + 1]);
        let span = t1 - t0;
        if span <= 0.0 {
            return Some(v1);
        }
        let s = (t_s - t0) / span;
        Some(match self.interpolation.get(i).copied().unwrap_or(Interpolation::Linear) {
            Interpolation::Constant => v0,
            Interpolation::Linear => v0 + s * (v1 - v0),
            Interpolation::Cubic { right_slope, next_left_slope } => {
                let (s2, s3) = (s * s, s * s * s);
                (2.0 * s3 - 3.0 * s2 + 1.0) * v0
                    + (s3 - 2.0 * s2 + s) * span * right_slope
                    + (-2.0 * s3 + 3.0 * s2) * v1
                    + (s3 - s2) * span * next_left_slope
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(interpolation: Interpolation) -> Curve {
        Curve { times_s: vec![0.0, 1.0, 2.0], values: vec![0.0, 10.0, 0.0], interpolation: vec![interpolation; 3] }
    }

    #[test]
    fn keys_are_hit_and_ends_are_held() {
        for i in [Interpolation::Constant, Interpolation::Linear] {
            let c = curve(i);
            assert_eq!(c.value_at(1.0), Some(10.0));
            assert_eq!(c.value_at(-5.0), Some(0.0));
            assert_eq!(c.value_at(9.0), Some(0.0));
        }
        assert_eq!(Curve::default().value_at(0.0), None);
    }

    #[test]
    fn constant_holds_linear_interpolates() {
        assert_eq!(curve(Interpolation::Constant).value_at(0.5), Some(0.0));
        assert_eq!(curve(Interpolation::Linear).value_at(0.25), Some(2.5));
    }

    #[test]
    fn cubic_matches_the_polynomial_its_slopes_describe() {
        // v(t) = t³ on [0, 1] has slopes 0 and 3 at the ends.
        let c = Curve {
            times_s: vec![0.0, 1.0],
            values: vec![0.0, 1.0],
            interpolation: vec![Interpolation::Cubic { right_slope: 0.0, next_left_slope: 3.0 }; 2],
        };
        for t in [0.1, 0.5, 0.9] {
            assert!((c.value_at(t).unwrap() - t * t * t).abs() < 1e-12);
        }
    }
}
