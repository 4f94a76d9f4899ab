//! How far a step's positions are from the exact motion's: backward Euler's
//! local error, the measure by which steps lengthen while the cloth is calm
//! ([`super::adaptive`]).
//!
//! Backward Euler ends a step of `h` at `x₁ = x₀ + h v₁` with
//! `v₁ = v₀ + Δv`, where the exact motion reaches `x₀ + h v₀ + ½ h² a`.
//! With `Δv ≈ h a`, the step is off by `½ h Δv` per particle: `h²/2 · g`
//! (1.4 mm at 1/60 s) for cloth in free fall, next to nothing for cloth at
//! rest. The estimate is the root mean square of `½ h |Δv|` over the free
//! particles (pins go where they are told): a few particles kicked by a
//! contact do not hold the whole cloth to short steps, and a cloth that
//! swings or lands as a whole does. The error grows as `h²`, so a step
//! twice as long is expected to be four times as far off.
//!
//! How far off a step may be is measured against what the scene's own
//! nominal step makes of a free fall ([`free_fall_error_m`]): the step a
//! user picks says how accurate they want the motion, and a cloth whose
//! parts accelerate at a fraction of gravity can be stepped longer for the
//! same accuracy.

/// The gravity a free fall is measured with, m/s².
pub const STANDARD_GRAVITY: f64 = 9.81;

/// Backward Euler's position error over one step of `step_s` seconds of a
/// free fall at [`STANDARD_GRAVITY`], `½ g h²`, m.
pub fn free_fall_error_m(step_s: f64) -> f64 {
    0.5 * STANDARD_GRAVITY * step_s * step_s
}

/// The local error estimate of a step.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LocalError {
    /// The step's length, s (0 before any step).
    pub step_s: f64,
    /// Root mean square over the free particles of `½ h |Δv|`, m.
    pub error_m: f64,
}

impl LocalError {
    /// The estimate for a step of `step_s` seconds that took the free
    /// particles (those not `fixed`) from velocities `before` to `after`
    /// (m/s); the sum runs in particle order, so it is the same at any
    /// thread count.
    pub fn of_step(
        step_s: f64,
        before: &[nalgebra::Vector3<f64>],
        after: &[nalgebra::Vector3<f64>],
        fixed: &[bool],
    ) -> Self {
        let (sum, free) = before
            .iter()
            .zip(after)
            .zip(fixed)
            .filter(|(_, fixed)| !**fixed)
            .fold((0.0, 0usize), |(sum, free), ((v0, v1), _)| (sum + (v1 - v0).norm_squared(), free + 1));
        let rms_change = (sum / free.max(1) as f64).sqrt();
        LocalError { step_s, error_m: 0.5 * step_s * rms_change }
    }

    /// The error expected of a step of `step_s` seconds taken now, m: this
    /// one's, scaled by the square of the lengths (none before any step).
    pub fn predicted(&self, step_s: f64) -> f64 {
        if self.step_s > 0.0 { self.error_m * (step_s / self.step_s).powi(2) } else { f64::INFINITY }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// A falling particle: backward Euler's step ends `h² g` below the start
    /// where the exact fall ends `h² g / 2` below: the estimate is the gap.
    #[test]
    fn free_fall_is_off_by_half_g_h_squared() {
        let (h, g) = (1.0 / 60.0, Vector3::new(0.0, -9.81, 0.0));
        let v0 = Vector3::new(0.3, -1.0, 0.0);
        let v1 = v0 + g * h;
        let euler = v1 * h;
        let exact = v0 * h + g * (0.5 * h * h);
        let estimate = LocalError::of_step(h, &[v0], &[v1], &[false]);
        assert!((estimate.error_m - (euler - exact).norm()).abs() < 1e-15, "{estimate:?}");
        assert!((estimate.error_m - 1.3625e-3).abs() < 1e-7, "1.4 mm at 1/60 s");
        assert!((free_fall_error_m(h) - estimate.error_m).abs() < 1e-15);
    }

    #[test]
    fn the_estimate_is_a_root_mean_square_over_the_free_particles() {
        let before = [Vector3::zeros(); 4];
        let after = [Vector3::new(3.0, 0.0, 0.0), Vector3::new(0.0, 4.0, 0.0), Vector3::zeros(), Vector3::x() * 100.0];
        let estimate = LocalError::of_step(0.1, &before, &after, &[false, false, false, true]);
        let rms = ((9.0 + 16.0) / 3.0f64).sqrt();
        assert!((estimate.error_m - 0.05 * rms).abs() < 1e-15, "the pinned particle's 100 m/s left out");
        let none = LocalError::of_step(0.1, &before[..1], &after[..1], &[true]);
        assert_eq!(none.error_m, 0.0, "all pinned: nothing to be off");
    }

    #[test]
    fn a_longer_step_is_expected_off_by_the_square_of_its_length() {
        let estimate = LocalError { step_s: 0.01, error_m: 1e-4 };
        assert!((estimate.predicted(0.02) - 4e-4).abs() < 1e-18);
        assert!((estimate.predicted(0.005) - 2.5e-5).abs() < 1e-18);
        assert_eq!(LocalError::default().predicted(0.01), f64::INFINITY, "nothing known before a step");
    }
}
