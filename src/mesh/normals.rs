//! Vertex normals from positions.

use nalgebra::Vector3;

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
}
