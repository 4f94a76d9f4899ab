//! Bounding-volume hierarchy of swept boxes (parry3d's `Bvh`): built once from
//! a mesh's triangles, refitted every step with each triangle's box over the
//! whole step, grown by half the thickness (the other feature's box is grown
//! by the other half).
//!
//! parry3d works in f32; boxes are rounded outwards when converted, so no pair
//! that overlaps in f64 is lost.

use nalgebra::Vector3;
use parry3d::bounding_volume::Aabb;
use parry3d::math::Vector;
use parry3d::partitioning::{Bvh, BvhBuildStrategy, BvhNode, BvhWorkspace};

use super::pair_sort::PairSorter;

/// Steps between incremental re-optimisations of the tree (refitting alone
/// lets its quality decay as the cloth deforms).
const OPTIMIZE_EVERY: u32 = 16;

/// An axis-aligned box in f64, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Box3 {
    /// Lower corner.
    pub min: Vector3<f64>,
    /// Upper corner.
    pub max: Vector3<f64>,
}

impl Box3 {
    /// The empty box.
    pub fn empty() -> Self {
        Box3 { min: Vector3::repeat(f64::INFINITY), max: Vector3::repeat(f64::NEG_INFINITY) }
    }

    /// This box grown to contain `p`.
    pub fn with(self, p: &Vector3<f64>) -> Self {
        Box3 { min: self.min.inf(p), max: self.max.sup(p) }
    }

    /// This box grown by `margin` on every side.
    pub fn grown(self, margin: f64) -> Self {
        Box3 { min: self.min.add_scalar(-margin), max: self.max.add_scalar(margin) }
    }

    /// The smallest box containing both.
    pub fn union(self, other: &Box3) -> Self {
        Box3 { min: self.min.inf(&other.min), max: self.max.sup(&other.max) }
    }

    /// True when the boxes share a point. All six comparisons are made,
    /// without branches: in the narrow phase a box test's outcome is close
    /// to a coin toss, and mispredicted branches cost more than the
    /// comparisons they skip.
    pub fn overlaps(&self, other: &Box3) -> bool {
        let (a, b) = (self, other);
        (a.min.x <= b.max.x)
            & (b.min.x <= a.max.x)
            & (a.min.y <= b.max.y)
            & (b.min.y <= a.max.y)
            & (a.min.z <= b.max.z)
            & (b.min.z <= a.max.z)
    }

    /// True when the box holds no point (as [`Box3::empty`]).
    pub fn is_empty(&self) -> bool {
        !(self.min.x <= self.max.x && self.min.y <= self.max.y && self.min.z <= self.max.z)
    }

    /// True when `other` lies inside this box.
    pub fn contains(&self, other: &Box3) -> bool {
        self.union(other) == *self
    }

    /// The f32 box containing this one.
    fn outward(&self) -> Aabb {
        let down = |x: f64| {
            let f = x as f32;
            if (f as f64) > x { f.next_down() } else { f }
        };
        let up = |x: f64| {
            let f = x as f32;
            if (f as f64) < x { f.next_up() } else { f }
        };
        Aabb::new(
            Vector::new(down(self.min.x), down(self.min.y), down(self.min.z)),
            Vector::new(up(self.max.x), up(self.max.y), up(self.max.z)),
        )
    }
}

/// A hierarchy over a fixed set of leaves whose boxes change every step.
#[derive(Clone)]
pub struct SweptBvh {
    bvh: Bvh,
    workspace: BvhWorkspace,
    sorter: PairSorter,
    steps: u32,
}

impl std::fmt::Debug for SweptBvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SweptBvh").field("leaves", &self.bvh.leaf_count()).field("steps", &self.steps).finish()
    }
}

impl SweptBvh {
    /// A hierarchy over `boxes` (leaf `i` is `boxes[i]`).
    pub fn new(boxes: &[Box3]) -> Self {
        let leaves: Vec<Aabb> = boxes.iter().map(Box3::outward).collect();
        SweptBvh {
            bvh: Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves),
            workspace: BvhWorkspace::default(),
            sorter: PairSorter::default(),
            steps: 0,
        }
    }

    /// Replaces every leaf's box and refits the tree.
    pub fn update(&mut self, boxes: &[Box3]) {
        for (i, b) in boxes.iter().enumerate() {
            self.bvh.insert_or_update_partially(b.outward(), i as u32, 0.0);
        }
        self.refit();
    }

    /// Replaces the boxes of `leaves` (leaf `i` is `boxes[i]`; the others
    /// keep theirs) and refits the tree.
    pub fn update_leaves(&mut self, boxes: &[Box3], leaves: impl Iterator<Item = usize>) {
        for i in leaves {
            self.bvh.insert_or_update_partially(boxes[i].outward(), i as u32, 0.0);
        }
        self.refit();
    }

    /// Refits the tree to its leaves' boxes, and now and then optimises it.
    fn refit(&mut self) {
        self.bvh.refit(&mut self.workspace);
        self.steps += 1;
        if self.steps.is_multiple_of(OPTIMIZE_EVERY) {
            self.bvh.optimize_incremental(&mut self.workspace);
        }
    }

    /// Every pair of distinct leaves whose boxes overlap, as `(low, high)`,
    /// sorted, into `out`, but for the pairs `keep` refuses.
    pub fn self_pairs(&mut self, keep: impl Fn(u32, u32) -> bool, out: &mut Vec<(u32, u32)>) {
        out.clear();
        self.bvh.traverse_bvtt_single_tree::<false>(&mut self.workspace, &mut |a, b| {
            if keep(a, b) {
                out.push((a.min(b), a.max(b)));
            }
        });
        self.sorter.sort(out);
    }

    /// Every pair `(leaf of self, leaf of other)` whose boxes overlap, in
    /// no particular order, appended to `out`; a few pairs whose boxes do
    /// not overlap may be among them (the traversal hands over its first
    /// node pairs unchecked), so callers test each pair's own boxes.
    pub fn pairs_with(&self, other: &SweptBvh, out: &mut Vec<(u32, u32)>) {
        out.extend(self.bvh.leaf_pairs(&other.bvh, |a: &BvhNode, b: &BvhNode| a.intersects(b)));
    }

    /// Leaves whose boxes overlap `query`, sorted, into `out`.
    pub fn overlapping(&self, query: &Box3, out: &mut Vec<u32>) {
        out.clear();
        let aabb = query.outward();
        out.extend(self.bvh.intersect_aabb(&aabb));
        out.sort_unstable();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_at(x: f64) -> Box3 {
        Box3 { min: Vector3::new(x, 0.0, 0.0), max: Vector3::new(x + 1.0, 1.0, 1.0) }
    }

    #[test]
    fn pairs_follow_the_boxes_as_they_move() {
        let mut boxes = vec![unit_at(0.0), unit_at(0.5), unit_at(5.0)];
        let mut bvh = SweptBvh::new(&boxes);
        let mut pairs = Vec::new();
        bvh.self_pairs(|_, _| true, &mut pairs);
        assert_eq!(pairs, vec![(0, 1)]);
        boxes[2] = unit_at(1.2);
        bvh.update(&boxes);
        bvh.self_pairs(|_, _| true, &mut pairs);
        assert_eq!(pairs, vec![(0, 1), (1, 2)]);
        bvh.self_pairs(|a, b| a.max(b) != 2, &mut pairs);
        assert_eq!(pairs, vec![(0, 1)], "refused pairs are left out");
        let mut hits = Vec::new();
        bvh.overlapping(&Box3 { min: Vector3::new(1.3, 0.5, 0.5), max: Vector3::new(1.4, 0.6, 0.6) }, &mut hits);
        assert_eq!(hits, vec![1, 2]);
    }

    #[test]
    fn a_box_contains_what_lies_inside_it_and_not_what_crosses_its_side() {
        let outer = unit_at(0.0).grown(0.1);
        assert!(outer.contains(&unit_at(0.0)) && outer.contains(&unit_at(0.1)) && outer.contains(&outer));
        assert!(!outer.contains(&unit_at(0.2)) && !unit_at(0.0).contains(&outer));
    }

    #[test]
    fn f64_boxes_touching_by_a_hair_still_overlap_in_f32() {
        let a = Box3 { min: Vector3::zeros(), max: Vector3::new(0.1 + 1e-12, 1.0, 1.0) };
        let b = Box3 { min: Vector3::new(0.1, 0.0, 0.0), max: Vector3::new(1.0, 1.0, 1.0) };
        assert!(a.overlaps(&b));
        let mut bvh = SweptBvh::new(&[a, b]);
        let mut pairs = Vec::new();
        bvh.self_pairs(|_, _| true, &mut pairs);
        assert_eq!(pairs, vec![(0, 1)]);
    }
}
