//! Cloth particles against analytic colliders, after the implicit solve.
//!
//! Each particle's straight path over the step is followed in each collider's
//! own frame (the collider's pose at the start of the step for the start point,
//! at the end for the end point), so a moving or spinning collider is seen
//! relative to the cloth and a fast one cannot jump over a particle. At the
//! first time the particle comes within the thickness (normal and surface
//! velocity taken at that moment), its velocity relative to
//! the surface loses its approaching normal part (an inelastic contact) and the
//! tangential part is reduced by Coulomb friction (PAPER eq. 15):
//!
//! ```text
//! v_T = max(1 − μ Δv_N / |v_T_pre|, 0) · v_T_pre
//! ```
//!
//! The particle moves freely up to the contact and with its new velocity after,
//! and ends no closer than the thickness to the surface.

use nalgebra::Vector3;

use super::colliders::Collider;

/// One step's timing, for contact processing.
#[derive(Clone, Copy, Debug)]
pub struct StepWindow {
    /// Start of the step, s.
    pub t0: f64,
    /// End of the step, s.
    pub t1: f64,
}

impl StepWindow {
    /// Duration, s.
    pub fn h(&self) -> f64 {
        self.t1 - self.t0
    }
}

/// A particle's contact properties.
#[derive(Clone, Copy, Debug)]
pub struct ParticleSurface {
    /// Distance to keep from colliders, m.
    pub thickness: f64,
    /// Friction coefficient used when the collider names none, unitless.
    pub friction: f64,
}

/// Resolves one particle against every collider in order. `start` is the
/// position at the start of the step; `end` and `velocity` are the solver's
/// candidates and are corrected in place. Returns the number of contacts.
pub fn resolve_particle(
    start: &Vector3<f64>,
    end: &mut Vector3<f64>,
    velocity: &mut Vector3<f64>,
    surface: ParticleSurface,
    colliders: &[Collider],
    window: StepWindow,
) -> u32 {
    colliders
        .iter()
        .map(|c| resolve_against(start, end, velocity, surface, c, window) as u32)
        .sum()
}

/// Resolves one particle against one collider; true when they touched.
fn resolve_against(
    start: &Vector3<f64>,
    end: &mut Vector3<f64>,
    velocity: &mut Vector3<f64>,
    surface: ParticleSurface,
    collider: &Collider,
    window: StepWindow,
) -> bool {
    let pose_start = collider.world_from_local(window.t0);
    let pose_end = collider.world_from_local(window.t1);
    let from = pose_start.inverse_transform_point(&(*start).into()).coords;
    let to = pose_end.inverse_transform_point(&(*end).into()).coords;
    let Some(t) = collider
        .shape
        .first_time_within(&from, &to, surface.thickness)
    else {
        return false;
    };
    let touch = from + (to - from) * t;
    // Normal and surface velocity where and when the particle touches.
    let touch_time = window.t0 + t * window.h();
    let pose_touch = collider.world_from_local(touch_time);
    let normal = pose_touch.rotation * collider.shape.signed_distance(&touch).normal;
    let touch_world = (pose_touch * nalgebra::Point3::from(touch)).coords;
    let surface_velocity = collider.surface_velocity(&touch_world, touch_time);
    let relative = *velocity - surface_velocity;
    let approach = relative.dot(&normal);
    let mut local_end = to;
    if approach < 0.0 {
        let tangential = relative - normal * approach;
        let speed = tangential.norm();
        let mu = collider.friction.unwrap_or(surface.friction);
        let keep = if speed > 0.0 {
            (1.0 - mu * -approach / speed).max(0.0)
        } else {
            0.0
        };
        *velocity = surface_velocity + tangential * keep;
        // After the touch the particle moves with the surface plus its slide.
        let slide = pose_touch.rotation.inverse() * (*velocity - surface_velocity);
        local_end = touch + slide * ((1.0 - t) * window.h());
    }
    let depth = collider.shape.signed_distance(&local_end);
    if depth.distance < surface.thickness {
        local_end += depth.normal * (surface.thickness - depth.distance);
    }
    *end = (pose_end * nalgebra::Point3::from(local_end)).coords;
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::colliders::Shape;
    use crate::sim::motion::{MotionSpec, RigidMotion};
    use nalgebra::Isometry3;

    fn ground() -> Collider {
        Collider {
            name: "ground".into(),
            shape: Shape::Plane,
            rest_pose: Isometry3::identity(),
            motion: None,
            friction: None,
        }
    }

    const SURFACE: ParticleSurface = ParticleSurface {
        thickness: 0.002,
        friction: 0.5,
    };
    const WINDOW: StepWindow = StepWindow { t0: 0.0, t1: 0.01 };

    #[test]
    fn falling_particle_stops_on_the_ground_at_the_thickness() {
        let start = Vector3::new(0.0, 0.01, 0.0);
        let mut velocity = Vector3::new(0.0, -3.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        let contacts = resolve_particle(
            &start,
            &mut end,
            &mut velocity,
            SURFACE,
            &[ground()],
            WINDOW,
        );
        assert_eq!(contacts, 1);
        assert_eq!(
            velocity,
            Vector3::zeros(),
            "inelastic, no tangential motion"
        );
        assert!((end.y - 0.002).abs() < 1e-12, "{end}");
    }

    /// Eq. 15: friction removes μ Δv_N of sliding speed, and stops the particle
    /// when that is more than it has.
    #[test]
    fn coulomb_friction_removes_mu_times_the_normal_velocity_change() {
        let start = Vector3::new(0.0, 0.002, 0.0);
        let mut velocity = Vector3::new(2.0, -1.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        resolve_particle(
            &start,
            &mut end,
            &mut velocity,
            SURFACE,
            &[ground()],
            WINDOW,
        );
        assert!(
            (velocity - Vector3::new(1.5, 0.0, 0.0)).norm() < 1e-12,
            "{velocity}"
        );
        assert!(
            (end - Vector3::new(0.015, 0.002, 0.0)).norm() < 1e-12,
            "{end}"
        );

        let mut velocity = Vector3::new(0.3, -1.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        resolve_particle(
            &start,
            &mut end,
            &mut velocity,
            SURFACE,
            &[ground()],
            WINDOW,
        );
        assert_eq!(velocity, Vector3::zeros(), "static friction holds it");
    }

    #[test]
    fn separating_particle_is_left_alone() {
        let start = Vector3::new(0.0, 0.0025, 0.0);
        let mut velocity = Vector3::new(1.0, 2.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        let expected = end;
        resolve_particle(
            &start,
            &mut end,
            &mut velocity,
            SURFACE,
            &[ground()],
            WINDOW,
        );
        assert_eq!((end, velocity), (expected, Vector3::new(1.0, 2.0, 0.0)));
    }

    /// A sphere moving at 8 m/s meets a resting particle in the middle of the step
    /// and carries it along: the particle ends ahead of the sphere, never inside
    /// or behind it, although the sphere moves more than its radius in the step.
    #[test]
    fn fast_sphere_pushes_a_particle_instead_of_passing_it() {
        let motion = RigidMotion::from_spec(
            &MotionSpec {
                velocity_m_per_s: [0.0, 0.0, -8.0],
                ..Default::default()
            },
            Vector3::zeros(),
        );
        let ball = Collider {
            name: "projectile".into(),
            shape: Shape::Sphere { radius: 0.1 },
            rest_pose: Isometry3::translation(0.0, 0.0, 0.2),
            motion: Some(motion),
            friction: Some(0.0),
        };
        let window = StepWindow {
            t0: 0.0,
            t1: 1.0 / 30.0,
        };
        let start = Vector3::zeros();
        let (mut end, mut velocity) = (start, Vector3::zeros());
        resolve_particle(
            &start,
            &mut end,
            &mut velocity,
            SURFACE,
            &[ball.clone()],
            window,
        );
        let centre_end = 0.2 - 8.0 / 30.0;
        assert!(
            (end.z - (centre_end - 0.102)).abs() < 1e-9,
            "ends at the sphere's front: {end}"
        );
        assert!((velocity - Vector3::new(0.0, 0.0, -8.0)).norm() < 1e-12);
        assert!(ball.signed_distance_at(&end, window.t1) >= 0.002 - 1e-12);
    }

    #[test]
    fn spinning_sphere_drags_a_resting_particle_by_friction() {
        let spin = RigidMotion::from_spec(
            &MotionSpec {
                angular_velocity_deg_per_s: [0.0, 360.0, 0.0],
                ..Default::default()
            },
            Vector3::zeros(),
        );
        let ball = Collider {
            name: "ball".into(),
            shape: Shape::Sphere { radius: 0.3 },
            rest_pose: Isometry3::identity(),
            motion: Some(spin),
            friction: None,
        };
        // A particle resting on the sphere's equator, pressed in by gravity.
        let start = Vector3::new(0.302, 0.0, 0.0);
        let mut velocity = Vector3::new(-1.0, 0.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        resolve_particle(&start, &mut end, &mut velocity, SURFACE, &[ball], WINDOW);
        // Surface speed there is 2π·0.3 ≈ 1.9 m/s towards −Z; friction gives μ·1 m/s of it.
        assert!((velocity.z + 0.5).abs() < 0.01, "{velocity}");
        assert!(velocity.x.abs() < 0.02, "{velocity}");
    }
}
