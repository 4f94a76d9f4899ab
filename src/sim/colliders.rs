//! Analytic colliders: exact signed distances (f64) of the primitive shapes the
//! scenes use, their rigid motion, and the first time a moving point comes
//! within a distance of them.
//!
//! Every shape is built from two exact 2D distances (a circle, a convex polygon)
//! by extrusion along local Y or revolution about it, so each signed distance is
//! the true Euclidean distance outside (1-Lipschitz, which the conservative
//! advancement of [`Shape::first_time_within`] relies on) and the depth to the
//! nearest face inside. A moving point's first contact with a plane or a ball
//! is solved in closed form: a cloth resting on one glides along it, where
//! advancement would crawl.

use nalgebra::{Isometry3, Vector2, Vector3};

use super::motion::Placement;

/// Iteration cap of the conservative advancement; a path still approaching at
/// the cap is treated as touching (a grazing contact within the tolerance band).
const ADVANCEMENT_ITERATIONS: usize = 100;

/// A point this close beyond the level asked of [`Shape::first_time_within`]
/// counts as within it, m.
pub const TOUCH_TOLERANCE_M: f64 = 1e-9;

/// Largest turn of a collider, rad, over which a particle's straight world
/// path, seen in the collider's frame, is taken as a straight segment
/// ([`Collider::first_touch`]): 2°, where the chord of the true arc sags
/// inside it by at most `1 − cos 1°` ≈ 1.5·10⁻⁴ of the distance to the axis.
const PIECE_TURN_RAD: f64 = 0.035;

/// A primitive solid in its local frame (axis along local Y, centred on the origin).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// The half-space below the local XZ plane (a ground when unrotated).
    Plane,
    /// A ball of radius `radius` m.
    Sphere {
        /// Radius, m.
        radius: f64,
    },
    /// A box of half extents `half_extents` m.
    Box {
        /// Half extents along local X, Y, Z, m.
        half_extents: Vector3<f64>,
    },
    /// A capped cylinder along Y.
    Cylinder {
        /// Radius, m.
        radius: f64,
        /// Half of the height, m.
        half_height: f64,
    },
    /// A cone along Y: base disc at `-half_height`, apex at `+half_height`.
    Cone {
        /// Base radius, m.
        radius: f64,
        /// Half of the height, m.
        half_height: f64,
    },
    /// An upright prism whose cross-section is an equilateral triangle in XZ with
    /// one corner towards +Z.
    Prism {
        /// Side of the triangle, m.
        side: f64,
        /// Half of the height, m.
        half_height: f64,
    },
}

/// Signed distance of a point to a shape, with the outward unit normal of the
/// nearest surface point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SignedDistance {
    /// Distance to the surface, m; negative inside.
    pub distance: f64,
    /// Unit direction of steepest increase of the distance.
    pub normal: Vector3<f64>,
}

impl Shape {
    /// Exact signed distance and normal at `p` (local frame, metres).
    pub fn signed_distance(&self, p: &Vector3<f64>) -> SignedDistance {
        match *self {
            Shape::Plane => SignedDistance { distance: p.y, normal: Vector3::y() },
            Shape::Sphere { radius } => {
                let r = p.norm();
                let normal = if r > 0.0 { p / r } else { Vector3::y() };
                SignedDistance { distance: r - radius, normal }
            }
            Shape::Box { half_extents: h } => {
                let corners = [(-h.x, -h.z), (h.x, -h.z), (h.x, h.z), (-h.x, h.z)];
                extrude(p, convex_polygon(&Vector2::new(p.x, p.z), &corners.map(v2)), h.y)
            }
            Shape::Cylinder { radius, half_height } => extrude(p, circle(&Vector2::new(p.x, p.z), radius), half_height),
            Shape::Cone { radius, half_height } => {
                let meridian = [(-radius, -half_height), (radius, -half_height), (0.0, half_height)];
                revolve(p, |m| convex_polygon(m, &meridian.map(v2)))
            }
            Shape::Prism { side, half_height } => {
                let circumradius = side / 3f64.sqrt();
                let corner = |deg: f64| {
                    Vector2::new(circumradius * deg.to_radians().sin(), circumradius * deg.to_radians().cos())
                };
                // Clockwise in the compass sense = counter-clockwise in (x, z).
                let corners = [corner(0.0), corner(240.0), corner(120.0)];
                extrude(p, convex_polygon(&Vector2::new(p.x, p.z), &corners), half_height)
            }
        }
    }

    /// Radius of the smallest ball about the local origin that holds the
    /// whole shape, m (infinite for the plane).
    pub fn bounding_radius(&self) -> f64 {
        match *self {
            Shape::Plane => f64::INFINITY,
            Shape::Sphere { radius } => radius,
            Shape::Box { half_extents } => half_extents.norm(),
            Shape::Cylinder { radius, half_height } | Shape::Cone { radius, half_height } => radius.hypot(half_height),
            Shape::Prism { side, half_height } => (side / 3f64.sqrt()).hypot(half_height),
        }
    }

    /// First fraction `t ∈ [0, 1]` of the straight path `from → to` (local frame)
    /// at which the point comes within `level` m of the surface (to within
    /// [`TOUCH_TOLERANCE_M`]), or `None` when it stays farther. A plane or a
    /// ball is solved in closed form; the other shapes by conservative
    /// advancement.
    pub fn first_time_within(&self, from: &Vector3<f64>, to: &Vector3<f64>, level: f64) -> Option<f64> {
        match *self {
            Shape::Plane => first_time_below(from.y, to.y, level),
            Shape::Sphere { radius } => first_time_inside_ball(from, to, radius + level),
            _ => self.advance_within(from, to, level),
        }
    }

    /// [`Self::first_time_within`] by conservative advancement: every step
    /// moves by the current distance, so no crossing is skipped; a path
    /// still approaching after [`ADVANCEMENT_ITERATIONS`] is treated as
    /// touching (a grazing contact within the tolerance band).
    fn advance_within(&self, from: &Vector3<f64>, to: &Vector3<f64>, level: f64) -> Option<f64> {
        let path = to - from;
        let length = path.norm();
        let mut t = 0.0;
        for _ in 0..ADVANCEMENT_ITERATIONS {
            let gap = self.signed_distance(&(from + path * t)).distance - level;
            if gap <= TOUCH_TOLERANCE_M {
                return Some(t);
            }
            if length == 0.0 {
                return None;
            }
            t += gap / length;
            if t > 1.0 {
                return None;
            }
        }
        Some(t)
    }
}

/// First `t ∈ [0, 1]` at which the height `from + t (to − from)` reaches
/// `level` m, or comes within [`TOUCH_TOLERANCE_M`] above it (then the
/// step's end, where it is lowest).
fn first_time_below(from: f64, to: f64, level: f64) -> Option<f64> {
    let reach = level + TOUCH_TOLERANCE_M;
    if from <= reach {
        return Some(0.0);
    }
    (to <= reach).then(|| ((from - level) / (from - to)).min(1.0))
}

/// First `t ∈ [0, 1]` at which the point `from + t (to − from)` comes within
/// `level` m of the origin (the smaller root of `|f + t d|² = level²`, in the
/// form that does not cancel), or within [`TOUCH_TOLERANCE_M`] more (then
/// its closest approach).
fn first_time_inside_ball(from: &Vector3<f64>, to: &Vector3<f64>, level: f64) -> Option<f64> {
    let (reach, start) = (level + TOUCH_TOLERANCE_M, from.norm_squared());
    if start <= reach * reach {
        return Some(0.0);
    }
    let path = to - from;
    let (a, b) = (path.norm_squared(), from.dot(&path));
    if b >= 0.0 {
        return None;
    }
    let excess = start - level * level;
    let discriminant = b * b - a * excess;
    if discriminant >= 0.0 {
        let t = excess / (-b + discriminant.sqrt());
        if t <= 1.0 {
            return Some(t);
        }
    }
    let closest = (-b / a).min(1.0);
    ((from + path * closest).norm_squared() <= reach * reach).then_some(closest)
}

fn v2((x, y): (f64, f64)) -> Vector2<f64> {
    Vector2::new(x, y)
}

/// Signed distance to a circle of radius `radius` centred on the origin.
fn circle(p: &Vector2<f64>, radius: f64) -> (f64, Vector2<f64>) {
    let r = p.norm();
    let normal = if r > 0.0 { p / r } else { Vector2::x() };
    (r - radius, normal)
}

/// Exact signed distance to a convex polygon with counter-clockwise `corners`.
fn convex_polygon(p: &Vector2<f64>, corners: &[Vector2<f64>]) -> (f64, Vector2<f64>) {
    let mut nearest = (f64::INFINITY, Vector2::x());
    let mut deepest = (f64::NEG_INFINITY, Vector2::x());
    for (i, a) in corners.iter().enumerate() {
        let edge = corners[(i + 1) % corners.len()] - a;
        let outward = Vector2::new(edge.y, -edge.x).normalize();
        let side = (p - a).dot(&outward);
        if side > deepest.0 {
            deepest = (side, outward);
        }
        let along = ((p - a).dot(&edge) / edge.norm_squared()).clamp(0.0, 1.0);
        let offset = p - (a + edge * along);
        let distance = offset.norm();
        if distance < nearest.0 {
            nearest = (distance, if distance > 0.0 { offset / distance } else { outward });
        }
    }
    if deepest.0 <= 0.0 { deepest } else { nearest }
}

/// Extrudes a 2D signed distance in (x, z) along local Y over `±half_height`.
fn extrude(p: &Vector3<f64>, (d2, n2): (f64, Vector2<f64>), half_height: f64) -> SignedDistance {
    let across = Vector3::new(n2.x, 0.0, n2.y);
    let up = Vector3::y() * p.y.signum();
    let dy = p.y.abs() - half_height;
    if d2 <= 0.0 && dy <= 0.0 {
        let (distance, normal) = if d2 > dy { (d2, across) } else { (dy, up) };
        return SignedDistance { distance, normal };
    }
    let (a, b) = (d2.max(0.0), dy.max(0.0));
    let distance = a.hypot(b);
    SignedDistance { distance, normal: (across * a + up * b) / distance }
}

/// Revolves a 2D signed distance of the meridian plane (r, y) about local Y. The
/// 2D shape must be symmetric about r = 0.
fn revolve(p: &Vector3<f64>, meridian: impl Fn(&Vector2<f64>) -> (f64, Vector2<f64>)) -> SignedDistance {
    let r = p.x.hypot(p.z);
    let radial = if r > 0.0 { Vector3::new(p.x / r, 0.0, p.z / r) } else { Vector3::x() };
    let (distance, n) = meridian(&Vector2::new(r, p.y));
    SignedDistance { distance, normal: radial * n.x + Vector3::y() * n.y }
}

/// Where a particle's path first comes within a level of a collider's surface
/// ([`Collider::first_touch`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Touch {
    /// Fraction of the step at the touch, in `[0, 1]`.
    pub t: f64,
    /// The particle there, in the collider's frame, m.
    pub local: Vector3<f64>,
    /// The particle's motion relative to the collider around the touch, in
    /// the collider's frame, m per step.
    pub approach: Vector3<f64>,
}

/// A collider: a shape, where it is at time 0, and how it moves.
#[derive(Clone, Debug, PartialEq)]
pub struct Collider {
    /// Name from the scene file, for reports.
    pub name: String,
    /// The solid, in its local frame.
    pub shape: Shape,
    /// Where it is and how it moves.
    pub placement: Placement,
    /// Friction coefficient overriding the fabric's, unitless.
    pub friction: Option<f64>,
}

impl Collider {
    /// `world_from_local` at time `t` s.
    pub fn world_from_local(&self, t: f64) -> Isometry3<f64> {
        self.placement.world_from_local(t)
    }

    /// Velocity of the collider's surface at world point `p` at time `t`, m/s.
    pub fn surface_velocity(&self, p: &Vector3<f64>, t: f64) -> Vector3<f64> {
        self.placement.velocity_at(p, t)
    }

    /// Whether the straight path `start → end` (world, m) may come within
    /// `reach` m of the collider over a step: false only for a collider that
    /// does not move, whose bounding ball the whole path stays farther from.
    pub fn may_come_within(&self, start: &Vector3<f64>, end: &Vector3<f64>, reach: f64) -> bool {
        let radius = self.shape.bounding_radius();
        if self.placement.motion.is_some() || !radius.is_finite() {
            return true;
        }
        let centre = self.placement.rest_pose.translation.vector;
        let path = end - start;
        let along = path.norm_squared();
        let t = if along > 0.0 { ((centre - start).dot(&path) / along).clamp(0.0, 1.0) } else { 0.0 };
        (start + path * t - centre).norm() <= radius + reach
    }

    /// Where the straight world path `start → end` over the times `t0 → t1` (s)
    /// first comes within `level` m of the surface, or `None`. In the
    /// collider's frame the path is straight only while the collider does
    /// not turn: a turning one (a spinning sphere under resting cloth) is
    /// followed in pieces over which it turns by at most [`PIECE_TURN_RAD`],
    /// as the chord of the whole turn would cut into the surface under a
    /// particle that stays where it is.
    pub fn first_touch(
        &self,
        start: &Vector3<f64>,
        end: &Vector3<f64>,
        (t0, t1): (f64, f64),
        level: f64,
    ) -> Option<Touch> {
        let turn = self.world_from_local(t0).rotation.angle_to(&self.world_from_local(t1).rotation);
        let pieces = (turn / PIECE_TURN_RAD).ceil().max(1.0) as u32;
        let local_at = |k: u32| {
            let (s, t) = if k == pieces {
                (1.0, t1)
            } else {
                let s = f64::from(k) / f64::from(pieces);
                (s, t0 + s * (t1 - t0))
            };
            self.world_from_local(t).inverse_transform_point(&(start + (end - start) * s).into()).coords
        };
        let mut from = local_at(0);
        for k in 0..pieces {
            let to = local_at(k + 1);
            if let Some(s) = self.shape.first_time_within(&from, &to, level) {
                let t = (f64::from(k) + s) / f64::from(pieces);
                return Some(Touch { t, local: from + (to - from) * s, approach: (to - from) * f64::from(pieces) });
            }
            from = to;
        }
        None
    }

    /// Signed distance of world point `p` at time `t`, m (negative inside).
    pub fn signed_distance_at(&self, p: &Vector3<f64>, t: f64) -> f64 {
        let local = self.world_from_local(t).inverse_transform_point(&(*p).into());
        self.shape.signed_distance(&local.coords).distance
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::motion::RigidMotion;
    use parry3d::query::PointQuery;
    use proptest::prelude::*;

    fn shapes() -> Vec<(Shape, Box<dyn PointQuery>)> {
        use parry3d::math::Vector as V;
        use parry3d::shape::{Ball, Cone, ConvexPolyhedron, Cuboid, Cylinder};
        let side = 0.2f64;
        let prism = Shape::Prism { side, half_height: 0.5 };
        let rc = (side / 3f64.sqrt()) as f32;
        let mut prism_points = Vec::new();
        for deg in [0.0f32, 120.0, 240.0] {
            let (s, c) = deg.to_radians().sin_cos();
            prism_points.push(V::new(rc * s, -0.5, rc * c));
            prism_points.push(V::new(rc * s, 0.5, rc * c));
        }
        vec![
            (Shape::Sphere { radius: 0.3 }, Box::new(Ball::new(0.3)) as Box<dyn PointQuery>),
            (
                Shape::Box { half_extents: Vector3::new(0.5, 0.025, 0.3) },
                Box::new(Cuboid::new(V::new(0.5, 0.025, 0.3))),
            ),
            (Shape::Cylinder { radius: 0.08, half_height: 0.5 }, Box::new(Cylinder::new(0.5, 0.08))),
            (Shape::Cone { radius: 0.15, half_height: 0.5 }, Box::new(Cone::new(0.5, 0.15))),
            (prism, Box::new(ConvexPolyhedron::from_convex_hull(&prism_points).unwrap())),
        ]
    }

    fn parry_signed_distance(shape: &dyn PointQuery, p: &Vector3<f64>) -> f64 {
        let q = parry3d::math::Vector::new(p.x as f32, p.y as f32, p.z as f32);
        let projection = shape.project_local_point(q, false);
        let d = (q - projection.point).length() as f64;
        if projection.is_inside { -d } else { d }
    }

    proptest! {
        /// Our f64 distances agree with parry3d's (f32) projections everywhere.
        #[test]
        fn signed_distances_match_parry(x in -0.8..0.8f64, y in -0.8..0.8f64, z in -0.8..0.8f64) {
            let p = Vector3::new(x, y, z);
            for (shape, reference) in shapes() {
                let ours = shape.signed_distance(&p).distance;
                let theirs = parry_signed_distance(reference.as_ref(), &p);
                prop_assert!((ours - theirs).abs() < 2e-5, "{shape:?} at {p}: {ours} vs {theirs}");
            }
        }

        /// The closed-form entry times of the plane and the ball are the first
        /// times a dense sampling of the path comes within the level, and a
        /// path that never does has none.
        #[test]
        fn closed_form_entry_times_match_a_sampled_path(
            from in prop::array::uniform3(-0.6..0.6f64),
            to in prop::array::uniform3(-0.6..0.6f64),
        ) {
            let (from, to) = (Vector3::from(from), Vector3::from(to));
            let level = 0.01;
            for shape in [Shape::Plane, Shape::Sphere { radius: 0.3 }] {
                let gap = |t: f64| shape.signed_distance(&(from + (to - from) * t)).distance - level;
                let samples = 20_000;
                let first_sampled = (0..=samples).map(|k| f64::from(k) / f64::from(samples)).find(|&t| gap(t) <= 0.0);
                match (shape.first_time_within(&from, &to, level), first_sampled) {
                    (Some(t), Some(sampled)) => {
                        prop_assert!(t <= sampled + 1e-12, "{shape:?}: {t} after the sampled {sampled}");
                        prop_assert!(t >= sampled - 1.0 / f64::from(samples), "{shape:?}: {t} before {sampled}");
                        prop_assert!(gap(t) <= 1e-8, "{shape:?}: gap {} at {t}", gap(t));
                    }
                    (Some(t), None) => prop_assert!(gap(t) <= 1e-8, "{shape:?}: found {t}, gap {}", gap(t)),
                    (None, sampled) => prop_assert!(sampled.is_none(), "{shape:?}: missed {sampled:?}"),
                }
            }
        }

        /// A path the bounding-ball test rules out stays farther than the reach
        /// from the shape all along.
        #[test]
        fn culled_paths_stay_out_of_reach(
            from in prop::array::uniform3(-1.0..1.0f64),
            to in prop::array::uniform3(-1.0..1.0f64),
        ) {
            let (from, to) = (Vector3::from(from), Vector3::from(to));
            let reach = 0.05;
            for shape in shapes().into_iter().map(|(shape, _)| shape) {
                let placement = Placement { rest_pose: Isometry3::translation(0.1, -0.2, 0.05), motion: None };
                let collider = Collider { name: "c".into(), shape, placement, friction: None };
                if !collider.may_come_within(&from, &to, reach) {
                    for k in 0..=200 {
                        let p = from + (to - from) * (f64::from(k) / 200.0);
                        prop_assert!(collider.signed_distance_at(&p, 0.0) > reach, "{:?} at {p}", collider.shape);
                    }
                }
            }
        }

        /// The normal is the gradient of the distance (checked by finite differences
        /// away from edges, where the gradient exists).
        #[test]
        fn normals_are_distance_gradients(x in -0.8..0.8f64, y in -0.8..0.8f64, z in -0.8..0.8f64) {
            let p = Vector3::new(x, y, z);
            for (shape, _) in shapes() {
                let h = 1e-7;
                let f = |q: Vector3<f64>| shape.signed_distance(&q).distance;
                let grad = Vector3::new(
                    f(p + Vector3::x() * h) - f(p - Vector3::x() * h),
                    f(p + Vector3::y() * h) - f(p - Vector3::y() * h),
                    f(p + Vector3::z() * h) - f(p - Vector3::z() * h),
                ) / (2.0 * h);
                if (grad.norm() - 1.0).abs() < 1e-4 {
                    let n = shape.signed_distance(&p).normal;
                    prop_assert!((grad - n).norm() < 1e-3, "{shape:?} at {p}: {grad} vs {n}");
                }
            }
        }
    }

    /// Points just outside each shape's bounding ball, spread over it, are
    /// outside the shape.
    #[test]
    fn every_shape_lies_in_its_bounding_ball() {
        for (shape, _) in shapes() {
            let radius = shape.bounding_radius();
            for k in 0..2000 {
                let (height, turn) = (1.0 - (f64::from(k) + 0.5) / 1000.0, f64::from(k) * 2.399_963);
                let ring = (1.0 - height * height).sqrt();
                let direction = Vector3::new(ring * turn.cos(), height, ring * turn.sin());
                let distance = shape.signed_distance(&(direction * radius * 1.000_001)).distance;
                assert!(distance > 0.0, "{shape:?} reaches past {radius} towards {direction}");
            }
        }
    }

    #[test]
    fn plane_distance_is_height() {
        let d = Shape::Plane.signed_distance(&Vector3::new(3.0, -0.2, 1.0));
        assert_eq!(d, SignedDistance { distance: -0.2, normal: Vector3::y() });
    }

    #[test]
    fn advancement_finds_the_entry_time_of_a_thin_blade() {
        // A point crossing a 2 cm blade in one step is caught at its near face.
        let blade = Shape::Box { half_extents: Vector3::new(0.01, 0.5, 0.15) };
        let (from, to) = (Vector3::new(-0.05, 0.0, 0.0), Vector3::new(0.05, 0.0, 0.0));
        let t = blade.first_time_within(&from, &to, 0.002).unwrap();
        assert!((t - 0.38).abs() < 1e-6, "{t}");
        assert_eq!(blade.first_time_within(&from, &Vector3::new(-0.02, 0.0, 0.0), 0.002), None);
    }

    /// A point gliding along a plane or a ball a hair above the level does
    /// not touch it; one a hair below does from the start.
    #[test]
    fn a_gliding_point_touches_only_within_the_level() {
        let glide = |height: f64| (Vector3::new(-0.1, height, 0.0), Vector3::new(0.1, height, 0.0));
        let (from, to) = glide(0.002 + 1e-7);
        assert_eq!(Shape::Plane.first_time_within(&from, &to, 0.002), None);
        let (from, to) = glide(0.002 - 1e-7);
        assert_eq!(Shape::Plane.first_time_within(&from, &to, 0.002), Some(0.0));
        let ball = Shape::Sphere { radius: 0.3 };
        let tangent = Vector3::new(0.05, 0.0, 0.0);
        let top = Vector3::new(0.0, 0.3 + 0.002 + 1e-7, 0.0);
        assert_eq!(ball.first_time_within(&top, &(top + tangent), 0.002), None);
    }

    #[test]
    fn advancement_reports_contact_at_the_start_when_already_within() {
        let ball = Shape::Sphere { radius: 0.3 };
        let inside = Vector3::new(0.0, 0.301, 0.0);
        assert_eq!(ball.first_time_within(&inside, &Vector3::new(0.0, 0.5, 0.0), 0.002), Some(0.0));
    }

    /// A ball turning 24° in a step under a point that stays where it is,
    /// 1 mm outside the level: the chord of the whole turn would cut 6.6 mm
    /// into the ball; followed in pieces, the point never touches. A point
    /// that does come in is caught where its world path crosses the level.
    #[test]
    fn a_turning_collider_is_followed_along_the_world_path() {
        let spin = RigidMotion::from_spec(
            &crate::sim::motion::MotionSpec { angular_velocity_deg_per_s: [0.0, 1440.0, 0.0], ..Default::default() },
            Vector3::zeros(),
        );
        let ball = Collider {
            name: "ball".into(),
            shape: Shape::Sphere { radius: 0.3 },
            placement: Placement { rest_pose: Isometry3::identity(), motion: Some(spin) },
            friction: None,
        };
        let window = (0.0, 1.0 / 60.0);
        let still = Vector3::new(0.303, 0.0, 0.0);
        let (from, to) = (still, ball.world_from_local(window.1).inverse_transform_point(&still.into()).coords);
        assert!(ball.shape.first_time_within(&from, &to, 0.002).is_some(), "the chord cuts in");
        assert_eq!(ball.first_touch(&still, &still, window, 0.002), None);
        let inward = Vector3::new(0.299, 0.0, 0.0);
        let touch = ball.first_touch(&still, &inward, window, 0.002).expect("comes within the level");
        assert!((touch.t - 0.25).abs() < 1e-3, "{touch:?}");
        assert!((touch.local.norm() - 0.302).abs() < 1e-6, "{touch:?}");
        assert!(touch.approach.x < 0.0 && touch.approach.z.abs() > 0.1, "inward while the ball turns: {touch:?}");
    }

    #[test]
    fn moving_collider_distance_follows_its_motion() {
        let motion = RigidMotion::from_spec(
            &crate::sim::motion::MotionSpec { velocity_m_per_s: [0.0, 0.0, -8.0], ..Default::default() },
            Vector3::zeros(),
        );
        let ball = Collider {
            name: "projectile".into(),
            shape: Shape::Sphere { radius: 0.1 },
            placement: Placement { rest_pose: Isometry3::translation(0.0, 0.0, 1.0), motion: Some(motion) },
            friction: None,
        };
        assert!((ball.signed_distance_at(&Vector3::zeros(), 0.125) + 0.1).abs() < 1e-12);
        assert_eq!(ball.surface_velocity(&Vector3::zeros(), 0.1), Vector3::new(0.0, 0.0, -8.0));
    }
}
