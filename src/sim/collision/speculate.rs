//! The first detection's broad phase, done ahead on the other core while the
//! implicit solve runs (whose spring factor keeps one core busy and the
//! other waiting).
//!
//! Before the solve the cloth's end positions are not known, so they are
//! predicted (a simulator carries each particle by its start velocity) and
//! every point's box over the step is grown by [`MARGIN_IN_THICKNESSES`] of
//! its thickness beyond what the real box needs. The cloth's hierarchy is
//! refitted to these boxes and its self pairs (but those sharing a vertex,
//! see [`super::adjacent`]) and body pairs are found.
//! When the real ends are known, the first detection *confirms* them: a pair
//! whose real boxes overlap is kept, and the triangles whose real box left
//! its predicted one (they *escaped*) are queried again, as moved triangles
//! are after a response. Every real box lies in its hierarchy leaf, so the confirmed
//! pairs are exactly those a broad phase of the real boxes finds, and the
//! contacts do not depend on how good the prediction was; only the work
//! left after the solve does.

use nalgebra::Vector3;

use super::adjacent;
use super::bvh::{Box3, SweptBvh};
use super::pair_sort::merge_sorted;
use super::partners::moved_pairs;
use super::{CollisionPipeline, ParticleCollision, Workspace};
use crate::sim::contact::StepWindow;

/// How far, in multiples of a particle's thickness, its predicted box is
/// grown beyond the thickness its real box is grown by. On `skirt_walk`,
/// predicting the ends from the start velocities, 11 % of the triangles
/// escape boxes grown by two more thicknesses (5 mm) in a mean step, 23 %
/// by one; three or four do not pay for their larger pair lists.
pub const MARGIN_IN_THICKNESSES: f64 = 2.0;

impl CollisionPipeline {
    /// Boxes the cloth for the step over `window` from its `start` and
    /// `predicted_end` positions (m), refits its hierarchy and finds the
    /// pairs the boxes give, for the step's first detection to confirm.
    /// Does nothing unless the obstacles are framed for `window` (the boxes
    /// share their frame).
    pub fn speculate(&mut self, window: StepWindow, start: &[Vector3<f64>], predicted_end: &[Vector3<f64>]) {
        let cloth_pairs = self.cloth_pairs_wanted();
        let ws = &mut self.ws;
        ws.speculative = false;
        ws.partners.invalidate();
        if self.framed != Some(window) || self.triangles.is_empty() {
            return;
        }
        let (shift, growth) = (ws.shift, ws.growth);
        let particles = &self.particles;
        let point_box = |v: u32| {
            let (i, thickness) = (v as usize, particles[v as usize].thickness);
            let path = Box3::empty().with(&start[i]).with(&(predicted_end[i] - shift));
            path.grown(growth + thickness * MARGIN_IN_THICKNESSES)
        };
        ws.leaf_box.clear();
        ws.leaf_box.extend(self.triangles.iter().map(|t| {
            let [a, b, c] = t.map(point_box);
            a.union(&b).union(&c)
        }));
        let bvh = match &mut self.bvh {
            Some(bvh) => {
                bvh.update(&ws.leaf_box);
                bvh
            }
            None => self.bvh.insert(SweptBvh::new(&ws.leaf_box)),
        };
        ws.speculative_pairs.clear();
        if cloth_pairs {
            let triangles = &self.triangles;
            let apart = adjacent::apart(triangles);
            bvh.self_pairs(apart, &mut ws.speculative_pairs);
        }
        ws.speculative_mesh_pairs.clear();
        if let Some(obstacles) = &self.obstacle_bvh {
            obstacles.pairs_with(bvh, &mut ws.speculative_mesh_pairs);
        }
        // The lists need only the pairs: made here, on the core the solve
        // leaves free, they cost the first detection nothing.
        ws.partners.list(self.triangles.len(), &ws.speculative_pairs, &ws.speculative_mesh_pairs);
        ws.speculative = true;
    }

    /// After a speculation, marks the triangles whose real box is not
    /// inside the predicted one (they escaped) as the workspace's
    /// `moved_triangle`s and `moved_list`, to be queried again as moved
    /// triangles are after a response; their leaves become their real
    /// boxes grown by the margin. Every leaf then contains its triangle's
    /// real box, and the leaf partners the speculation listed for the
    /// step's later detections ([`super::partners`]) hold.
    pub(super) fn update_escaped(&mut self) {
        let ws = &mut self.ws;
        let boxes = ws.leaf_box.iter().zip(&ws.triangle_box);
        ws.moved_triangle.clear();
        ws.moved_triangle.extend(boxes.map(|(predicted, real)| !predicted.contains(real)));
        let escaped = ws.moved_triangle.iter().enumerate().filter(|&(_, &e)| e);
        ws.moved_list.clear();
        ws.moved_list.extend(escaped.map(|(t, _)| t as u32));
        let Some(bvh) = &mut self.bvh else {
            // A speculation made the hierarchy; without one nothing is listed.
            ws.partners.invalidate();
            return;
        };
        let margin = leaf_margin(&self.triangles, &self.particles);
        let boxes = (&ws.triangle_box[..], &mut ws.leaf_box[..]);
        ws.partners.re_leaf(&ws.moved_list, boxes, margin, bvh, (&mut ws.query_chunks, &mut ws.pair_sorter));
    }
}

/// How much a triangle's real box is grown to make its leaf: the margin of
/// the speculation, for the thickest of its particles, m.
pub(super) fn leaf_margin<'a>(
    triangles: &'a [[u32; 3]],
    particles: &'a [ParticleCollision],
) -> impl Fn(u32) -> f64 + 'a {
    move |t| {
        let thickest = triangles[t as usize].iter().map(|&v| particles[v as usize].thickness).fold(0.0, f64::max);
        MARGIN_IN_THICKNESSES * thickest
    }
}

/// The speculation's self pairs whose real boxes overlap, with the escaped
/// triangles' own, into the workspace's `pairs`, sorted: what
/// [`SweptBvh::self_pairs`] of the real boxes gives, without the pairs of
/// `triangles` that share a vertex.
pub(super) fn confirmed_self_pairs(bvh: &SweptBvh, triangles: &[[u32; 3]], ws: &mut Workspace) {
    let (boxes, escaped) = (&ws.triangle_box, &ws.moved_triangle);
    let scratch = (&mut ws.query_chunks, &mut ws.pair_sorter);
    let apart = adjacent::apart(triangles);
    moved_pairs(bvh, (boxes, escaped, &ws.moved_list), None, apart, scratch, &mut ws.escaped_pairs);
    let kept = ws.speculative_pairs.iter().copied().filter(|&(a, b)| boxes[a as usize].overlaps(&boxes[b as usize]));
    merge_sorted(kept, &ws.escaped_pairs, &mut ws.pairs);
}
