//! Prescribed rigid motion over time, for kinematic colliders and moving pins:
//! a constant linear velocity plus a constant spin about a pivot, active between
//! a start and an end time.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// A rigid motion as written in scene files.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MotionSpec {
    /// Linear velocity, m/s.
    #[serde(default)]
    pub velocity_m_per_s: [f64; 3],
    /// Angular velocity (axis × rate), degrees per second.
    #[serde(default)]
    pub angular_velocity_deg_per_s: [f64; 3],
    /// Point the spin turns about at the start, m (world space). Defaults to the
    /// object's own centre.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pivot_m: Option<[f64; 3]>,
    /// Time the motion starts, s.
    #[serde(default)]
    pub start_s: f64,
    /// Time the motion stops, s; it never stops when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_s: Option<f64>,
}

/// A rigid motion ready to evaluate: `world_from_rest(t)` maps where a point was
/// at time 0 to where it is at time `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidMotion {
    /// Linear velocity, m/s.
    pub velocity: Vector3<f64>,
    /// Angular velocity, rad/s.
    pub angular_velocity: Vector3<f64>,
    /// Pivot of the spin at time 0, m.
    pub pivot: Vector3<f64>,
    /// Start time, s.
    pub start: f64,
    /// End time, s (may be infinite).
    pub end: f64,
}

impl RigidMotion {
    /// Resolves a file's motion, using `default_pivot` when it names none.
    pub fn from_spec(spec: &MotionSpec, default_pivot: Vector3<f64>) -> Self {
        RigidMotion {
            velocity: Vector3::from(spec.velocity_m_per_s),
            angular_velocity: Vector3::from(spec.angular_velocity_deg_per_s).map(f64::to_radians),
            pivot: spec.pivot_m.map_or(default_pivot, Vector3::from),
            start: spec.start_s,
            end: spec.end_s.unwrap_or(f64::INFINITY),
        }
    }

    /// Time spent moving by time `t`, s.
    fn moving_time(&self, t: f64) -> f64 {
        (t.min(self.end) - self.start).max(0.0)
    }

    /// True while the motion is active at time `t`.
    fn is_moving(&self, t: f64) -> bool {
        t >= self.start && t < self.end
    }

    /// The transform from rest (time 0) to time `t`: spin about the pivot, then
    /// translate.
    pub fn world_from_rest(&self, t: f64) -> Isometry3<f64> {
        let tau = self.moving_time(t);
        let rotation = UnitQuaternion::from_scaled_axis(self.angular_velocity * tau);
        let translation = self.pivot + self.velocity * tau - rotation * self.pivot;
        Isometry3::from_parts(Translation3::from(translation), rotation)
    }

    /// Velocity at time `t` of the material point that is at `point` (world), m/s.
    pub fn velocity_at(&self, point: &Vector3<f64>, t: f64) -> Vector3<f64> {
        if !self.is_moving(t) {
            return Vector3::zeros();
        }
        let pivot_now = self.pivot + self.velocity * self.moving_time(t);
        self.velocity + self.angular_velocity.cross(&(point - pivot_now))
    }
}

/// Where a rigid object is at time 0 and how it moves from there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// `world_from_local` at time 0.
    pub rest_pose: Isometry3<f64>,
    /// Prescribed motion, if kinematic.
    pub motion: Option<RigidMotion>,
}

impl Placement {
    /// `world_from_local` at time `t` s.
    pub fn world_from_local(&self, t: f64) -> Isometry3<f64> {
        match &self.motion {
            Some(m) => m.world_from_rest(t) * self.rest_pose,
            None => self.rest_pose,
        }
    }

    /// Velocity at time `t` of the material point at world point `p`, m/s.
    pub fn velocity_at(&self, p: &Vector3<f64>, t: f64) -> Vector3<f64> {
        self.motion.as_ref().map_or_else(Vector3::zeros, |m| m.velocity_at(p, t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    fn spin_about_y(rev_per_s: f64, start: f64) -> RigidMotion {
        RigidMotion::from_spec(
            &MotionSpec {
                angular_velocity_deg_per_s: [0.0, 360.0 * rev_per_s, 0.0],
                start_s: start,
                ..Default::default()
            },
            Vector3::new(0.0, 0.5, 0.0),
        )
    }

    #[test]
    fn spin_turns_points_about_the_pivot_after_the_start() {
        let motion = spin_about_y(1.0, 1.0);
        let p = Vector3::new(0.3, 0.5, 0.0);
        assert_eq!(motion.world_from_rest(0.9).transform_vector(&p), p);
        let quarter = motion.world_from_rest(1.25) * nalgebra::Point3::from(p);
        assert!((quarter.coords - Vector3::new(0.0, 0.5, -0.3)).norm() < 1e-12);
    }

    #[test]
    fn velocity_is_the_time_derivative_of_the_pose() {
        let motion = RigidMotion::from_spec(
            &MotionSpec {
                velocity_m_per_s: [0.5, 0.0, -8.0],
                angular_velocity_deg_per_s: [30.0, 90.0, 0.0],
                ..Default::default()
            },
            Vector3::new(0.1, 0.2, 0.3),
        );
        let rest = nalgebra::Point3::new(0.4, -0.2, 0.7);
        let (t, h) = (0.8, 1e-6);
        let at = |t: f64| (motion.world_from_rest(t) * rest).coords;
        let numeric = (at(t + h) - at(t - h)) / (2.0 * h);
        let analytic = motion.velocity_at(&at(t), t);
        assert!((numeric - analytic).norm() < 1e-6, "{numeric} vs {analytic}");
    }

    #[test]
    fn motion_stops_at_its_end_time() {
        let mut motion = spin_about_y(0.5, 0.0);
        motion.end = 1.0;
        let at_end = motion.world_from_rest(1.0);
        assert_eq!(motion.world_from_rest(5.0), at_end);
        assert!((at_end.rotation.angle() - PI).abs() < 1e-12);
        assert_eq!(motion.velocity_at(&Vector3::x(), 2.0), Vector3::zeros());
    }
}
