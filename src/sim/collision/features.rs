//! Representative triangles (Curtis, Tamstorf and Manocha 2008; PAPER Fig. 7
//! and Algorithm 1): every vertex and every edge of a mesh is owned by exactly
//! one of its incident triangles, so that when two triangles' boxes overlap
//! they test only the features they own and each elementary test runs once.

/// Features a triangle owns: bit `k` (0..3) for corner `k`, bit `3 + k` for the
/// edge from corner `k` to corner `(k + 1) % 3`.
pub type Owned = u8;

/// Ownership of every triangle of a mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Ownership {
    /// Per triangle, the features it owns.
    pub owned: Vec<Owned>,
}

impl Ownership {
    /// Assigns each vertex and each edge to its first incident triangle.
    pub fn new(triangles: &[[u32; 3]], vertex_count: usize) -> Self {
        let mut vertex_taken = vec![false; vertex_count];
        let mut edge_taken = std::collections::HashSet::new();
        let owned = triangles
            .iter()
            .map(|tri| {
                let mut bits = 0;
                for k in 0..3 {
                    let v = tri[k] as usize;
                    if !vertex_taken[v] {
                        vertex_taken[v] = true;
                        bits |= 1 << k;
                    }
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    if edge_taken.insert((a.min(b), a.max(b))) {
                        bits |= 1 << (3 + k);
                    }
                }
                bits
            })
            .collect();
        Ownership { owned }
    }

    /// Every triangle owns all its features: what testing without
    /// representative triangles amounts to (each shared feature tested once
    /// per incident triangle).
    pub fn everything(triangle_count: usize) -> Self {
        Ownership { owned: vec![0b11_1111; triangle_count] }
    }

    /// Corners `k` of triangle `t` whose vertex it owns.
    pub fn vertices(&self, t: usize) -> impl Iterator<Item = usize> + '_ {
        (0..3).filter(move |k| self.owned[t] & (1 << k) != 0)
    }

    /// Edges `k` (corner `k` to `k + 1`) of triangle `t` that it owns.
    pub fn edges(&self, t: usize) -> impl Iterator<Item = usize> + '_ {
        (0..3).filter(move |k| self.owned[t] & (1 << (3 + k)) != 0)
    }
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
            let edges = Topology::new(&mesh.triangles).edges;
            assert_eq!(edge_owners.len(), edges.len());
            assert!(edge_owners.values().all(|&c| c == 1));
        }
    }
}
