//! What the renderer draws: triangle meshes with a material and a placement,
//! as plain data. The renderer knows nothing of cloth or colliders.

use std::sync::Arc;

use glam::Mat4;

/// A mesh vertex as the GPU reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    /// Position in the mesh's frame, m.
    pub position: [f32; 3],
    /// Unit normal in the mesh's frame (front side).
    pub normal: [f32; 3],
    /// Texture coordinates.
    pub uv: [f32; 2],
}

/// A surface's look: metallic-roughness PBR with a fabric sheen lobe.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Front-face base colour, linear RGB in 0..1.
    pub base_color: [f32; 3],
    /// Back-face base colour, linear RGB in 0..1 (cloth has two sides).
    pub back_color: [f32; 3],
    /// Metalness, 0..1 (0 for fabrics).
    pub metallic: f32,
    /// Perceptual roughness of the specular lobe, 0..1.
    pub roughness: f32,
    /// Sheen colour, linear RGB in 0..1; black turns the sheen off.
    pub sheen_color: [f32; 3],
    /// Sheen roughness, 0..1.
    pub sheen_roughness: f32,
    /// Spacing of darker grid lines on the XZ plane (a ground), m; 0 for none.
    pub grid_spacing_m: f32,
    /// Base-colour texture (sRGB), multiplied with the base colour.
    pub texture: Option<Arc<image::RgbaImage>>,
    /// Share of the image that shows the base colour unlit, 0..1: a fit
    /// map reads the same in any light (0 for every real material).
    pub unlit: f32,
}

impl Material {
    /// A matte, non-metallic surface without sheen.
    pub fn matte(color: [f32; 3], roughness: f32) -> Material {
        Material {
            base_color: color,
            back_color: color,
            metallic: 0.0,
            roughness,
            sheen_color: [0.0; 3],
            sheen_roughness: 0.5,
            grid_spacing_m: 0.0,
            texture: None,
            unlit: 0.0,
        }
    }
}

/// A triangle mesh to draw.
#[derive(Clone, Debug)]
pub struct DrawMesh {
    /// Name, for reports and GPU labels.
    pub name: String,
    /// Vertices in the mesh's frame.
    pub vertices: Vec<Vertex>,
    /// Triangles, three indices each.
    pub indices: Vec<u32>,
    /// Its look.
    pub material: Material,
    /// Placement of the mesh in the world.
    pub world_from_model: Mat4,
    /// Whether it appears in the shadow map (a ground receives but need not cast).
    pub casts_shadow: bool,
}
