//! Triangle meshes as the simulator and the exporters see them.
//!
//! A [`TriMesh`] holds one vertex per physical point of the cloth (vertices that
//! a file split at UV seams or between groups are welded), the triangles, the
//! quads the source had (their diagonals become shear springs), and the
//! [`Surface`] attributes (UVs, materials, named parts) that rendering and export
//! keep per triangle corner.

pub mod generate;
pub mod normals;
pub mod seams;
pub mod topology;
pub mod validate;
pub mod weld;

use nalgebra::Vector3;

/// A triangle mesh: welded vertex positions, triangles, source quads and surface
/// attributes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    /// Vertex positions, metres.
    pub positions: Vec<Vector3<f64>>,
    /// Triangles as vertex indices, counter-clockwise seen from the front side.
    pub triangles: Vec<[u32; 3]>,
    /// Quads of the source, corners in order around the quad. Each quad is also
    /// present as the two triangles `(a, b, c)` and `(a, c, d)`.
    pub quads: Vec<[u32; 4]>,
    /// Render and export attributes, per triangle corner.
    pub surface: Surface,
}

/// Attributes that live on triangle corners rather than on physical vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Surface {
    /// Texture coordinates (u, v), unitless.
    pub uvs: Vec<[f32; 2]>,
    /// Per triangle, the UV index of each corner; empty when the mesh has no UVs.
    pub triangle_uvs: Vec<[u32; 3]>,
    /// Materials referenced by parts.
    pub materials: Vec<Material>,
    /// Named, contiguous runs of triangles (OBJ objects or groups).
    pub parts: Vec<Part>,
}

/// A named run of triangles with one material.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// Name from the source file (OBJ `o`/`g`), or a generated one.
    pub name: String,
    /// Index into [`Surface::materials`], if the part has a material.
    pub material: Option<usize>,
    /// First triangle of the part.
    pub first_triangle: usize,
    /// Number of triangles in the part.
    pub triangle_count: usize,
}

/// A surface material as read from an MTL file.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Material name (`newmtl`).
    pub name: String,
    /// Diffuse (base) colour, linear RGB in 0..1.
    pub diffuse: [f32; 3],
    /// Diffuse texture file (`map_Kd`), resolved against the MTL's folder.
    pub diffuse_texture: Option<std::path::PathBuf>,
}

impl TriMesh {
    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Corner positions of triangle `t`, metres.
    pub fn triangle_corners(&self, t: usize) -> [Vector3<f64>; 3] {
        let [a, b, c] = self.triangles[t];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Area of triangle `t`, square metres.
    pub fn triangle_area(&self, t: usize) -> f64 {
        let [a, b, c] = self.triangle_corners(t);
        0.5 * (b - a).cross(&(c - a)).norm()
    }

    /// Total surface area, square metres.
    pub fn area(&self) -> f64 {
        (0..self.triangles.len()).map(|t| self.triangle_area(t)).sum()
    }

    /// Axis-aligned bounds `(min, max)` of the vertices, metres; `None` when empty.
    pub fn bounds(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        let first = *self.positions.first()?;
        Some(self.positions.iter().fold((first, first), |(lo, hi), p| (lo.inf(p), hi.sup(p))))
    }

    /// Reorders the vertices by `key` (stable: equal keys keep their order),
    /// renumbering triangles and quads.
    pub fn sort_vertices_by(&mut self, key: &[usize]) {
        let mut order: Vec<usize> = (0..self.positions.len()).collect();
        order.sort_by_key(|&v| key[v]);
        let mut new_index = vec![0u32; order.len()];
        for (new, &old) in order.iter().enumerate() {
            new_index[old] = new as u32;
        }
        self.positions = order.iter().map(|&old| self.positions[old]).collect();
        for tri in &mut self.triangles {
            *tri = tri.map(|v| new_index[v as usize]);
        }
        for quad in &mut self.quads {
            *quad = quad.map(|v| new_index[v as usize]);
        }
    }

    /// Applies `world_from_model` (scale, then rotation, then translation) to every
    /// vertex.
    pub fn transform(&mut self, world_from_model: &nalgebra::Similarity3<f64>) {
        for p in &mut self.positions {
            *p = world_from_model.transform_point(&(*p).into()).coords;
        }
    }
}
