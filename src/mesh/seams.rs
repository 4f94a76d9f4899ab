//! A mesh split at its UV seams, as renderers and interchange formats want
//! it: one vertex per distinct (position, UV) corner, so texture seams stay
//! sharp while each new vertex still says which welded vertex it follows.

use std::collections::HashMap;
use std::ops::Range;

use super::TriMesh;

/// Some triangles of a mesh with their corners split at UV seams.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SeamSplit {
    /// Per split vertex, the mesh vertex it follows.
    pub vertices: Vec<u32>,
    /// Per split vertex, its UV as the mesh stores it (v up, as in OBJ);
    /// `[0, 0]` when the mesh has none.
    pub uvs: Vec<[f32; 2]>,
    /// Triangles as split-vertex indices, three per triangle.
    pub indices: Vec<u32>,
}

/// Splits the mesh's `triangles` at their UV seams (the corners of one
/// vertex with different UVs become different vertices), in the order the
/// triangles first use them.
pub fn split_at_uv_seams(mesh: &TriMesh, triangles: Range<usize>) -> SeamSplit {
    let surface = &mesh.surface;
    let mut index_of: HashMap<(u32, u32), u32> = HashMap::new();
    let mut split = SeamSplit::default();
    for t in triangles.filter(|&t| t < mesh.triangles.len()) {
        for k in 0..3 {
            let v = mesh.triangles[t][k];
            let uv_index = surface.triangle_uvs.get(t).map_or(u32::MAX, |uvs| uvs[k]);
            let next = split.vertices.len() as u32;
            let id = *index_of.entry((v, uv_index)).or_insert_with(|| {
                split.uvs.push(surface.uvs.get(uv_index as usize).copied().unwrap_or([0.0; 2]));
                split.vertices.push(v);
                next
            });
            split.indices.push(id);
        }
    }
    split
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;
    use crate::mesh::Surface;

    #[test]
    fn a_vertex_on_a_seam_becomes_one_vertex_per_uv() {
        // Two triangles sharing edge 1-2; vertex 2 has another UV in the second.
        let mesh = TriMesh {
            positions: vec![Vector3::zeros(); 4],
            triangles: vec![[0, 1, 2], [2, 1, 3]],
            quads: Vec::new(),
            surface: Surface {
                uvs: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, 0.5]],
                triangle_uvs: vec![[0, 1, 2], [4, 1, 3]],
                ..Default::default()
            },
        };
        let split = split_at_uv_seams(&mesh, 0..2);
        assert_eq!(split.vertices, [0, 1, 2, 2, 3]);
        assert_eq!(split.indices, [0, 1, 2, 3, 1, 4]);
        assert_eq!(split.uvs[3], [0.5, 0.5]);
        // Without UVs, vertices are shared as they are.
        let plain = TriMesh { surface: Surface::default(), ..mesh };
        assert_eq!(split_at_uv_seams(&plain, 0..2).vertices, [0, 1, 2, 3]);
    }
}
