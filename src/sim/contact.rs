//! Cloth particles against analytic colliders, after the implicit solve.
//!
//! Each particle's straight path over the step is followed in each collider's
//! own frame (in pieces while the collider turns:
//! [`Collider::first_touch`]), so a moving or spinning collider is seen
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
//! The particle moves freely up to the contact and with its new velocity after
//! (straight, in world: friction alone decides how far a turning surface drags
//! it), and ends no closer than the thickness to the surface.
//!
//! A particle that ends a step resting on a collider starts the next step
//! constrained to it ([`SurfaceContact`]): its velocity along the normal is
//! prescribed, so the rest of the cloth feels the support within the same
//! implicit solve. Its friction is part of that solve too
//! ([`SurfaceContact::friction_damping`]): a tangential damping whose
//! coefficient μN/|v_T| makes the friction force μN while the particle slides
//! and holds it (static friction) as it stops. Friction applied as a velocity
//! correction after the solve would fight the stiff springs around the particle
//! and blow up.

use nalgebra::{Matrix3, Point3, Vector3};

use super::colliders::Collider;
use super::constraint::Constraint;

/// One step's timing, for contact processing.
#[derive(Clone, Copy, Debug, PartialEq)]
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

/// A particle counts as resting on a collider when it ends a step within the
/// thickness plus this fraction of it.
const RESTING_SLACK: f64 = 0.1;

/// A particle's contact properties.
#[derive(Clone, Copy, Debug)]
pub struct ParticleSurface {
    /// Distance to keep from colliders, m.
    pub thickness: f64,
    /// Friction coefficient used when the collider names none, unitless.
    pub friction: f64,
}

impl ParticleSurface {
    /// The distance from a collider within which a particle ends a step
    /// resting on it: the thickness plus [`RESTING_SLACK`] of it, m.
    fn resting_band(&self) -> f64 {
        self.thickness * (1.0 + RESTING_SLACK)
    }
}

/// What the analytic colliders did to one particle over a step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleContacts {
    /// Colliders it came within its thickness of.
    pub touches: u32,
    /// The last collider it ends the step resting on.
    pub resting_on: Option<u32>,
    /// The sum of the outward unit normals of the colliders it touched (zero
    /// when none did): the direction they pushed it off along.
    pub pushed_along: Vector3<f64>,
}

/// Resolves one particle against every collider in order. `start` is the
/// position at the start of the step; `end` and `velocity` are the solver's
/// candidates and are corrected in place.
pub fn resolve_particle(
    start: &Vector3<f64>,
    end: &mut Vector3<f64>,
    velocity: &mut Vector3<f64>,
    surface: ParticleSurface,
    colliders: &[Collider],
    window: StepWindow,
) -> ParticleContacts {
    let mut contacts = ParticleContacts { touches: 0, resting_on: None, pushed_along: Vector3::zeros() };
    for (c, collider) in colliders.iter().enumerate() {
        if !collider.may_come_within(start, end, surface.resting_band()) {
            continue;
        }
        let outcome = resolve_against(start, end, velocity, surface, collider, window);
        if let Some(normal) = outcome.touched {
            contacts.touches += 1;
            contacts.pushed_along += normal;
        }
        if outcome.resting {
            contacts.resting_on = Some(c as u32);
        }
    }
    contacts
}

/// Coulomb friction (eq. 15): the tangential relative velocity after a normal
/// velocity change of `normal_change` m/s, with coefficient `mu`.
pub fn coulomb_friction(tangential: Vector3<f64>, normal_change: f64, mu: f64) -> Vector3<f64> {
    let speed = tangential.norm();
    if speed == 0.0 {
        return tangential;
    }
    tangential * (1.0 - mu * normal_change / speed).max(0.0)
}

/// What a collider did to a particle over a step.
struct Outcome {
    /// The particle came within its thickness during the step: the
    /// surface's outward unit normal at the touch.
    touched: Option<Vector3<f64>>,
    /// It ends within the resting band ([`ParticleSurface::resting_band`]): it starts the
    /// next step held on the surface (and is let go there if the surface
    /// would have to pull it).
    resting: bool,
}

/// Resolves one particle against one collider.
fn resolve_against(
    start: &Vector3<f64>,
    end: &mut Vector3<f64>,
    velocity: &mut Vector3<f64>,
    surface: ParticleSurface,
    collider: &Collider,
    window: StepWindow,
) -> Outcome {
    let band = surface.resting_band();
    let pose_end = collider.world_from_local(window.t1);
    let Some(touch) = collider.first_touch(start, end, (window.t0, window.t1), surface.thickness) else {
        let to = pose_end.inverse_transform_point(&(*end).into()).coords;
        let resting = collider.shape.signed_distance(&to).distance <= band;
        return Outcome { touched: None, resting };
    };
    // Normal and surface velocity where and when the particle touches.
    let touch_time = window.t0 + touch.t * window.h();
    let pose_touch = collider.world_from_local(touch_time);
    let normal = pose_touch.rotation * collider.shape.signed_distance(&touch.local).normal;
    let touch_world = (pose_touch * Point3::from(touch.local)).coords;
    let surface_velocity = collider.surface_velocity(&touch_world, touch_time);
    let relative = *velocity - surface_velocity;
    let approach = relative.dot(&normal);
    let mut world_end = *end;
    if approach < 0.0 {
        let mu = collider.friction.unwrap_or(surface.friction);
        *velocity = surface_velocity + coulomb_friction(relative - normal * approach, -approach, mu);
        // After the touch the particle moves on with its new velocity.
        world_end = touch_world + *velocity * ((1.0 - touch.t) * window.h());
    }
    let mut local_end = pose_end.inverse_transform_point(&world_end.into()).coords;
    let depth = collider.shape.signed_distance(&local_end);
    if depth.distance < surface.thickness {
        local_end += depth.normal * (surface.thickness - depth.distance);
    }
    *end = (pose_end * Point3::from(local_end)).coords;
    Outcome { touched: Some(normal), resting: depth.distance <= band }
}

/// A particle held to a collider's surface in the solve: its velocity along
/// the normal is prescribed, the rest is free.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceContact {
    /// Index of the collider.
    pub collider: u32,
    /// Outward unit normal of the surface at the particle.
    pub normal: Vector3<f64>,
    /// Velocity of the surface there, m/s.
    pub surface_velocity: Vector3<f64>,
    /// Prescribed velocity along the normal relative to the surface, m/s
    /// (0 for a resting particle, negative for one arriving during the step).
    pub normal_speed: f64,
}

/// Below this sliding speed (m/s) friction damping stops growing: the particle
/// is held by static friction, creeping at most this fast under a load within
/// the friction cone.
pub const STICKING_SPEED: f64 = 1e-3;

impl SurfaceContact {
    /// The contact of a particle at `position` resting on collider `index` at
    /// the start of `window`.
    pub fn resting(position: &Vector3<f64>, colliders: &[Collider], index: u32, window: StepWindow) -> Self {
        let collider = &colliders[index as usize];
        let pose = collider.world_from_local(window.t0);
        let local = pose.inverse_transform_point(&(*position).into()).coords;
        SurfaceContact {
            collider: index,
            normal: pose.rotation * collider.shape.signed_distance(&local).normal,
            surface_velocity: collider.surface_velocity(position, window.t0),
            normal_speed: 0.0,
        }
    }

    /// The first collider that the straight path `start → end` over the step
    /// brings within `thickness` while approaching it, as a contact that keeps
    /// the part of the approach before the touch: the particle arrives at the
    /// thickness at the end of the step and slides along the surface.
    pub fn predicted(
        start: &Vector3<f64>,
        end: &Vector3<f64>,
        thickness: f64,
        colliders: &[Collider],
        window: StepWindow,
    ) -> Option<Self> {
        colliders.iter().enumerate().find_map(|(index, collider)| {
            if !collider.may_come_within(start, end, thickness) {
                return None;
            }
            let touch = collider.first_touch(start, end, (window.t0, window.t1), thickness)?;
            let local_normal = collider.shape.signed_distance(&touch.local).normal;
            let approach = touch.approach.dot(&local_normal);
            if approach >= 0.0 {
                return None;
            }
            let pose_touch = collider.world_from_local(window.t0 + touch.t * window.h());
            Some(SurfaceContact {
                collider: index as u32,
                normal: pose_touch.rotation * local_normal,
                surface_velocity: collider.surface_velocity(start, window.t0),
                normal_speed: touch.t * approach / window.h(),
            })
        })
    }

    /// The constraint this contact puts on the solve.
    pub fn constraint(&self) -> Constraint {
        Constraint::Normal(self.normal)
    }

    /// The velocity change `dv` of a particle with velocity `v`, with its
    /// normal part replaced by the prescribed one.
    pub fn prescribe(&self, v: &Vector3<f64>, dv: &Vector3<f64>) -> Vector3<f64> {
        let target = self.normal.dot(&self.surface_velocity) + self.normal_speed;
        dv - self.normal * self.normal.dot(dv) + self.normal * (target - self.normal.dot(v))
    }

    /// Coulomb friction as a tangential damping of the relative velocity, for
    /// a normal force `normal_force` (N), coefficient `mu` and current velocity
    /// `v`: returns the damping matrix `c (I − n nᵀ)` (N·s/m) with
    /// `c = μ N / max(|v_T|, STICKING_SPEED)`, and the force it exerts now, N.
    pub fn friction_damping(&self, v: &Vector3<f64>, normal_force: f64, mu: f64) -> (Matrix3<f64>, Vector3<f64>) {
        let tangent_plane = Matrix3::identity() - self.normal * self.normal.transpose();
        let sliding = tangent_plane * (v - self.surface_velocity);
        let c = mu * normal_force / sliding.norm().max(STICKING_SPEED);
        (tangent_plane * c, -sliding * c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::colliders::Shape;
    use crate::sim::motion::{MotionSpec, Placement, RigidMotion};
    use nalgebra::Isometry3;

    fn ground() -> Collider {
        Collider {
            name: "ground".into(),
            shape: Shape::Plane,
            placement: Placement { rest_pose: Isometry3::identity(), motion: None },
            friction: None,
        }
    }

    const SURFACE: ParticleSurface = ParticleSurface { thickness: 0.002, friction: 0.5 };
    const WINDOW: StepWindow = StepWindow { t0: 0.0, t1: 0.01 };

    #[test]
    fn falling_particle_stops_on_the_ground_at_the_thickness() {
        let start = Vector3::new(0.0, 0.01, 0.0);
        let mut velocity = Vector3::new(0.0, -3.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        let contacts = resolve_particle(&start, &mut end, &mut velocity, SURFACE, &[ground()], WINDOW);
        assert_eq!((contacts.touches, contacts.resting_on), (1, Some(0)), "touching and resting on the ground");
        assert_eq!(contacts.pushed_along, Vector3::y());
        assert_eq!(velocity, Vector3::zeros(), "inelastic, no tangential motion");
        assert!((end.y - 0.002).abs() < 1e-12, "{end}");
    }

    /// Eq. 15: friction removes μ Δv_N of sliding speed, and stops the particle
    /// when that is more than it has.
    #[test]
    fn coulomb_friction_removes_mu_times_the_normal_velocity_change() {
        let start = Vector3::new(0.0, 0.002, 0.0);
        let mut velocity = Vector3::new(2.0, -1.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        resolve_particle(&start, &mut end, &mut velocity, SURFACE, &[ground()], WINDOW);
        assert!((velocity - Vector3::new(1.5, 0.0, 0.0)).norm() < 1e-12, "{velocity}");
        assert!((end - Vector3::new(0.015, 0.002, 0.0)).norm() < 1e-12, "{end}");

        let mut velocity = Vector3::new(0.3, -1.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        resolve_particle(&start, &mut end, &mut velocity, SURFACE, &[ground()], WINDOW);
        assert_eq!(velocity, Vector3::zeros(), "static friction holds it");
    }

    #[test]
    fn separating_particle_is_left_alone() {
        let start = Vector3::new(0.0, 0.0025, 0.0);
        let mut velocity = Vector3::new(1.0, 2.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        let expected = end;
        let contacts = resolve_particle(&start, &mut end, &mut velocity, SURFACE, &[ground()], WINDOW);
        assert_eq!((end, velocity), (expected, Vector3::new(1.0, 2.0, 0.0)));
        assert_eq!(contacts.resting_on, None, "it leaves the surface");
    }

    /// A particle gliding along the ground a little above its thickness, within
    /// the resting band, is not touched but rests there for the next step;
    /// one ending above the band does not.
    #[test]
    fn a_particle_ending_in_the_resting_band_rests_there_untouched() {
        let start = Vector3::new(0.0, 0.00205, 0.0);
        let mut velocity = Vector3::new(0.5, 0.0, 0.0);
        let mut end = start + velocity * WINDOW.h();
        let glide = resolve_particle(&start, &mut end, &mut velocity, SURFACE, &[ground()], WINDOW);
        assert_eq!((glide.touches, glide.resting_on), (0, Some(0)), "resting on the ground, untouched");
        assert_eq!(velocity, Vector3::new(0.5, 0.0, 0.0));

        let mut velocity = Vector3::new(0.5, 0.03, 0.0);
        let mut end = start + velocity * WINDOW.h();
        let rise = resolve_particle(&start, &mut end, &mut velocity, SURFACE, &[ground()], WINDOW);
        assert_eq!((rise.touches, rise.resting_on), (0, None), "0.25 mm above the band: free");
    }

    /// A sphere moving at 8 m/s meets a resting particle in the middle of the step
    /// and carries it along: the particle ends ahead of the sphere, never inside
    /// or behind it, although the sphere moves more than its radius in the step.
    #[test]
    fn fast_sphere_pushes_a_particle_instead_of_passing_it() {
        let motion = RigidMotion::from_spec(
            &MotionSpec { velocity_m_per_s: [0.0, 0.0, -8.0], ..Default::default() },
            Vector3::zeros(),
        );
        let ball = Collider {
            name: "projectile".into(),
            shape: Shape::Sphere { radius: 0.1 },
            placement: Placement { rest_pose: Isometry3::translation(0.0, 0.0, 0.2), motion: Some(motion) },
            friction: Some(0.0),
        };
        let window = StepWindow { t0: 0.0, t1: 1.0 / 30.0 };
        let start = Vector3::zeros();
        let (mut end, mut velocity) = (start, Vector3::zeros());
        resolve_particle(&start, &mut end, &mut velocity, SURFACE, std::slice::from_ref(&ball), window);
        let centre_end = 0.2 - 8.0 / 30.0;
        assert!((end.z - (centre_end - 0.102)).abs() < 1e-9, "ends at the sphere's front: {end}");
        assert!((velocity - Vector3::new(0.0, 0.0, -8.0)).norm() < 1e-12);
        assert!(ball.signed_distance_at(&end, window.t1) >= 0.002 - 1e-12);
    }

    #[test]
    fn spinning_sphere_drags_a_resting_particle_by_friction() {
        let spin = RigidMotion::from_spec(
            &MotionSpec { angular_velocity_deg_per_s: [0.0, 360.0, 0.0], ..Default::default() },
            Vector3::zeros(),
        );
        let ball = Collider {
            name: "ball".into(),
            shape: Shape::Sphere { radius: 0.3 },
            placement: Placement { rest_pose: Isometry3::identity(), motion: Some(spin) },
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

    /// A sphere that starts spinning at 2 turns/s under a particle resting on
    /// its side pulls it by friction no more than μ times the particle's own
    /// approach: the particle is not carried along with the surface.
    #[test]
    fn a_sphere_spun_abruptly_drags_a_resting_particle_only_by_friction() {
        let spin = RigidMotion::from_spec(
            &MotionSpec { angular_velocity_deg_per_s: [0.0, 720.0, 0.0], ..Default::default() },
            Vector3::zeros(),
        );
        let ball = Collider {
            name: "ball".into(),
            shape: Shape::Sphere { radius: 0.3 },
            placement: Placement { rest_pose: Isometry3::identity(), motion: Some(spin) },
            friction: Some(0.8),
        };
        let window = StepWindow { t0: 0.0, t1: 1.0 / 60.0 };
        let start = Vector3::new(0.3021, 0.0, 0.0);
        let mut velocity = Vector3::new(-0.1, 0.0, 0.0);
        let mut end = start + velocity * window.h();
        let contacts = resolve_particle(&start, &mut end, &mut velocity, SURFACE, &[ball.clone()], window);
        assert_eq!((contacts.touches, contacts.resting_on), (1, Some(0)));
        assert!(velocity.z.abs() <= 0.8 * 0.1 + 1e-5 && velocity.z < -0.07, "dragged by μΔv_N: {velocity}");
        assert!((end - start).norm() < 0.002, "the particle stays near where it was: {end}");
        assert!(ball.signed_distance_at(&end, window.t1) >= 0.002 - 1e-12);
    }

    /// Sliding: the damping force is μN against the sliding direction; nearly
    /// stopped: it grows to hold the particle (static friction).
    #[test]
    fn friction_damping_is_coulomb_while_sliding_and_holds_when_stopped() {
        let contact = SurfaceContact::resting(&Vector3::new(0.0, 0.0025, 0.0), &[ground()], 0, WINDOW);
        assert_eq!(contact.constraint(), Constraint::Normal(Vector3::y()));
        let (damping, force) = contact.friction_damping(&Vector3::new(2.0, -0.5, 0.0), 3.0, 0.5);
        assert!((force - Vector3::new(-1.5, 0.0, 0.0)).norm() < 1e-12, "μN against the slide: {force}");
        assert_eq!(damping * Vector3::y(), Vector3::zeros(), "no damping along the normal");
        let (hold, _) = contact.friction_damping(&Vector3::zeros(), 3.0, 0.5);
        assert!((hold[(0, 0)] - 1.5 / STICKING_SPEED).abs() < 1e-9);
    }

    #[test]
    fn predicted_contact_makes_a_falling_particle_arrive_at_the_thickness() {
        let start = Vector3::new(0.0, 0.0125, 0.0);
        let v = Vector3::new(0.5, -2.0, 0.0);
        let end = start + Vector3::new(0.5, -3.0, 0.0) * WINDOW.h();
        let contact = SurfaceContact::predicted(&start, &end, 0.0025, &[ground()], WINDOW).unwrap();
        let dv = contact.prescribe(&v, &Vector3::new(0.1, -1.0, 0.2));
        let arrival = start + (v + dv) * WINDOW.h();
        assert!((arrival.y - 0.0025).abs() < 1e-8, "{arrival}");
        assert_eq!((dv.x, dv.z), (0.1, 0.2), "tangential part left to the solve");
        let missed = SurfaceContact::predicted(&start, &(start + Vector3::x()), 0.0025, &[ground()], WINDOW);
        assert_eq!(missed, None);
        let resting = Vector3::new(0.0, 0.0025, 0.0);
        let leaving =
            SurfaceContact::predicted(&resting, &(resting + Vector3::y() * 0.01), 0.0025, &[ground()], WINDOW);
        assert_eq!(leaving, None, "a particle moving away is not held");
    }

    /// A particle falling past the side of a sphere, whose path just grazes it,
    /// is not yanked towards the sphere: it keeps the approach it had.
    #[test]
    fn grazing_prediction_keeps_the_particles_own_approach() {
        let ball = Collider {
            name: "ball".into(),
            shape: crate::sim::colliders::Shape::Sphere { radius: 0.3 },
            placement: Placement { rest_pose: Isometry3::identity(), motion: None },
            friction: None,
        };
        let start = Vector3::new(0.3015, 0.05, 0.0);
        let end = Vector3::new(0.3015, -0.05, 0.0);
        let contact = SurfaceContact::predicted(&start, &end, 0.0025, &[ball], WINDOW).unwrap();
        let sideways = contact.normal_speed * contact.normal.x;
        assert!(sideways.abs() < 0.1 * 0.1 / WINDOW.h(), "{contact:?}");
    }
}
