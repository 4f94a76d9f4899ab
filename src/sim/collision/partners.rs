//! The broad phase of a step's later detections, from lists instead of
//! hierarchy queries.
//!
//! After a speculated first detection ([`super::speculate`]) every cloth
//! triangle's hierarchy leaf is a box grown by a margin around its path
//! (its *leaf box*), and the leaves' overlapping pairs are known. A later
//! detection (after a response pass moved some points) must find, for every
//! moved triangle, the triangles and obstacle triangles whose real boxes
//! meet its own. While the moved triangle's real box stays inside its leaf
//! box, those are among the partners its leaf had: every real box lies in
//! its leaf, so two real boxes that overlap have leaves that overlap. So the
//! partners are listed once per step, and a moved triangle that stays in
//! its leaf reads its list and tests the real boxes, where a query walked
//! the hierarchy: on `skirt_walk`, on average, 835 triangles in a step's
//! second detection, 655 in its third and 374 in its fourth.
//!
//! A triangle whose real box leaves its leaf box (it *escapes*: the first
//! detection's escaped triangles, and any a response moved further than
//! the margin) gets a new leaf, its real box grown by the same margin, and
//! is queried from then on, as moved triangles were; the triangles its new
//! leaf meets have it added to their lists. The pairs found are the same,
//! in the same order, as with queries alone (unit-tested), so the contacts
//! and the bake are too.

use super::bvh::{Box3, SweptBvh};
use super::pair_sort::{PairSorter, merge_sorted};
use super::queries::{QueryChunk, parallel_queries};

/// Per cloth triangle, the partners its hierarchy leaf overlaps, for the
/// step under way.
#[derive(Clone, Debug, Default)]
pub(super) struct Partners {
    /// Whether the lists hold for the hierarchy's leaves (a speculated
    /// first detection made them this step).
    valid: bool,
    /// `cloth_start[t]..cloth_start[t + 1]` indexes `cloth` for triangle `t`.
    cloth_start: Vec<u32>,
    /// Cloth triangles whose leaves overlapped each one's when listed.
    cloth: Vec<u32>,
    /// Likewise, obstacle triangles.
    obstacle_start: Vec<u32>,
    obstacle: Vec<u32>,
    /// Per cloth triangle: its leaf changed after the lists were made, so
    /// it is queried instead.
    queried: Vec<bool>,
    /// `(triangle, partner)`: a queried triangle's new leaf overlaps the
    /// triangle's leaf, sorted.
    added: Vec<(u32, u32)>,
    /// Scratch of the lists' filling.
    fill: Vec<u32>,
    /// Scratch of [`Self::re_leaf`]'s queries.
    fresh: Vec<(u32, u32)>,
    /// Scratch of [`Self::re_leaf`]'s merge of them into `added`.
    merged: Vec<(u32, u32)>,
}

impl Partners {
    /// Lists the partners of `triangle_count` cloth triangles from the
    /// overlapping leaf pairs `self_pairs` (`(low, high)`) and `mesh_pairs`
    /// (`(obstacle triangle, cloth triangle)`; a few that do not overlap
    /// may be among them).
    pub fn list(&mut self, triangle_count: usize, self_pairs: &[(u32, u32)], mesh_pairs: &[(u32, u32)]) {
        let both_ways = self_pairs.iter().flat_map(|&(a, b)| [(a, b), (b, a)]);
        fill_lists(triangle_count, both_ways, (&mut self.cloth_start, &mut self.cloth), &mut self.fill);
        let by_cloth = mesh_pairs.iter().map(|&(obstacle, cloth)| (cloth, obstacle));
        fill_lists(triangle_count, by_cloth, (&mut self.obstacle_start, &mut self.obstacle), &mut self.fill);
        self.queried.clear();
        self.queried.resize(triangle_count, false);
        self.added.clear();
        self.valid = true;
    }

    /// Forgets the lists (a detection without speculation made the leaves).
    pub fn invalidate(&mut self) {
        self.valid = false;
    }

    /// Whether the lists hold for this step's leaves.
    pub fn valid(&self) -> bool {
        self.valid
    }

    /// Whether triangle `t` is queried rather than read from its lists.
    pub fn queried(&self, t: u32) -> bool {
        self.queried[t as usize]
    }

    /// The cloth triangles whose leaves overlap listed triangle `t`'s
    /// (some perhaps more than once).
    pub fn cloth_of(&self, t: u32) -> impl Iterator<Item = u32> + '_ {
        let t = t as usize;
        let listed = &self.cloth[self.cloth_start[t] as usize..self.cloth_start[t + 1] as usize];
        let from = self.added.partition_point(|&(k, _)| (k as usize) < t);
        let added = self.added[from..].iter().take_while(move |&&(k, _)| k as usize == t);
        listed.iter().copied().chain(added.map(|&(_, partner)| partner))
    }

    /// The obstacle triangles whose leaves overlap listed triangle `t`'s.
    pub fn obstacles_of(&self, t: u32) -> &[u32] {
        let t = t as usize;
        &self.obstacle[self.obstacle_start[t] as usize..self.obstacle_start[t + 1] as usize]
    }

    /// Gives each of the `escaping` triangles (whose real boxes `real` left
    /// their leaves) a new leaf, its real box grown by `margin(t)` (m), in
    /// `leaf_box` and in `bvh`; marks them queried, and adds each to the
    /// lists of the triangles its new leaf meets (queried in parallel
    /// `chunks`; sorted after, so in the same order at any thread count:
    /// only the new entries are sorted, by `sorter`, and merged into those
    /// of the step's earlier detections; sorting them all again at every
    /// detection took 4 % of `pull_through_funnel`'s time).
    pub fn re_leaf(
        &mut self,
        escaping: &[u32],
        (real, leaf_box): (&[Box3], &mut [Box3]),
        margin: impl Fn(u32) -> f64,
        bvh: &mut SweptBvh,
        (chunks, sorter): (&mut Vec<QueryChunk>, &mut PairSorter),
    ) {
        if escaping.is_empty() {
            return;
        }
        for &t in escaping {
            leaf_box[t as usize] = real[t as usize].grown(margin(t));
            self.queried[t as usize] = true;
        }
        bvh.update_leaves(leaf_box, escaping.iter().map(|&t| t as usize));
        let (bvh, leaf_box) = (&*bvh, &*leaf_box);
        parallel_queries(escaping, chunks, &mut self.fresh, |t, hits, met| {
            bvh.overlapping(&leaf_box[t as usize], hits);
            met.extend(hits.iter().filter(|&&h| h != t).map(|&h| (h, t)));
        });
        sorter.sort(&mut self.fresh);
        merge_sorted(self.added.iter().copied(), &self.fresh, &mut self.merged);
        std::mem::swap(&mut self.added, &mut self.merged);
    }
}

/// Compressed lists (`start`, `out`) of `(owner, partner)` entries over
/// `count` owners; `fill` is scratch.
fn fill_lists(
    count: usize,
    entries: impl Iterator<Item = (u32, u32)> + Clone,
    (start, out): (&mut Vec<u32>, &mut Vec<u32>),
    fill: &mut Vec<u32>,
) {
    start.clear();
    start.resize(count + 1, 0);
    for (owner, _) in entries.clone() {
        start[owner as usize + 1] += 1;
    }
    for t in 0..count {
        start[t + 1] += start[t];
    }
    out.clear();
    out.resize(start[count] as usize, 0);
    fill.clear();
    fill.extend_from_slice(&start[..count]);
    for (owner, partner) in entries {
        out[fill[owner as usize] as usize] = partner;
        fill[owner as usize] += 1;
    }
}

/// The overlapping pairs `(low, high)` of cloth triangles with at least one
/// `moved`, sorted: what [`SweptBvh::self_pairs`] gives, restricted to them
/// and to the pairs `keep` accepts.
/// `moved_list` holds the moved triangles in increasing order; the triangles'
/// real `boxes` come first. With `listed` partners a moved triangle still
/// inside its leaf reads its list instead of querying the hierarchy (see
/// [`super::partners`]). The queries' buffers and the sorter's scratch are
/// kept in `scratch`.
pub(super) fn moved_pairs(
    bvh: &SweptBvh,
    (boxes, moved, moved_list): (&[Box3], &[bool], &[u32]),
    listed: Option<&Partners>,
    keep: impl Fn(u32, u32) -> bool + Sync,
    (chunks, sorter): (&mut Vec<QueryChunk>, &mut PairSorter),
    out: &mut Vec<(u32, u32)>,
) {
    parallel_queries(moved_list, chunks, out, |a, hits, pairs| {
        let wanted = |h: u32| {
            h != a && (!moved[h as usize] || a < h) && boxes[h as usize].overlaps(&boxes[a as usize]) && keep(a, h)
        };
        let pair = |h: u32| (a.min(h), a.max(h));
        match listed.filter(|partners| !partners.queried(a)) {
            Some(partners) => pairs.extend(partners.cloth_of(a).filter(|&h| wanted(h)).map(pair)),
            None => {
                bvh.overlapping(&boxes[a as usize], hits);
                pairs.extend(hits.iter().copied().filter(|&h| wanted(h)).map(pair));
            }
        }
    });
    sorter.sort(out);
    // A list may name a partner twice.
    out.dedup();
}
