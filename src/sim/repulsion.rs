//! Repulsions between the cloth's resting self-contacts, in the implicit
//! solve (after Bridson et al. 2002's repulsion springs).
//!
//! A pair of features resting on each other at distance `d` of its
//! thickness `δ` ([`RestingPair`]) is a spring of stiffness `k` that pushes
//! until `d₀ = (1 + band) δ`: energy `E = ½ k (d₀ − d)²` for `d < d₀`, so
//! particle `i` of the pair feels `fᵢ = k (d₀ − d) wᵢ n` (the closest
//! points' weights `wᵢ` and the unit normal `n`; the weights' own change
//! moves `d` only to second order at the closest points).
//!
//! The spring couples particles of two fold layers, which the springs'
//! factor does not hold, and conjugate gradients pays for such couplings with
//! many iterations (BENCHMARKS, 2026-12-04 noon). So its Jacobian
//! `−k (w wᵀ) ⊗ (n nᵀ)` enters the system *lumped*: each particle's diagonal
//! block gets its row's absolute sum, `k |wᵢ| Σⱼ |wⱼ| n nᵀ = 2 k |wᵢ| n nᵀ`
//! (the weights of each feature sum to one). The lumped matrix exceeds the
//! true one by a positive semi-definite part, so the step is as stable as a
//! fully implicit one, and where the spring is stiff against the masses the
//! two features together close the gap to `d₀` once, each moving its share,
//! rather than each closing it all as if the other stood still. The force
//! enters the right-hand side at the step's start; the collision response
//! still guarantees the thickness, the repulsions only spare it most of the
//! resting pairs it would answer pass after pass.

use nalgebra::Vector3;

use super::collision::resting::RestingPair;
use super::implicit::SystemBuffers;
use super::sparse::BlockPattern;

/// What the repulsions of a step add.
#[derive(Clone, Copy, Debug)]
pub struct Repulsion {
    /// Spring stiffness `k`, N/m.
    pub stiffness: f64,
    /// `d₀` beyond the thickness, as a fraction of it.
    pub band: f64,
    /// Step, s.
    pub h: f64,
}

impl Repulsion {
    /// Force of `pair`'s spring on its `k`th particle, N.
    pub fn force(&self, pair: &RestingPair, k: usize) -> Vector3<f64> {
        let push = ((1.0 + self.band) * pair.thickness - pair.distance).max(0.0);
        pair.normal * (self.stiffness * push * pair.weights[k])
    }

    /// Adds every pair's impulse `h fᵢ` (N·s) to the right-hand side and its
    /// lumped Jacobian `2 h² k |wᵢ| n nᵀ` (kg) to the diagonal blocks of the
    /// system on `pattern`, in the pairs' order.
    pub fn add_to(&self, pairs: &[RestingPair], pattern: &BlockPattern, system: &mut SystemBuffers) {
        let lumped = 2.0 * self.h * self.h * self.stiffness;
        for pair in pairs {
            let stiffening = pair.normal * pair.normal.transpose();
            for (k, &node) in pair.nodes.iter().enumerate() {
                let i = node as usize;
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

    fn vertex_over_triangle(x: &[Vector3<f64>; 4]) -> RestingPair {
        let [wa, wb, wc] = closest_on_triangle(&x[0], &x[1], &x[2], &x[3]);
        let weights = [1.0, -wa, -wb, -wc];
        let gap: Vector3<f64> = (0..4).map(|k| x[k] * weights[k]).sum();
        let distance = gap.norm();
        RestingPair { nodes: [0, 1, 2, 3], weights, normal: gap / distance, distance, thickness: THICKNESS }
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
        let repulsion = Repulsion { stiffness: 2.0, band: 0.1, h: 1.0 / 60.0 };
        let energy = |x: &[Vector3<f64>; 4]| {
            let d = point_triangle_distance(&x[0], &x[1], &x[2], &x[3]);
            let push = ((1.0 + repulsion.band) * THICKNESS - d).max(0.0);
            0.5 * repulsion.stiffness * push * push
        };
        let x = resting_vertex();
        let pair = vertex_over_triangle(&x);
        let step = 1e-7;
        for k in 0..4 {
            for axis in 0..3 {
                let (mut plus, mut minus) = (x, x);
                plus[k][axis] += step;
                minus[k][axis] -= step;
                let numeric = -(energy(&plus) - energy(&minus)) / (2.0 * step);
                let analytic = repulsion.force(&pair, k)[axis];
                assert!((numeric - analytic).abs() < 1e-6 * (1.0 + analytic.abs()), "{k} {axis}: {numeric} {analytic}");
            }
        }
    }

    /// Stiff against the masses, the lumped solve closes the gap to `d₀`
    /// once: the two features move apart by `d₀ − d` together.
    #[test]
    fn a_stiff_repulsion_closes_the_gap_once_wherever_the_vertex_rests() {
        for at in [Vector3::new(0.3, 0.0024, 0.2), Vector3::new(0.01, 0.0024, 0.01), Vector3::new(0.5, 0.0024, 0.0)] {
            let mut x = resting_vertex();
            x[0] = at;
            let pair = vertex_over_triangle(&x);
            let h = 1.0 / 60.0;
            let repulsion = Repulsion { stiffness: 1e9, band: 0.1, h };
            let mass = 1e-5;
            let pattern = BlockPattern::new(4, []);
            let mut system = SystemBuffers::default();
            system.matrix = vec![Matrix3::identity() * mass; pattern.stored_blocks()];
            system.rhs = vec![Vector3::zeros(); 4];
            repulsion.add_to(&[pair], &pattern, &mut system);
            let velocity_change: Vec<Vector3<f64>> =
                (0..4).map(|i| system.matrix[pattern.diagonal(i)].try_inverse().unwrap() * system.rhs[i]).collect();
            let opened: f64 = (0..4).map(|k| pair.weights[k] * pair.normal.dot(&(velocity_change[k] * h))).sum();
            let gap = (1.0 + repulsion.band) * THICKNESS - pair.distance;
            assert!((opened - gap).abs() < 1e-6 * gap, "{opened} against {gap}");
        }
    }
}
