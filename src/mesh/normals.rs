//! Vertex normals from positions.

use nalgebra::Vector3;
use rayon::prelude::*;

/// Area-weighted vertex normals (unit length; zero for a vertex whose triangles
/// all have zero area). Each triangle adds its unnormalised cross product, whose
/// length is twice its area, to its three corners.
pub fn vertex_normals(positions: &[Vector3<f64>], triangles: &[[u32; 3]]) -> Vec<Vector3<f64>> {
    let mut normals = vec![Vector3::zeros(); positions.len()];
    for &[a, b, c] in triangles {
        let [pa, pb, pc] = [a, b, c].map(|i| positions[i as usize]);
        let weighted = (pb - pa).cross(&(pc - pa));
        for i in [a, b, c] {
            normals[i as usize] += weighted;
        }
    }
    for n in &mut normals {
        *n = n.try_normalize(0.0).unwrap_or_else(Vector3::zeros);
    }
    normals
}

/// The triangles around each vertex (compressed rows), built once from the
/// topology, so that vertex normals can be recomputed every frame in parallel.
#[derive(Clone, Debug, Default)]
pub struct VertexTriangles {
    /// Row starts: vertex `v`'s triangles are `triangles[offsets[v]..offsets[v + 1]]`.
    offsets: Vec<u32>,
    /// Triangle indices, ascending within each row.
    triangles: Vec<u32>,
}

impl VertexTriangles {
    /// The incidence of `triangles` over `vertex_count` vertices.
    pub fn new(triangles: &[[u32; 3]], vertex_count: usize) -> Self {
        let mut offsets = vec![0u32; vertex_count + 1];
        for t in triangles {
            for &v in t {
                offsets[v as usize + 1] += 1;
            }
        }
        for v in 0..vertex_count {
            offsets[v + 1] += offsets[v];
        }
        let mut next = offsets.clone();
        let mut rows = vec![0u32; offsets[vertex_count] as usize];
        for (t, corners) in triangles.iter().enumerate() {
            for &v in corners {
                rows[next[v as usize] as usize] = t as u32;
                next[v as usize] += 1;
            }
        }
        VertexTriangles { offsets, triangles: rows }
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    /// Area-weighted unit vertex normals of `positions` (zero where every
    /// triangle around a vertex is degenerate), parallel over triangles and then
    /// vertices. Each vertex sums its triangles in ascending order, so the result
    /// is the same at any thread count and equals [`vertex_normals`].
    pub fn normals(&self, positions: &[Vector3<f64>], triangles: &[[u32; 3]]) -> Vec<Vector3<f64>> {
        let weighted: Vec<Vector3<f64>> = triangles
            .par_iter()
            .map(|&[a, b, c]| {
                let [pa, pb, pc] = [a, b, c].map(|i| positions[i as usize]);
                (pb - pa).cross(&(pc - pa))
            })
            .collect();
        self.offsets
            .par_windows(2)
            .map(|row| {
                let around = &self.triangles[row[0] as usize..row[1] as usize];
                let sum = around.iter().fold(Vector3::zeros(), |s, &t| s + weighted[t as usize]);
                sum.try_normalize(0.0).unwrap_or_else(Vector3::zeros)
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn flat_grid_normals_point_up() {
        let mesh = generate::grid(1.0, 4);
        for n in vertex_normals(&mesh.positions, &mesh.triangles) {
            assert!((n - Vector3::y()).norm() < 1e-12);
        }
    }

    #[test]
    fn normals_weight_triangles_by_area() {
        // Vertex 0 joins a large triangle facing +z and a small one facing +x.
        let positions =
            [Vector3::zeros(), Vector3::new(2.0, 0.0, 0.0), Vector3::new(0.0, 2.0, 0.0), Vector3::new(0.0, 0.0, 0.1)];
        let triangles = [[0, 1, 2], [0, 2, 3]];
        let n = vertex_normals(&positions, &triangles)[0];
        let expected = Vector3::new(0.2, 0.0, 4.0).normalize();
        assert!((n - expected).norm() < 1e-12);
    }

    #[test]
    fn parallel_normals_equal_the_serial_ones_bit_for_bit() {
        let mut mesh = generate::grid(1.0, 12);
        for (i, p) in mesh.positions.iter_mut().enumerate() {
            p.y = (i as f64 * 0.37).sin() * 0.05;
        }
        let around = VertexTriangles::new(&mesh.triangles, mesh.vertex_count());
        assert_eq!(around.normals(&mesh.positions, &mesh.triangles), vertex_normals(&mesh.positions, &mesh.triangles));
    }
}
