//! Collision response: inelastic impulses with friction (PAPER eq. 7-15), and
//! rigid impact zones as the fail-safe.
//!
//! A contact between four points with weights `wᵢ` (see [`Hit`]) and unit
//! normal `n` has the relative normal velocity `v_N = n · Σ wᵢ vᵢ`. The impulse
//! `J n` applied as `Δvᵢ = wᵢ J n / mᵢ` changes it by `J Σ wᵢ²/mᵢ`; with equal
//! masses this is the paper's `Ĩ = 2I / (1 + Σ wᵢ²)` (eq. 7-9 vertex-triangle,
//! eq. 10-14 edge-edge), and with a pinned or obstacle point (`1/m = 0`) the
//! whole change goes to the free points. The target is the normal velocity
//! that leaves the features at the thickness at the end of the step, moving
//! from where they started: `v_N ≥ (δ − d₀) / h`. The tangential relative
//! velocity then loses `μ Δv_N` (eq. 15, Coulomb).
//!
//! A rigid impact zone (Provot 1997, Bridson et al. 2002) is a set of points
//! whose collisions the impulses could not resolve: it moves as one rigid body
//! (its linear and angular momentum kept), so no pair inside it can cross; if
//! it holds a pinned or obstacle point, it follows that point's prescribed
//! motion instead.

use nalgebra::{Matrix3, Vector3};

use super::ccd::Hit;

/// Fraction of the thickness below which a contact's shortfall counts as met.
pub const SATISFIED: f64 = 1e-6;

/// Which elementary pair a contact is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ContactKind {
    /// A vertex (first point) and a triangle (the other three).
    VertexTriangle,
    /// An edge (first two points) and an edge (last two).
    EdgeEdge,
}

/// A contact between four points: cloth particles `0..n`, obstacle vertices
/// from `n` on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Vertex-triangle or edge-edge.
    pub kind: ContactKind,
    /// The four points (vertex, triangle corners) or (edge, edge).
    pub nodes: [u32; 4],
    /// Where, when and how they meet.
    pub hit: Hit,
    /// Distance to keep, m.
    pub thickness: f64,
    /// Friction coefficient, unitless.
    pub friction: f64,
}

impl Contact {
    /// The contact's identity across passes: kind and points, sorted.
    pub fn key(&self) -> [u32; 5] {
        let [a, b, c, d] = self.nodes;
        match self.kind {
            ContactKind::VertexTriangle => {
                let mut tri = [b, c, d];
                tri.sort_unstable();
                [0, a, tri[0], tri[1], tri[2]]
            }
            ContactKind::EdgeEdge => {
                let (e1, e2) = ([a.min(b), a.max(b)], [c.min(d), c.max(d)]);
                let (lo, hi) = if e1 <= e2 { (e1, e2) } else { (e2, e1) };
                [1, lo[0], lo[1], hi[0], hi[1]]
            }
        }
    }

    /// The features' relative velocity, m/s, with the points moving at
    /// `velocity`, m/s.
    fn relative_velocity(&self, velocity: &[Vector3<f64>]) -> Vector3<f64> {
        (0..4).map(|k| velocity[self.nodes[k] as usize] * self.hit.weights[k]).sum()
    }

    /// The relative normal velocity the contact still needs, m/s, with the
    /// points moving at `velocity`, m/s, over a step of `h` s (positive: the
    /// features would end closer than the thickness).
    pub fn deficit(&self, velocity: &[Vector3<f64>], h: f64) -> f64 {
        let target = (self.thickness - self.hit.start_distance) / h;
        target - self.relative_velocity(velocity).dot(&self.hit.normal)
    }

    /// How far short of the thickness the features would end a step of `h`
    /// s with the points moving at `velocity`, m/s: m, zero if they would not.
    pub fn shortfall(&self, velocity: &[Vector3<f64>], h: f64) -> f64 {
        (self.deficit(velocity, h) * h).max(0.0)
    }
}

/// Positions and velocities of every point during collision processing.
pub struct Points<'a> {
    /// Positions at the start of the step, m.
    pub start: &'a [Vector3<f64>],
    /// Positions at the end of the step, m (updated by the response).
    pub end: &'a mut [Vector3<f64>],
    /// Velocities over the step, m/s (updated by the response).
    pub velocity: &'a mut [Vector3<f64>],
    /// Inverse masses, 1/kg; zero for pinned particles and obstacle vertices.
    pub inverse_mass: &'a [f64],
    /// Set for every point whose path the response changes.
    pub moved: &'a mut [bool],
    /// Step, s.
    pub h: f64,
}

impl Points<'_> {
    fn effective_inverse_mass(&self, c: &Contact) -> f64 {
        (0..4).map(|k| c.hit.weights[k] * c.hit.weights[k] * self.inverse_mass[c.nodes[k] as usize]).sum()
    }

    fn push(&mut self, c: &Contact, impulse: Vector3<f64>) {
        for k in 0..4 {
            let i = c.nodes[k] as usize;
            let dv = impulse * (c.hit.weights[k] * self.inverse_mass[i]);
            self.velocity[i] += dv;
            self.end[i] += dv * self.h;
            self.moved[i] |= dv != Vector3::zeros();
        }
    }

    /// Applies contact `c`'s impulse and friction if it needs them; returns
    /// the normal impulse per unit of a point's weight (each point `i` of
    /// the contact receives `|wᵢ|` of it), N·s, if it did. A deficit that
    /// would leave the features short of the thickness by less than
    /// [`SATISFIED`] of it is round-off, not a need.
    pub fn respond(&mut self, c: &Contact) -> Option<f64> {
        let deficit = c.deficit(self.velocity, self.h);
        let k = self.effective_inverse_mass(c);
        if deficit <= SATISFIED * c.thickness / self.h || k == 0.0 {
            return None;
        }
        let n = c.hit.normal;
        let relative = c.relative_velocity(self.velocity);
        let tangential = relative - n * relative.dot(&n);
        let slide = tangential.norm();
        let friction =
            if slide > 0.0 { tangential * ((c.friction * deficit).min(slide) / slide) } else { Vector3::zeros() };
        self.push(c, (n * deficit - friction) / k);
        Some(deficit / k)
    }
}

/// Union-find over points, for impact zones.
#[derive(Clone, Debug, Default)]
pub struct Zones {
    parent: Vec<u32>,
}

impl Zones {
    /// Every point in a zone of its own.
    pub fn reset(&mut self, n: usize) {
        self.parent.clear();
        self.parent.extend(0..n as u32);
    }

    /// The zone of point `i`.
    pub fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let grand = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = grand;
            i = grand;
        }
        i
    }

    /// Joins the zones of `a` and `b` (the smaller index becomes the root, so
    /// the result does not depend on the order of unions).
    pub fn join(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        self.parent[hi as usize] = lo;
    }
}

/// Where a point that starts at the given position (m) must end the step:
/// the prescribed motion a zone held by a kinematic point follows.
pub type PrescribedEnd = dyn Fn(&Vector3<f64>) -> Vector3<f64>;

/// Makes the free points of one zone (`members`) move rigidly, keeping their
/// linear and angular momentum about their centre of mass at the start of
/// the step. `prescribed` maps a start position to where the pinned or
/// obstacle point the zone must follow would carry it by the end of the
/// step, if the zone holds one.
///
/// Either way every point moves along a straight line under one invertible
/// affine map of the start positions (`I + t h Ω` for a free zone, whose
/// `AᵀA ≥ I` never brings two points closer), so no two features of the zone
/// can meet during the step if they were apart at its start.
pub fn rigidify(points: &mut Points, members: impl Iterator<Item = u32> + Clone, prescribed: Option<&PrescribedEnd>) {
    let inverse_mass = points.inverse_mass;
    let free = members.map(|i| i as usize).filter(move |&i| inverse_mass[i] > 0.0);
    if let Some(carry) = prescribed {
        for i in free {
            points.end[i] = carry(&points.start[i]);
            points.velocity[i] = (points.end[i] - points.start[i]) / points.h;
            points.moved[i] = true;
        }
        return;
    }
    let mass = |i: usize| 1.0 / points.inverse_mass[i];
    let total: f64 = free.clone().map(mass).sum();
    if total == 0.0 {
        return;
    }
    let centre = free.clone().map(|i| points.start[i] * mass(i)).sum::<Vector3<f64>>() / total;
    let linear = free.clone().map(|i| points.velocity[i] * mass(i)).sum::<Vector3<f64>>() / total;
    let mut angular = Vector3::zeros();
    let mut inertia = Matrix3::zeros();
    for i in free.clone() {
        let r = points.start[i] - centre;
        angular += r.cross(&points.velocity[i]) * mass(i);
        inertia += (Matrix3::identity() * r.norm_squared() - r * r.transpose()) * mass(i);
    }
    let spin = inertia.try_inverse().map_or_else(Vector3::zeros, |inv| inv * angular);
    for i in free {
        let v = linear + spin.cross(&(points.start[i] - centre));
        points.velocity[i] = v;
        points.end[i] = points.start[i] + v * points.h;
        points.moved[i] = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(weights: [f64; 4], start_distance: f64) -> Hit {
        Hit { time: 0.5, weights, normal: Vector3::y(), start_distance, crossing: true }
    }

    /// Eq. 7-9 with equal masses: the vertex-triangle impulse stops the approach
    /// and splits between the vertex and the triangle's corners by weight.
    #[test]
    fn vertex_triangle_impulse_cancels_the_approach_with_equal_masses() {
        let start = [Vector3::new(0.2, 0.1, 0.2), Vector3::zeros(), Vector3::x(), Vector3::z()];
        let mut end = start;
        let mut velocity = [Vector3::new(0.0, -3.0, 0.0), Vector3::zeros(), Vector3::zeros(), Vector3::zeros()];
        let h = 0.05;
        let mut points = Points {
            start: &start,
            end: &mut end,
            velocity: &mut velocity,
            inverse_mass: &[1.0; 4],
            moved: &mut [false; 4],
            h,
        };
        let weights = [1.0, -0.6, -0.2, -0.2];
        let contact = Contact {
            kind: ContactKind::VertexTriangle,
            nodes: [0, 1, 2, 3],
            hit: hit(weights, 0.1),
            thickness: 0.1,
            friction: 0.0,
        };
        assert!(points.respond(&contact).is_some());
        let v_n: f64 = (0..4).map(|k| points.velocity[k].y * weights[k]).sum();
        assert!(v_n.abs() < 1e-12, "the approach is cancelled: {v_n}");
        // Paper eq. 7: Ĩ = 2I/(1 + Σw²), I = m v_N / 2 → the vertex keeps −Ĩ/m.
        let i_tilde = 3.0 / (1.0 + 0.36 + 0.04 + 0.04);
        assert!((points.velocity[0].y - (-3.0 + i_tilde)).abs() < 1e-12);
        assert!((points.velocity[1].y - (-0.6 * i_tilde)).abs() < 1e-12, "eq. 8");
        let momentum: f64 = points.velocity.iter().map(|v| v.y).sum();
        assert!((momentum + 3.0).abs() < 1e-12, "momentum is conserved");
    }

    #[test]
    fn an_obstacle_takes_no_velocity_and_the_cloth_takes_it_all() {
        let start =
            [Vector3::new(0.0, 0.01, 0.0), Vector3::new(-1.0, 0.0, 0.0), Vector3::new(1.0, 0.0, 0.0), Vector3::zeros()];
        let mut velocity = [Vector3::new(1.0, -2.0, 0.0), Vector3::zeros(), Vector3::zeros(), Vector3::zeros()];
        let mut end: Vec<_> = start.iter().zip(&velocity).map(|(x, v)| x + v * 0.01).collect();
        let mut points = Points {
            start: &start,
            end: &mut end,
            velocity: &mut velocity,
            inverse_mass: &[2.0, 0.0, 0.0, 0.0],
            moved: &mut [false; 4],
            h: 0.01,
        };
        let contact = Contact {
            kind: ContactKind::EdgeEdge,
            nodes: [0, 1, 2, 3],
            hit: hit([1.0, -0.5, -0.5, 0.0], 0.01),
            thickness: 0.01,
            friction: 0.25,
        };
        points.respond(&contact);
        assert!(points.velocity[0].y.abs() < 1e-12 && points.velocity[1] == Vector3::zeros());
        assert!((points.velocity[0].x - 0.5).abs() < 1e-12, "eq. 15: loses μ Δv_N = 0.25 × 2 of its slide");
        assert!((points.end[0] - (start[0] + points.velocity[0] * 0.01)).norm() < 1e-15);
    }

    #[test]
    fn contact_keys_ignore_the_order_of_points_but_not_the_kind() {
        let h = hit([1.0, -0.5, -0.5, 0.0], 0.0);
        let vt =
            Contact { kind: ContactKind::VertexTriangle, nodes: [4, 3, 1, 2], hit: h, thickness: 0.0, friction: 0.0 };
        let same = Contact { nodes: [4, 2, 3, 1], ..vt };
        assert_eq!(vt.key(), same.key());
        let ee = Contact { kind: ContactKind::EdgeEdge, nodes: [2, 1, 4, 3], ..vt };
        let swapped = Contact { nodes: [3, 4, 1, 2], ..ee };
        assert_eq!(ee.key(), swapped.key());
        assert_ne!(vt.key(), Contact { kind: ContactKind::EdgeEdge, ..vt }.key());
    }

    #[test]
    fn a_zone_moves_rigidly_with_its_momentum() {
        let start = [Vector3::new(-1.0, 0.0, 0.0), Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.0, 0.0, 1.0)];
        let mut end = start;
        let mut velocity = [Vector3::new(0.0, 1.0, 0.0), Vector3::new(0.0, -1.0, 0.0), Vector3::new(0.3, 0.0, 0.0)];
        let mut points = Points {
            start: &start,
            end: &mut end,
            velocity: &mut velocity,
            inverse_mass: &[1.0; 3],
            moved: &mut [false; 3],
            h: 0.1,
        };
        rigidify(&mut points, [0, 1, 2].into_iter(), None);
        let momentum: Vector3<f64> = points.velocity.iter().sum();
        assert!((momentum - Vector3::new(0.3, 0.0, 0.0)).norm() < 1e-12);
        for (i, j) in [(0, 1), (1, 2), (0, 2)] {
            let before = start[i] - start[j];
            let relative = points.velocity[i] - points.velocity[j];
            assert!(before.dot(&relative).abs() < 1e-12, "rigid: no stretching between {i} and {j}");
        }
    }
}
