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
//! instead, keeping a pair only when one of its feature pairs passes its
//! culls ([`super::detect`]). Every pair that has a test to run is kept, and
//! the kept pairs are merged into the traversal's sorted pairs, so the
//! narrow phase runs the same tests in the same order as when the
//! traversal listed them all.

/// Whether triangles `a` and `b` (vertex indices) have a corner in common.
pub(super) fn share_a_vertex(a: &[u32; 3], b: &[u32; 3]) -> bool {
    a.iter().any(|v| b.contains(v))
}

/// Per triangle, the other triangles it shares a vertex with, among the
/// triangles of garments that collide with themselves.
#[derive(Clone, Debug, Default)]
pub(super) struct AdjacentTriangles {
    /// `start[t]..start[t + 1]` indexes `adjacent` for triangle `t`.
    start: Vec<u32>,
    /// The triangles adjacent to each, increasing.
    adjacent: Vec<u32>,
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
        let (mut start, mut adjacent) = (vec![0u32; triangles.len() + 1], Vec::new());
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
            start[t + 1] = adjacent.len() as u32;
        }
        AdjacentTriangles { start, adjacent, members }
    }

    /// The triangles sharing a vertex with triangle `t`, increasing.
    pub fn of(&self, t: u32) -> &[u32] {
        let t = t as usize;
        self.start.get(t + 1).map_or(&[], |&end| &self.adjacent[self.start[t] as usize..end as usize])
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
    fn triangles_share_a_vertex_when_any_corner_is_common() {
        assert!(share_a_vertex(&[0, 1, 2], &[2, 3, 4]));
        assert!(share_a_vertex(&[0, 1, 2], &[1, 0, 5]));
        assert!(!share_a_vertex(&[0, 1, 2], &[3, 4, 5]));
    }
}
