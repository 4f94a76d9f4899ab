//! Representative triangles (Curtis, Tamstorf and Manocha 2008; PAPER Fig. 7
//! and Algorithm 1): every vertex and every edge of a mesh is owned by exactly
//! one of its incident triangles, so that when two triangles' boxes overlap
//! they test only the features they own and each elementary test runs once.
//!
//! Without ownership, a feature is tested once from every triangle it belongs
//! to: when two features' boxes overlap, so do the boxes of every triangle
//! holding them, and each such pair of triangles is a candidate. The count of
//! tests that would take is therefore each owned test weighted by how many
//! triangles share each of its two features, which the step report gives
//! without running or box-testing the unowned features.

use std::collections::HashMap;

/// Features a triangle owns: bit `k` (0..3) for corner `k`, bit `3 + k` for the
/// edge from corner `k` to corner `(k + 1) % 3`.
pub type Owned = u8;

/// Ownership of every triangle of a mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Ownership {
    /// Per triangle, the features it owns.
    pub owned: Vec<Owned>,
    /// Per triangle, for each feature it owns (corners 0..3, then edges
    /// 3..6), how many triangles would test it without ownership: the
    /// triangles sharing it. 1 where the triangle owns everything.
    sharing: Vec<[u32; 6]>,
}

impl Ownership {
    /// Assigns each vertex and each edge to its first incident triangle.
    pub fn new(triangles: &[[u32; 3]], vertex_count: usize) -> Self {
        let mut vertex_triangles = vec![0u32; vertex_count];
        let mut edge_triangles: HashMap<(u32, u32), u32> = HashMap::new();
        for tri in triangles {
            for k in 0..3 {
                vertex_triangles[tri[k] as usize] += 1;
                *edge_triangles.entry(edge_key(*tri, k)).or_insert(0) += 1;
            }
        }
        let mut vertex_taken = vec![false; vertex_count];
        let mut edge_taken = std::collections::HashSet::new();
        let (owned, sharing) = triangles
            .iter()
            .map(|tri| {
                let (mut bits, mut sharing) = (0, [0; 6]);
                for k in 0..3 {
                    let v = tri[k] as usize;
                    if !vertex_taken[v] {
                        vertex_taken[v] = true;
                        bits |= 1 << k;
                        sharing[k] = vertex_triangles[v];
                    }
                    let edge = edge_key(*tri, k);
                    if edge_taken.insert(edge) {
                        bits |= 1 << (3 + k);
                        sharing[3 + k] = edge_triangles[&edge];
                    }
                }
                (bits, sharing)
            })
            .unzip();
        Ownership { owned, sharing }
    }

    /// Every triangle owns all its features: what testing without
    /// representative triangles amounts to (each shared feature tested once
    /// per incident triangle).
    pub fn everything(triangle_count: usize) -> Self {
        Ownership { owned: vec![0b11_1111; triangle_count], sharing: vec![[1; 6]; triangle_count] }
    }

    /// Corners `k` of triangle `t` whose vertex it owns.
    pub fn vertices(&self, t: usize) -> impl Iterator<Item = usize> + '_ {
        (0..3).filter(move |k| self.owned[t] & (1 << k) != 0)
    }

    /// Edges `k` (corner `k` to `k + 1`) of triangle `t` that it owns.
    pub fn edges(&self, t: usize) -> impl Iterator<Item = usize> + '_ {
        (0..3).filter(move |k| self.owned[t] & (1 << (3 + k)) != 0)
    }

    /// How many times corner `k` of triangle `t`, which it owns, would be
    /// tested without ownership (the triangles sharing its vertex).
    pub fn vertex_sharing(&self, t: usize, k: usize) -> u32 {
        self.sharing[t][k]
    }

    /// How many times edge `k` of triangle `t`, which it owns, would be
    /// tested without ownership (the triangles sharing it).
    pub fn edge_sharing(&self, t: usize, k: usize) -> u32 {
        self.sharing[t][3 + k]
    }
}

/// Edge `k → k + 1` of `tri` by its points, lower first.
fn edge_key(tri: [u32; 3], k: usize) -> (u32, u32) {
    let (a, b) = (tri[k], tri[(k + 1) % 3]);
    (a.min(b), a.max(b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;
    use crate::mesh::topology::Topology;

    #[test]
    fn every_vertex_and_edge_is_owned_exactly_once() {
        for mesh in [generate::grid(1.0, 9), generate::tube(0.1, 1.0, 12, 7)] {
            let ownership = Ownership::new(&mesh.triangles, mesh.vertex_count());
            let mut vertex_owners = vec![0; mesh.vertex_count()];
            let mut edge_owners = std::collections::HashMap::new();
            for (t, tri) in mesh.triangles.iter().enumerate() {
                for k in ownership.vertices(t) {
                    vertex_owners[tri[k] as usize] += 1;
                }
                for k in ownership.edges(t) {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    *edge_owners.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                }
            }
            assert!(vertex_owners.iter().all(|&c| c == 1));
            let mut incident = vec![0; mesh.vertex_count()];
            mesh.triangles.iter().flatten().for_each(|&v| incident[v as usize] += 1);
            for (t, tri) in mesh.triangles.iter().enumerate() {
                for k in ownership.vertices(t) {
                    assert_eq!(ownership.vertex_sharing(t, k), incident[tri[k] as usize]);
                }
            }
            let edges = Topology::new(&mesh.triangles).edges;
            assert_eq!(edge_owners.len(), edges.len());
            assert!(edge_owners.values().all(|&c| c == 1));
            // Every triangle's three edges, each counted once by its owner
            // with the triangles sharing it.
            let shared_edges: u32 = (0..mesh.triangles.len())
                .flat_map(|t| ownership.edges(t).map(move |k| (t, k)))
                .map(|(t, k)| ownership.edge_sharing(t, k))
                .sum();
            assert_eq!(shared_edges as usize, 3 * mesh.triangles.len());
        }
    }
}
