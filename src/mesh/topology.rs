//! Connectivity of a triangle mesh: unique edges, their incident triangles, and
//! the hinges (interior edges with their two opposite vertices) that carry bending.

/// An undirected edge and the triangles that use it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    /// End vertices, smaller index first.
    pub vertices: [u32; 2],
    /// Up to two incident triangles; `u32::MAX` marks an absent second one.
    pub triangles: [u32; 2],
    /// Number of incident triangles (1 on the boundary, 2 inside, more when
    /// the edge is non-manifold).
    pub triangle_count: u32,
}

impl Edge {
    /// True when exactly two triangles share the edge.
    pub fn is_interior(&self) -> bool {
        self.triangle_count == 2
    }
}

/// Two triangles sharing an interior edge: the stencil of one bending element.
///
/// `edge` runs from `edge[0]` to `edge[1]`; `opposite[0]` closes the first triangle,
/// `opposite[1]` the second.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Hinge {
    /// The shared edge.
    pub edge: [u32; 2],
    /// The vertex opposite the edge in each of the two triangles.
    pub opposite: [u32; 2],
}

/// Edges and hinges of a triangle mesh, in a deterministic order (sorted by
/// vertex pair).
#[derive(Clone, Debug, Default)]
pub struct Topology {
    /// Every undirected edge once.
    pub edges: Vec<Edge>,
    /// One hinge per interior (two-triangle) edge.
    pub hinges: Vec<Hinge>,
    /// Interior edges whose two triangles traverse them in the same direction,
    /// i.e. whose winding disagrees.
    pub inconsistent_windings: usize,
}

impl Topology {
    /// Builds the topology of `triangles` (indices into a vertex array).
    pub fn new(triangles: &[[u32; 3]]) -> Self {
        let mut half_edges: Vec<(u32, u32, u32)> = Vec::with_capacity(triangles.len() * 3);
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                half_edges.push((a.min(b), a.max(b), t as u32));
            }
        }
        half_edges.sort_unstable();

        let mut topology = Topology::default();
        let mut run_start = 0;
        while run_start < half_edges.len() {
            let (a, b, first) = half_edges[run_start];
            let run_end = run_start + half_edges[run_start..].iter().take_while(|h| (h.0, h.1) == (a, b)).count();
            let count = (run_end - run_start) as u32;
            let second = if count >= 2 { half_edges[run_start + 1].2 } else { u32::MAX };
            let edge = Edge { vertices: [a, b], triangles: [first, second], triangle_count: count };
            if edge.is_interior() {
                topology.add_hinge(triangles, &edge);
            }
            topology.edges.push(edge);
            run_start = run_end;
        }
        topology
    }

    fn add_hinge(&mut self, triangles: &[[u32; 3]], edge: &Edge) {
        let [t0, t1] = edge.triangles.map(|t| triangles[t as usize]);
        let [a, b] = edge.vertices;
        let forward_in_t0 = runs_forward(&t0, a, b);
        if forward_in_t0 == runs_forward(&t1, a, b) {
            self.inconsistent_windings += 1;
        }
        // Orient the hinge edge as the first triangle traverses it.
        let edge_dir = if forward_in_t0 { [a, b] } else { [b, a] };
        self.hinges.push(Hinge { edge: edge_dir, opposite: [third_vertex(&t0, a, b), third_vertex(&t1, a, b)] });
    }

    /// Number of edges shared by more than two triangles.
    pub fn non_manifold_edges(&self) -> usize {
        self.edges.iter().filter(|e| e.triangle_count > 2).count()
    }

    /// Number of boundary edges (one incident triangle).
    pub fn boundary_edges(&self) -> usize {
        self.edges.iter().filter(|e| e.triangle_count == 1).count()
    }
}

/// True when triangle `tri` visits `a` then `b` in its counter-clockwise order.
fn runs_forward(tri: &[u32; 3], a: u32, b: u32) -> bool {
    (0..3).any(|k| tri[k] == a && tri[(k + 1) % 3] == b)
}

/// The corner of `tri` that is neither `a` nor `b`.
fn third_vertex(tri: &[u32; 3], a: u32, b: u32) -> u32 {
    tri.iter().copied().find(|&v| v != a && v != b).unwrap_or(tri[0])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two triangles forming a unit square: one interior edge (0, 2).
    const SQUARE: [[u32; 3]; 2] = [[0, 1, 2], [0, 2, 3]];

    #[test]
    fn square_has_five_edges_and_one_hinge() {
        let topo = Topology::new(&SQUARE);
        assert_eq!(topo.edges.len(), 5);
        assert_eq!(topo.boundary_edges(), 4);
        assert_eq!(topo.hinges.len(), 1);
        let hinge = topo.hinges[0];
        assert_eq!(hinge.edge, [2, 0], "oriented as the first triangle runs it");
        assert_eq!(hinge.opposite, [1, 3]);
        assert_eq!(topo.inconsistent_windings, 0);
    }

    #[test]
    fn flipped_triangle_is_reported_as_inconsistent_winding() {
        let topo = Topology::new(&[[0, 1, 2], [0, 3, 2]]);
        assert_eq!(topo.inconsistent_windings, 1);
    }

    #[test]
    fn three_triangles_on_one_edge_are_non_manifold_and_make_no_hinge() {
        let topo = Topology::new(&[[0, 1, 2], [1, 0, 3], [0, 1, 4]]);
        assert_eq!(topo.non_manifold_edges(), 1);
        assert!(topo.hinges.is_empty());
    }
}
