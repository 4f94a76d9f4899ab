//! Repulsions between the cloth's resting contacts, in the implicit solve
//! (after Bridson et al. 2002's repulsion springs).
//!
//! A pair of features resting on each other at distance `d` of its
//! thickness `δ` ([`RestingPair`]) is a spring of stiffness `k` that pushes
//! until `d₀ = (1 + band) δ`: energy `E = ½ k (d₀ − d)²` for `d < d₀`, so
//! particle `i` of the pair feels `fᵢ = k (d₀ − d) wᵢ n` (the closest
//! points' weights `wᵢ` and the unit normal `n`; the weights' own change
//! moves `d` only to second order at the closest points). A self-contact's
//! spring pushes both features; one against an analytic collider's sharp
//! feature (a table's edge, a needle's tip) pushes only the cloth's, the
//! feature being where its collider puts it. The three kinds have their own
//! stiffness: a fold resting on itself carries little more than its own
//! weight, a cloth drawn over a sharp edge the tension of all that hangs
//! from it, spread along the edge, and a cloth resting on a thin prop's tip
//! as on a point (a needle) all that hangs from it through the few
//! triangles over the tip.
//!
//! The spring couples particles of two fold layers, which the springs'
//! factor does not hold, and conjugate gradients pays for such couplings with
//! many iterations (b0ac764). So its Jacobian
//! `−k (w wᵀ) ⊗ (n nᵀ)` enters the system *lumped*: each cloth particle's
//! diagonal block gets its row's absolute sum over the cloth particles,
//! `k |wᵢ| Σⱼ |wⱼ| n nᵀ` (`2 k |wᵢ| n nᵀ` for a self-contact, the weights of
//! each feature summing to one; `k |wᵢ| n nᵀ` against an obstacle). The
//! lumped matrix exceeds the true one by a positive semi-definite part, so
//! the step is as stable as a fully implicit one, and where the spring is
//! stiff against the masses the cloth closes the gap to `d₀` once (the two
//! features of a self-contact together, each moving its share) rather than
//! each particle closing it all as if the others stood still. The force
//! enters the right-hand side at the step's start; the collision response
//! still guarantees the thickness, the repulsions only spare it most of the
//! resting pairs it would answer pass after pass.

use nalgebra::Vector3;

use super::implicit::SystemBuffers;
use super::sparse::BlockPattern;

/// Two features resting on each other at a step's start: both the cloth's,
/// or one the cloth's and one an obstacle's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestingPair {
    /// The four points: vertex then triangle, or first edge then second
    /// (cloth particles, or obstacle points numbered after them).
    pub nodes: [u32; 4],
    /// Whether each point is a cloth particle, which the solve moves; the
    /// others are obstacle points, which nothing pushes back.
    pub on_cloth: [bool; 4],
    /// Weights whose sum `Σ wᵢ xᵢ` is the second feature's closest point to
    /// the first, seen from the first: `[1, −wa, −wb, −wc]` or
    /// `[1 − s, s, −(1 − t), −t]`.
    pub weights: [f64; 4],
    /// Unit direction from the second feature to the first.
    pub normal: Vector3<f64>,
    /// Distance between the features, m.
    pub distance: f64,
    /// Distance the pair must keep, m.
    pub thickness: f64,
    /// Whether the obstacle feature is the tip of a prop the cloth rests
    /// on as on a point (one the strain projection holds the cloth off,
    /// [`crate::sim::collision::obstacles::Obstacles::holds`]).
    pub on_a_tip: bool,
}

impl RestingPair {
    /// True when both features are the cloth's.
    pub fn is_self_contact(&self) -> bool {
        self.on_cloth.iter().all(|&c| c)
    }
}

/// What the repulsions of a step add.
#[derive(Clone, Copy, Debug)]
pub struct Repulsion {
    /// Stiffness `k` of a spring between two cloth features, N/m.
    pub self_stiffness: f64,
    /// Stiffness `k` of a spring between a cloth feature and an analytic
    /// collider's sharp feature, N/m.
    pub feature_stiffness: f64,
    /// Stiffness `k` of a spring between a cloth feature and the tip of a
    /// prop it rests on as on a point, N/m.
    pub tip_stiffness: f64,
    /// `d₀` beyond the thickness, as a fraction of it.
    pub band: f64,
    /// Step, s.
    pub h: f64,
}

impl Repulsion {
    /// Stiffness of `pair`'s spring, N/m.
    pub fn stiffness(&self, pair: &RestingPair) -> f64 {
        if pair.is_self_contact() {
            self.self_stiffness
        } else if pair.on_a_tip {
            self.tip_stiffness
        } else {
            self.feature_stiffness
        }
    }

    /// Force of `pair`'s spring on its `k`th point, N (nothing moves an
    /// obstacle's point, whatever this says).
    pub fn force(&self, pair: &RestingPair, k: usize) -> Vector3<f64> {
        let push = ((1.0 + self.band) * pair.thickness - pair.distance).max(0.0);
        pair.normal * (self.stiffness(pair) * push * pair.weights[k])
    }

    /// Adds every pair's impulse `h fᵢ` (N·s) to the right-hand side of its
    /// cloth particles and its lumped Jacobian `h² k |wᵢ| Σⱼ |wⱼ| n nᵀ` (kg)
    /// to their diagonal blocks of the system on `pattern`, in the pairs'
    /// order.
    pub fn add_to(&self, pairs: &[RestingPair], pattern: &BlockPattern, system: &mut SystemBuffers) {
        for pair in pairs {
            let on_cloth = |k: &usize| pair.on_cloth[*k];
            let coupled: f64 = (0..4).filter(on_cloth).map(|k| pair.weights[k].abs()).sum();
            let lumped = self.h * self.h * self.stiffness(pair) * coupled;
            let stiffening = pair.normal * pair.normal.transpose();
            for k in (0..4).filter(on_cloth) {
                let i = pair.nodes[k] as usize;
                system.rhs[i] += self.force(pair, k) * self.h;
                system.matrix[pattern.diagonal(i)] += stiffening * (lumped * pair.weights[k].abs());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::Matrix3;

    use super::*;
    use crate::sim::collision::geometry::{closest_on_triangle, point_triangle_distance};

    const THICKNESS: f64 = 0.0025;

    const SELF_CONTACT: [bool; 4] = [true; 4];
    const ON_AN_OBSTACLE: [bool; 4] = [true, false, false, false];

    fn repulsion(self_stiffness: f64, feature_stiffness: f64) -> Repulsion {
        Repulsion { self_stiffness, feature_stiffness, tip_stiffness: feature_stiffness, band: 0.1, h: 1.0 / 60.0 }
    }

    fn vertex_over_triangle(x: &[Vector3<f64>; 4], on_cloth: [bool; 4]) -> RestingPair {
        let [wa, wb, wc] = closest_on_triangle(&x[0], &x[1], &x[2], &x[3]);
        let weights = [1.0, -wa, -wb, -wc];
        let gap: Vector3<f64> = (0..4).map(|k| x[k] * weights[k]).sum();
        let distance = gap.norm();
        let normal = gap / distance;
        RestingPair { nodes: [0, 1, 2, 3], on_cloth, weights, normal, distance, thickness: THICKNESS, on_a_tip: false }
    }

    fn resting_vertex() -> [Vector3<f64>; 4] {
        [
            Vector3::new(0.3, 0.0024, 0.2),
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0001, 0.0),
            Vector3::new(0.0, -0.0002, 1.0),
        ]
    }

    #[test]
    fn the_force_is_minus_the_gradient_of_the_spring_energy() {
        let x = resting_vertex();
        for (on_cloth, stiffness) in [(SELF_CONTACT, 2.0), (ON_AN_OBSTACLE, 30.0)] {
            let repulsion = repulsion(2.0, 30.0);
            let energy = |x: &[Vector3<f64>; 4]| {
                let d = point_triangle_distance(&x[0], &x[1], &x[2], &x[3]);
                let push = ((1.0 + repulsion.band) * THICKNESS - d).max(0.0);
                0.5 * stiffness * push * push
            };
            let pair = vertex_over_triangle(&x, on_cloth);
            let step = 1e-7;
            for k in 0..4 {
                for axis in 0..3 {
                    let (mut plus, mut minus) = (x, x);
                    plus[k][axis] += step;
                    minus[k][axis] -= step;
                    let numeric = -(energy(&plus) - energy(&minus)) / (2.0 * step);
                    let analytic = repulsion.force(&pair, k)[axis];
                    let close = (numeric - analytic).abs() < 1e-6 * (1.0 + analytic.abs());
                    assert!(close, "{k} {axis}: {numeric} {analytic}");
                }
            }
        }
    }

    /// The velocity changes a system of four particles of `mass` (kg) gets
    /// from `pair`'s repulsion alone.
    fn velocity_changes(repulsion: &Repulsion, pair: &RestingPair, mass: f64) -> Vec<Vector3<f64>> {
        let pattern = BlockPattern::new(4, []);
        let mut system = SystemBuffers::default();
        system.matrix = vec![Matrix3::identity() * mass; pattern.stored_blocks()];
        system.rhs = vec![Vector3::zeros(); 4];
        repulsion.add_to(&[*pair], &pattern, &mut system);
        (0..4).map(|i| system.matrix[pattern.diagonal(i)].try_inverse().unwrap() * system.rhs[i]).collect()
    }

    /// Stiff against the masses, the lumped solve closes the gap to `d₀`
    /// once: the two features of a self-contact move apart by `d₀ − d`
    /// together; against an obstacle the cloth's vertex moves it all and the
    /// obstacle's points get nothing.
    #[test]
    fn a_stiff_repulsion_closes_the_gap_once_wherever_the_vertex_rests() {
        let repulsion = repulsion(1e9, 1e9);
        for on_cloth in [SELF_CONTACT, ON_AN_OBSTACLE] {
            for at in [Vector3::new(0.3, 0.0024, 0.2), Vector3::new(0.01, 0.0024, 0.01), Vector3::new(0.5, 0.0024, 0.0)]
            {
                let mut x = resting_vertex();
                x[0] = at;
                let pair = vertex_over_triangle(&x, on_cloth);
                let velocity_change = velocity_changes(&repulsion, &pair, 1e-5);
                let moved = |k: usize| pair.weights[k] * pair.normal.dot(&(velocity_change[k] * repulsion.h));
                let opened: f64 = (0..4).map(moved).sum();
                let gap = (1.0 + repulsion.band) * THICKNESS - pair.distance;
                assert!((opened - gap).abs() < 1e-6 * gap, "{on_cloth:?}: {opened} against {gap}");
                for k in (0..4).filter(|&k| !on_cloth[k]) {
                    assert_eq!(velocity_change[k], Vector3::zeros(), "an obstacle point got a push");
                }
            }
        }
    }

    /// Each kind of pair is pushed with its own stiffness: a weak self
    /// repulsion leaves an obstacle pair's spring as stiff as it is set, and
    /// a cloth on a needle's tip is pushed with the tips' stiffness.
    #[test]
    fn self_obstacle_and_tip_pairs_have_their_own_stiffness() {
        let repulsion = Repulsion { tip_stiffness: 150.0, ..repulsion(0.5, 20.0) };
        let x = resting_vertex();
        let (folded, draped) = (vertex_over_triangle(&x, SELF_CONTACT), vertex_over_triangle(&x, ON_AN_OBSTACLE));
        let on_a_needle = RestingPair { on_a_tip: true, ..draped };
        let stiffness = [folded, draped, on_a_needle].map(|pair| repulsion.stiffness(&pair));
        assert_eq!(stiffness, [0.5, 20.0, 150.0]);
        let ratio = repulsion.force(&draped, 0).norm() / repulsion.force(&folded, 0).norm();
        assert!((ratio - 40.0).abs() < 1e-9, "{ratio}");
        let ratio = repulsion.force(&on_a_needle, 0).norm() / repulsion.force(&draped, 0).norm();
        assert!((ratio - 7.5).abs() < 1e-9, "{ratio}");
    }
}
