//! The six face-diagonal slabs that, with a box, bound a swept triangle as an
//! 18-DOP (Klosowski et al. 1998): its extent along x ± y, x ± z and y ± z.
//!
//! On a cloth lying flat and square to the axes, a triangle's box (grown by
//! half the thickness) overlaps those of the 17 triangles of the 3 × 3 cells
//! around it. A dozen share a corner with it, and their features that do not
//! (the far corner of a cell's other triangle, say) lie 0.7 of an edge away
//! along a diagonal of the cloth's plane; the rest are as far along one.
//! The boxes cannot tell any of these apart and the start distances can only
//! after a test per feature pair. The slabs tell them apart with twelve
//! comparisons: the narrow phase checks them for a pair of triangles (cloth
//! with cloth or with an obstacle) before its features, and for each feature
//! pair that passes the box test (sharp obstacle vertices and edges too).
//!
//! Why a pair whose slabs do not overlap cannot touch: every point of a
//! triangle at any time of the step is a convex combination of its corners,
//! each moving on a straight path, so its projection on an axis lies between
//! the least and the largest projection of the corners' starts and ends. A
//! slab grown by g along the unit axis (g √2 along the unscaled x ± y) holds
//! the ball of radius g around each of those points. Two slabs apart along an
//! axis put every point of one triangle more than 2g from every point of the
//! other at every time of the step; 2g is at least the thickness of any
//! contact ([`super::detect::box_growth`]), so neither a crossing nor a
//! proximity can be found between them: the slabs drop only pairs whose
//! every feature test would find nothing.

use nalgebra::Vector3;

/// Added to every slab's growth, m: more than the round-off of a diagonal
/// coordinate anywhere within a kilometre of the origin.
const ROUNDING_M: f64 = 1e-9;

/// The extent of a swept point or triangle along the six face diagonals
/// (x + y, x − y, x + z, x − z, y + z, y − z, unscaled: a unit step along the
/// diagonal is √2), m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct DiagonalSlabs {
    min: [f64; 6],
    max: [f64; 6],
}

/// The coordinates of `p` along the six face diagonals, m.
fn diagonals(p: &Vector3<f64>) -> [f64; 6] {
    [p.x + p.y, p.x - p.y, p.x + p.z, p.x - p.z, p.y + p.z, p.y - p.z]
}

impl DiagonalSlabs {
    /// No slabs: those of no point.
    pub(super) fn empty() -> Self {
        DiagonalSlabs { min: [f64::INFINITY; 6], max: [f64::NEG_INFINITY; 6] }
    }

    /// The slabs of a point going from `start` to `end` in a straight line,
    /// grown by `growth` (m) along each unit diagonal.
    pub(super) fn of_path(start: &Vector3<f64>, end: &Vector3<f64>, growth: f64) -> Self {
        let (a, b) = (diagonals(start), diagonals(end));
        let margin = growth * std::f64::consts::SQRT_2 + ROUNDING_M;
        DiagonalSlabs {
            min: std::array::from_fn(|k| a[k].min(b[k]) - margin),
            max: std::array::from_fn(|k| a[k].max(b[k]) + margin),
        }
    }

    /// The slabs of triangle `tri` whose points have slabs `point_slabs`.
    pub(super) fn of_triangle(tri: [u32; 3], point_slabs: &[DiagonalSlabs]) -> Self {
        let [a, b, c] = tri.map(|v| &point_slabs[v as usize]);
        a.union(b).union(c)
    }

    /// The smallest slabs holding both.
    pub(super) fn union(&self, other: &DiagonalSlabs) -> Self {
        DiagonalSlabs {
            min: std::array::from_fn(|k| self.min[k].min(other.min[k])),
            max: std::array::from_fn(|k| self.max[k].max(other.max[k])),
        }
    }

    /// True when the two overlap along every diagonal. All twelve
    /// comparisons are made, without branches (as [`super::bvh::Box3::overlaps`]).
    pub(super) fn overlaps(&self, other: &DiagonalSlabs) -> bool {
        (0..6).fold(true, |all, k| all & (self.min[k] <= other.max[k]) & (other.min[k] <= self.max[k]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::triangles::triangles_intersect;
    use crate::sim::collision::geometry::{point_triangle_distance, segment_distance};
    use crate::sim::test_grid::uniform_samples;

    /// The distance between two triangles, m: zero where they meet, else the
    /// least of their corner-triangle and edge-edge distances.
    fn triangle_distance(p: &[Vector3<f64>; 3], q: &[Vector3<f64>; 3]) -> f64 {
        if triangles_intersect(p, q) {
            return 0.0;
        }
        let corners = (0..3).flat_map(|k| {
            [point_triangle_distance(&p[k], &q[0], &q[1], &q[2]), point_triangle_distance(&q[k], &p[0], &p[1], &p[2])]
        });
        let edges = (0..9).map(|k| {
            let (i, j) = (k / 3, k % 3);
            segment_distance(&p[i], &p[(i + 1) % 3], &q[j], &q[(j + 1) % 3])
        });
        corners.chain(edges).fold(f64::INFINITY, f64::min)
    }

    fn triangle_slabs(points: &[(Vector3<f64>, Vector3<f64>)], growth: f64) -> DiagonalSlabs {
        let slabs: Vec<DiagonalSlabs> = points.iter().map(|(s, e)| DiagonalSlabs::of_path(s, e, growth)).collect();
        DiagonalSlabs::of_triangle([0, 1, 2], &slabs)
    }

    /// Triangles a row apart on a flat grid of 15.6 mm cells, in each of the
    /// three coordinate planes: their boxes grown by half a 2.5 mm thickness
    /// overlap, their slabs do not.
    #[test]
    fn flat_neighbours_a_row_apart_are_told_apart() {
        let h = 0.0156;
        let growth = 0.00125;
        let lower = [[0.0, 0.0], [h, 0.0], [0.0, h]];
        let upper_of_next_cell = [[2.0 * h, 0.0], [h, h], [2.0 * h, h]];
        for plane in [[0, 2], [0, 1], [1, 2]] {
            let place = |uv: [f64; 2]| {
                let mut p = Vector3::new(0.3, 0.7, -0.2);
                p[plane[0]] += uv[0];
                p[plane[1]] += uv[1];
                (p, p)
            };
            let a = triangle_slabs(&lower.map(place), growth);
            let b = triangle_slabs(&upper_of_next_cell.map(place), growth);
            assert!(!a.overlaps(&b), "plane {plane:?}");
            assert!(a.overlaps(&a));
        }
    }

    /// Random triangles over random straight paths: wherever the slabs are
    /// apart, the triangles stay farther apart than twice the growth at every
    /// sampled time (and some come within 1.5 times that).
    #[test]
    fn slabs_apart_keep_the_triangles_apart_over_the_step() {
        let mut next = uniform_samples(0x2545_f491_4f6c_dd1d);
        let growth = 0.01;
        let (mut apart, mut closest) = (0, f64::INFINITY);
        for _ in 0..4000 {
            let mut random_point = || Vector3::new(next(), next(), next()) * 0.2;
            let first: [(Vector3<f64>, Vector3<f64>); 3] = std::array::from_fn(|_| (random_point(), random_point()));
            let offset = Vector3::new(0.1, 0.1, 0.0);
            let second: [(Vector3<f64>, Vector3<f64>); 3] =
                std::array::from_fn(|_| (random_point() + offset, random_point() + offset));
            if triangle_slabs(&first, growth).overlaps(&triangle_slabs(&second, growth)) {
                continue;
            }
            apart += 1;
            for step in 0..=50 {
                let t = step as f64 / 50.0;
                let at = |(s, e): (Vector3<f64>, Vector3<f64>)| s + (e - s) * t;
                let (p, q) = (first.map(at), second.map(at));
                let distance = triangle_distance(&p, &q);
                closest = closest.min(distance);
                assert!(distance > 2.0 * growth, "slabs apart, triangles {distance} m apart at t = {t}");
            }
        }
        assert!(apart > 100, "the test exercised {apart} separated pairs");
        assert!(closest < 3.0 * growth, "and came near the bound: {closest} m against {}", 2.0 * growth);
    }
}
