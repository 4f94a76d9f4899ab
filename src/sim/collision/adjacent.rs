//! Cloth triangles that share a vertex, listed once from the topology.
//!
//! Two triangles with a common corner always have overlapping boxes, so on
//! a cloth they are most of the hierarchy's self pairs: on `drape_table`,
//! 125,000 of the 149,000 pairs of a step's first detection. Their common
//! features are never tested against each other, and the others lie an
//! edge's altitude apart until the cloth folds sharply there, which the
//! features' own boxes and face-diagonal slabs tell at once.
//!
//! So the hierarchy's traversals leave such pairs out (a look at the two
//! triangles' corners), and a detection takes them from these lists
//! instead, keeping a pair only when a coarse test of the features it could
//! test passes ([`super::detect`]), which every pair with a test to run
//! passes. The kept pairs are merged into the traversal's sorted pairs, so
//! the narrow phase runs the same tests in the same order as when the
//! traversal listed them all.

/// Whether triangles `a` and `b` (vertex indices) have a corner in common.
pub(super) fn share_a_vertex(a: &[u32; 3], b: &[u32; 3]) -> bool {
    a.iter().any(|v| b.contains(v))
}

/// The filter the hierarchy's traversals pass: whether two of `triangles`
/// (by index) have no corner in common, so that their pair is the
/// traversal's to list and not the adjacent triangles' lists'.
pub(super) fn apart(triangles: &[[u32; 3]]) -> impl Fn(u32, u32) -> bool + Sync + Copy + '_ {
    |a, b| !share_a_vertex(&triangles[a as usize], &triangles[b as usize])
}

/// Where two triangles that share a vertex meet, by corner index: corner
/// `k` of a triangle, and its edge `k`, which runs from corner `k` to
/// corner `k + 1` (mod 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Sharing {
    /// One corner: each triangle's edge opposite it.
    Corner { first_edge: u8, second_edge: u8 },
    /// An edge, from the first's corner `k + 1` to its corner `k + 2`, `k`
    /// being its corner off the edge (`first_corner`); the second's corner
    /// off the edge, and its edges from that corner to the shared edge's
    /// ends: to the first's corner `k + 2` and to its corner `k + 1`.
    Edge { first_corner: u8, second_corner: u8, second_to_far: u8, second_to_near: u8 },
}

impl Sharing {
    /// How triangles `first` and `second` (vertex indices, at least one
    /// in common, not all) meet.
    pub fn of(first: [u32; 3], second: [u32; 3]) -> Self {
        let lacked = |tri: [u32; 3], other: [u32; 3]| (0..3).find(|&k| !other.contains(&tri[k])).unwrap_or(0);
        let shared = |tri: [u32; 3], other: [u32; 3]| (0..3).find(|&k| other.contains(&tri[k])).unwrap_or(0);
        let k1 = lacked(first, second);
        let (near, far) = (first[(k1 + 1) % 3], first[(k1 + 2) % 3]);
        if second.contains(&near) && second.contains(&far) {
            let k2 = lacked(second, first);
            let towards = |end: u32| if second[(k2 + 1) % 3] == end { k2 } else { (k2 + 2) % 3 };
            let byte = |k: usize| k as u8;
            Sharing::Edge {
                first_corner: byte(k1),
                second_corner: byte(k2),
                second_to_far: byte(towards(far)),
                second_to_near: byte(towards(near)),
            }
        } else {
            let opposite = |tri, other| ((shared(tri, other) + 1) % 3) as u8;
            Sharing::Corner { first_edge: opposite(first, second), second_edge: opposite(second, first) }
        }
    }
}

/// Per triangle, the other triangles it shares a vertex with, among the
/// triangles of garments that collide with themselves, and how.
#[derive(Clone, Debug, Default)]
pub(super) struct AdjacentTriangles {
    /// `start[t]..start[t + 1]` indexes `adjacent` and `sharing` for triangle `t`.
    start: Vec<u32>,
    /// The triangles adjacent to each, increasing.
    adjacent: Vec<u32>,
    /// How each meets the triangle it is listed for (that one first).
    sharing: Vec<Sharing>,
    /// The triangles listed, increasing.
    members: Vec<u32>,
}

impl AdjacentTriangles {
    /// The lists of `triangles` over `vertex_count` vertices, for the
    /// triangles `t` with `listed(t)`; the others have empty lists.
    pub fn new(triangles: &[[u32; 3]], vertex_count: usize, listed: impl Fn(usize) -> bool) -> Self {
        let members: Vec<u32> = (0..triangles.len()).filter(|&t| listed(t)).map(|t| t as u32).collect();
        let mut around_start = vec![0u32; vertex_count + 1];
        for &t in &members {
            for &v in &triangles[t as usize] {
                around_start[v as usize + 1] += 1;
            }
        }
        for v in 0..vertex_count {
            around_start[v + 1] += around_start[v];
        }
        let mut fill = around_start.clone();
        let mut around = vec![0u32; around_start[vertex_count] as usize];
        for &t in &members {
            for &v in &triangles[t as usize] {
                around[fill[v as usize] as usize] = t;
                fill[v as usize] += 1;
            }
        }
        let (mut start, mut adjacent, mut sharing) = (vec![0u32; triangles.len() + 1], Vec::new(), Vec::new());
        let mut near = Vec::new();
        for t in 0..triangles.len() {
            near.clear();
            if listed(t) {
                for &v in &triangles[t] {
                    near.extend_from_slice(
                        &around[around_start[v as usize] as usize..around_start[v as usize + 1] as usize],
                    );
                }
                near.sort_unstable();
                near.dedup();
                near.retain(|&other| other as usize != t);
            }
            adjacent.extend_from_slice(&near);
            sharing.extend(near.iter().map(|&other| Sharing::of(triangles[t], triangles[other as usize])));
            start[t + 1] = adjacent.len() as u32;
        }
        AdjacentTriangles { start, adjacent, sharing, members }
    }

    /// The triangles sharing a vertex with triangle `t`, increasing.
    pub fn of(&self, t: u32) -> &[u32] {
        &self.adjacent[self.range(t)]
    }

    /// How each of [`Self::of`]`(t)` meets triangle `t`.
    pub fn sharing_of(&self, t: u32) -> &[Sharing] {
        &self.sharing[self.range(t)]
    }

    /// Where triangle `t`'s lists are.
    fn range(&self, t: u32) -> std::ops::Range<usize> {
        let t = t as usize;
        self.start.get(t + 1).map_or(0..0, |&end| self.start[t] as usize..end as usize)
    }

    /// The triangles listed, increasing.
    pub fn members(&self) -> &[u32] {
        &self.members
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate::grid;

    #[test]
    fn the_lists_hold_exactly_the_listed_triangles_that_share_a_vertex() {
        let grid = grid(1.0, 5);
        let triangles = &grid.triangles;
        // Every third triangle is left out, as a garment without self-collision would be.
        let listed = |t: usize| t % 3 != 1;
        let adjacent = AdjacentTriangles::new(triangles, grid.vertex_count(), listed);
        for t in 0..triangles.len() {
            let expected: Vec<u32> = (0..triangles.len())
                .filter(|&u| listed(t) && listed(u) && u != t && share_a_vertex(&triangles[t], &triangles[u]))
                .map(|u| u as u32)
                .collect();
            assert_eq!(adjacent.of(t as u32), &expected[..], "triangle {t}");
        }
        assert_eq!(adjacent.members().len(), (0..triangles.len()).filter(|&t| listed(t)).count());
        // Away from the border, a triangle of the grid (quads split in
        // alternating directions) touches its three edge neighbours and the
        // triangles around its corners: 12 or 14 in all.
        let all = AdjacentTriangles::new(triangles, grid.vertex_count(), |_| true);
        let interior = |v: u32| (1..4).contains(&(v / 5)) && (1..4).contains(&(v % 5));
        for t in (0..triangles.len()).filter(|&t| triangles[t].iter().all(|&v| interior(v))) {
            assert!([12, 14].contains(&all.of(t as u32).len()), "triangle {t}: {}", all.of(t as u32).len());
        }
    }

    #[test]
    fn sharing_names_the_corners_and_edges_where_two_triangles_meet() {
        // Corner 2 of the first is corner 0 of the second: the edges opposite are 0 and 1.
        assert_eq!(Sharing::of([5, 6, 7], [7, 8, 9]), Sharing::Corner { first_edge: 0, second_edge: 1 });
        // Edge 6-7 is shared; 5 (corner 0) and 8 (corner 2) are off it. The
        // second's edge 2 runs 8 → 7 (the first's corner 2), its edge 1 runs 6 → 8.
        let sharing = Sharing::of([5, 6, 7], [7, 6, 8]);
        assert_eq!(sharing, Sharing::Edge { first_corner: 0, second_corner: 2, second_to_far: 2, second_to_near: 1 });
    }

    #[test]
    fn triangles_share_a_vertex_when_any_corner_is_common() {
        assert!(share_a_vertex(&[0, 1, 2], &[2, 3, 4]));
        assert!(share_a_vertex(&[0, 1, 2], &[1, 0, 5]));
        assert!(!share_a_vertex(&[0, 1, 2], &[3, 4, 5]));
    }
}
