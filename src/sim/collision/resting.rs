//! The cloth's resting self-contacts at the start of a step, for the
//! implicit solve to push apart ([`crate::sim::repulsion`]).
//!
//! A fold that rests on itself is left by the response with its feature
//! pairs at the thickness; the next solve, which knows nothing of them,
//! presses them back within it, and every step's passes answer them again
//! (thousands per step on `drape_sphere`, see BENCHMARKS). The pairs are the
//! contacts the pipeline remembers (their influence, eq. 16: what snapshots,
//! roll-backs and resumed bakes already restore) between cloth particles,
//! taken in key order with their closest points at the current positions,
//! and kept only where they rest: within `band` (a fraction of the
//! thickness) of the thickness. Crossings just answered and pairs that slid
//! apart fall outside it.

use nalgebra::Vector3;

use super::CollisionPipeline;
use super::geometry::{closest_between_segments, closest_on_triangle};
use crate::sim::repulsion::Repulsion;

/// Two cloth features resting on each other at a step's start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestingPair {
    /// The four particles: vertex then triangle, or first edge then second.
    pub nodes: [u32; 4],
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
}

impl CollisionPipeline {
    /// The repulsions of a step of `h` s starting at positions `x` (m), with
    /// the resting pairs they push into `out`; `None` (and no pairs) when the
    /// scene turns them off.
    pub fn repulsion(&mut self, x: &[Vector3<f64>], h: f64, out: &mut Vec<RestingPair>) -> Option<Repulsion> {
        let (stiffness, band) = (self.settings.repulsion_stiffness, self.settings.repulsion_band);
        if stiffness == 0.0 {
            out.clear();
            return None;
        }
        self.resting_pairs(x, band, out);
        Some(Repulsion { stiffness, band, h })
    }

    /// The remembered contacts between cloth particles whose features lie
    /// within `band` (a fraction of their thickness) of the thickness at
    /// positions `x` (m), in key order, into `out`.
    pub fn resting_pairs(&mut self, x: &[Vector3<f64>], band: f64, out: &mut Vec<RestingPair>) {
        out.clear();
        let cloth = self.particles.len() as u32;
        let keys = &mut self.ws.resting_keys;
        keys.clear();
        keys.extend(self.influence.keys().filter(|key| key[1..].iter().all(|&i| i < cloth)));
        keys.sort_unstable();
        out.extend(keys.iter().filter_map(|key| {
            let nodes = [key[1], key[2], key[3], key[4]];
            let thickness = nodes.iter().map(|&i| self.particles[i as usize].thickness).fold(0.0, f64::max);
            let pair = pair_at(key[0], nodes, x, thickness)?;
            ((pair.distance - thickness).abs() <= band * thickness).then_some(pair)
        }));
    }
}

/// The pair of `kind` (0 vertex-triangle, 1 edge-edge) between `nodes` at
/// positions `x`, or `None` where its features touch.
fn pair_at(kind: u32, nodes: [u32; 4], x: &[Vector3<f64>], thickness: f64) -> Option<RestingPair> {
    let [a, b, c, d] = nodes.map(|i| x[i as usize]);
    let weights = if kind == 0 {
        let [wa, wb, wc] = closest_on_triangle(&a, &b, &c, &d);
        [1.0, -wa, -wb, -wc]
    } else {
        let (s, t) = closest_between_segments(&a, &b, &c, &d);
        [1.0 - s, s, -(1.0 - t), -t]
    };
    let gap = a * weights[0] + b * weights[1] + c * weights[2] + d * weights[3];
    let distance = gap.norm();
    (distance > 0.0).then(|| RestingPair { nodes, weights, normal: gap / distance, distance, thickness })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::collision::obstacles::{ClothScale, Obstacles};
    use crate::sim::collision::{CollisionMemory, CollisionSettings, ParticleCollision};

    /// Of the remembered contacts, those between cloth particles resting
    /// within the band of the thickness, in key order.
    #[test]
    fn resting_pairs_are_the_remembered_cloth_contacts_at_the_thickness() {
        let thickness = 0.0025;
        let particles = vec![ParticleCollision { thickness, friction: 0.3, pinned: None }; 6];
        let scale = ClothScale { longest_edge_m: 1.0, thinnest_m: thickness };
        let settings = CollisionSettings::default();
        let mut pipeline = CollisionPipeline::new(
            vec![[0, 1, 2], [3, 4, 5]],
            vec![0, 0],
            vec![true],
            particles,
            Obstacles::new(&[], &[], scale),
            settings,
        )
        .unwrap();
        let remembered = [
            ([0, 0, 3, 4, 5], 1.0, true),  // 20 cm apart
            ([0, 3, 0, 1, 2], 1.0, true),  // at the thickness
            ([0, 4, 0, 1, 2], 0.1, false), // 5 % past it
            ([0, 5, 0, 1, 2], 1.0, true),  // at half of it: a crossing just answered
            ([0, 6, 0, 1, 2], 1.0, true),  // an obstacle's point
        ];
        pipeline.restore_memory(&CollisionMemory::from_entries(&remembered));
        let x = [
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(0.2, thickness, 0.2),
            Vector3::new(0.3, 1.05 * thickness, 0.1),
            Vector3::new(0.2, 0.5 * thickness, 0.3),
        ];
        let mut pairs = Vec::new();
        pipeline.resting_pairs(&x, 0.1, &mut pairs);
        let nodes: Vec<[u32; 4]> = pairs.iter().map(|p| p.nodes).collect();
        assert_eq!(nodes, [[3, 0, 1, 2], [4, 0, 1, 2]]);
        assert!((pairs[1].distance - 1.05 * thickness).abs() < 1e-12 && pairs[1].thickness == thickness);
    }

    #[test]
    fn a_vertex_over_a_triangle_rests_along_the_triangle_normal() {
        let x = [
            Vector3::new(0.25, 0.0025, 0.25),
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
        ];
        let pair = pair_at(0, [0, 1, 2, 3], &x, 0.0025).unwrap();
        assert!((pair.distance - 0.0025).abs() < 1e-15);
        assert!((pair.normal - Vector3::y()).norm() < 1e-12);
        let expected = [1.0, -0.5, -0.25, -0.25];
        assert!(pair.weights.iter().zip(expected).all(|(w, e)| (w - e).abs() < 1e-12), "{:?}", pair.weights);
    }

    #[test]
    fn crossing_edges_rest_along_their_common_normal() {
        let x = [
            Vector3::new(-1.0, 0.003, 0.0),
            Vector3::new(1.0, 0.003, 0.0),
            Vector3::new(0.0, 0.0, -1.0),
            Vector3::new(0.0, 0.0, 3.0),
        ];
        let pair = pair_at(1, [0, 1, 2, 3], &x, 0.0025).unwrap();
        assert!((pair.distance - 0.003).abs() < 1e-15);
        let expected = [0.5, 0.5, -0.75, -0.25];
        assert!(pair.weights.iter().zip(expected).all(|(w, e)| (w - e).abs() < 1e-12), "{:?}", pair.weights);
        assert!((pair.normal - Vector3::y()).norm() < 1e-12);
    }
}
