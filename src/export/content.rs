//! What an export holds, whatever the format: every garment, every mesh of
//! every body and every collider as a mesh of its own (topology, UVs,
//! parts with their looks), and each mesh's positions at each exported
//! frame, from the bake's point caches or from the scene's colliders.

use std::ops::Range;
use std::path::PathBuf;

use nalgebra::{Point3, Vector3};

use crate::mesh::normals::vertex_normals;
use crate::mesh::{Part, Surface};
use crate::scene::Scene;
use crate::sim::collision::obstacles::MeshCollider;
use crate::stage::GROUND_HALF_SIZE_M;
use crate::stage::baked::BakedFrames;
use crate::stage::tessellate::shape_mesh;

/// What a mesh is in the scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    /// A simulated garment.
    Garment,
    /// A mesh of an animated body.
    Body,
    /// An obstacle (an analytic shape, a mesh collider, the ground).
    Collider,
}

/// How a surface looks: a PBR material (metallic-roughness, with sheen for cloth).
#[derive(Clone, Debug, PartialEq)]
pub struct Look {
    /// Name, unique in the export.
    pub name: String,
    /// Base colour, linear RGB 0..1.
    pub base_color: [f32; 3],
    /// Perceptual roughness 0..1.
    pub roughness: f32,
    /// Sheen colour (linear RGB) and roughness, for cloth.
    pub sheen: Option<([f32; 3], f32)>,
    /// Base colour texture (an image file), if any.
    pub texture: Option<PathBuf>,
}

/// The triangles of a mesh with one look.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshPart {
    /// Name (the material's, or the mesh's without one).
    pub name: String,
    /// Its triangles in the mesh, in increasing order.
    pub triangles: Vec<usize>,
    /// Its look, an index into [`Content::looks`].
    pub look: usize,
}

/// Where a mesh's positions come from at each frame.
#[derive(Clone, Debug)]
enum Source {
    /// Garment `index` of the bake.
    Garment(usize),
    /// Vertices `vertices` of mesh collider `collider` (a body's mesh, or a whole mesh collider).
    MeshCollider { collider: usize, vertices: Range<usize> },
    /// An analytic collider's mesh in its local frame, placed at each frame.
    Shape { collider: usize, local: Vec<Vector3<f64>> },
    /// Fixed positions (the ground).
    Still(Vec<Vector3<f64>>),
}

/// One exported mesh.
#[derive(Clone, Debug)]
pub struct ExportMesh {
    /// Name, unique in the export (the garment's, `body.part`, the collider's).
    pub name: String,
    /// What it is.
    pub role: Role,
    /// Its vertex count: every frame gives this many positions.
    pub vertex_count: usize,
    /// Triangles, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// UVs (v up, as in OBJ) and, per triangle, each corner's UV; both empty without UVs.
    pub surface: Surface,
    /// Runs of triangles with their looks, covering every triangle.
    pub parts: Vec<MeshPart>,
    source: Source,
}

/// Everything an export writes.
pub struct Content<'a> {
    scene: &'a Scene,
    frames: &'a BakedFrames,
    /// Frames per second.
    pub fps: f64,
    /// The bake's frames exported (frame 0 is the initial state).
    pub frame_numbers: Vec<usize>,
    /// The meshes, garments first, then the bodies, then the colliders.
    pub meshes: Vec<ExportMesh>,
    /// Every look the meshes use.
    pub looks: Vec<Look>,
}

/// Colour of a body mesh without a material (as the viewport draws it), linear RGB.
const BODY_COLOR: [f32; 3] = [0.6, 0.46, 0.38];
/// Colour of the colliders, linear RGB.
const COLLIDER_COLOR: [f32; 3] = [0.5, 0.49, 0.47];

impl<'a> Content<'a> {
    /// The meshes of `scene` (with its bodies when `body`) and the baked
    /// `frames` at `frame_numbers`.
    pub fn new(scene: &'a Scene, frames: &'a BakedFrames, frame_numbers: Vec<usize>, body: bool) -> Content<'a> {
        let mut content =
            Content { scene, frames, fps: scene.fps, frame_numbers, meshes: Vec::new(), looks: Vec::new() };
        content.add_garments();
        if body {
            content.add_bodies();
        }
        content.add_colliders();
        content
    }

    fn look(&mut self, mut look: Look) -> usize {
        let base = look.name.clone();
        let mut n = 1;
        while self.looks.iter().any(|l| l.name == look.name) {
            n += 1;
            look.name = format!("{base}_{n}");
        }
        self.looks.push(look);
        self.looks.len() - 1
    }

    fn add_garments(&mut self) {
        for (index, garment) in self.scene.garments.iter().enumerate() {
            let mesh = &garment.mesh;
            let appearance = garment.appearance().clone();
            let runs = parts_or_whole(&garment.name, &mesh.surface.parts, mesh.triangles.len());
            let mut parts: Vec<(Option<usize>, MeshPart)> = Vec::new();
            for run in runs {
                let faces = run.first_triangle..run.first_triangle + run.triangle_count;
                if let Some((_, part)) = parts.iter_mut().find(|(m, _)| *m == run.material) {
                    part.triangles.extend(faces);
                    continue;
                }
                let material = run.material.and_then(|m| mesh.surface.materials.get(m));
                let name = material.map_or(garment.name.clone(), |m| format!("{}_{}", garment.name, m.name));
                let look = self.look(Look {
                    name: name.clone(),
                    base_color: material.map_or(appearance.base_color, |m| m.diffuse),
                    roughness: appearance.roughness,
                    sheen: Some((appearance.sheen_color, appearance.sheen_roughness)),
                    texture: material.and_then(|m| m.diffuse_texture.clone()),
                });
                parts.push((run.material, MeshPart { name, triangles: faces.collect(), look }));
            }
            let parts = parts.into_iter().map(|(_, part)| part).collect();
            self.meshes.push(ExportMesh {
                name: garment.name.clone(),
                role: Role::Garment,
                vertex_count: mesh.vertex_count(),
                triangles: mesh.triangles.clone(),
                surface: mesh.surface.clone(),
                parts,
                source: Source::Garment(index),
            });
        }
    }

    fn add_bodies(&mut self) {
        for body in &self.scene.bodies {
            let Some(collider) = self.scene.mesh_colliders.get(body.collider) else { continue };
            let single = body.loaded.parts.len() == 1;
            for part in &body.loaded.parts {
                let name = if single { collider.name.clone() } else { format!("{}_{}", collider.name, part.name) };
                let mesh = self.sub_mesh(
                    name,
                    collider,
                    body.collider,
                    &body.surface,
                    part.vertices.clone(),
                    part.triangles.clone(),
                );
                self.meshes.push(mesh);
            }
        }
    }

    /// Vertices `vertices` and triangles `triangles` of a mesh collider as a mesh of their own.
    fn sub_mesh(
        &mut self,
        name: String,
        collider: &MeshCollider,
        index: usize,
        surface: &Surface,
        vertices: Range<usize>,
        triangles: Range<usize>,
    ) -> ExportMesh {
        let first = vertices.start as u32;
        let local: Vec<[u32; 3]> = collider
            .triangles
            .get(triangles.clone())
            .unwrap_or_default()
            .iter()
            .map(|t| t.map(|v| v - first))
            .collect();
        let mut own = Surface::default();
        if surface.triangle_uvs.len() >= triangles.end {
            own.uvs = surface.uvs.clone();
            own.triangle_uvs = surface.triangle_uvs[triangles.clone()].to_vec();
        }
        let runs = parts_or_whole(&name, &surface.parts, collider.triangles.len());
        let mut parts: Vec<MeshPart> = Vec::new();
        for run in runs {
            let (start, end) =
                (run.first_triangle.max(triangles.start), (run.first_triangle + run.triangle_count).min(triangles.end));
            if start >= end {
                continue;
            }
            let material = run.material.and_then(|m| surface.materials.get(m));
            let look_name = material.map_or(name.clone(), |m| m.name.clone());
            let look = self.shared_look(&look_name, material.map_or(BODY_COLOR, |m| m.diffuse));
            let faces = start - triangles.start..end - triangles.start;
            match parts.iter_mut().find(|p| p.look == look) {
                Some(part) => part.triangles.extend(faces),
                None => parts.push(MeshPart { name: look_name, triangles: faces.collect(), look }),
            }
        }
        ExportMesh {
            name,
            role: Role::Body,
            vertex_count: vertices.len(),
            triangles: local,
            surface: own,
            parts,
            source: Source::MeshCollider { collider: index, vertices },
        }
    }

    /// A matte look of `name` and `color`, made once and shared.
    fn shared_look(&mut self, name: &str, color: [f32; 3]) -> usize {
        match self.looks.iter().position(|l| l.name == name && l.base_color == color) {
            Some(i) => i,
            None => self.look(Look {
                name: name.to_owned(),
                base_color: color,
                roughness: 0.55,
                sheen: None,
                texture: None,
            }),
        }
    }

    fn add_colliders(&mut self) {
        let bodies: Vec<usize> = self.scene.bodies.iter().map(|b| b.collider).collect();
        for (index, collider) in self.scene.mesh_colliders.iter().enumerate().filter(|(i, _)| !bodies.contains(i)) {
            let all = 0..collider.vertices.len();
            let mut mesh = self.sub_mesh(
                collider.name.clone(),
                collider,
                index,
                &Surface::default(),
                all,
                0..collider.triangles.len(),
            );
            mesh.role = Role::Collider;
            self.meshes.push(mesh);
        }
        for (index, collider) in self.scene.colliders.iter().enumerate() {
            let (local, triangles) = match shape_mesh(&collider.shape) {
                Some(shape) => {
                    let local = shape.vertices.iter().map(|v| Vector3::from(v.position.map(f64::from))).collect();
                    (
                        Source::Shape { collider: index, local },
                        shape.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
                    )
                }
                None => ground(&collider.world_from_local(0.0)),
            };
            let look = self.shared_look(&collider.name, COLLIDER_COLOR);
            let vertex_count = match &local {
                Source::Shape { local, .. } | Source::Still(local) => local.len(),
                _ => 0,
            };
            let parts = vec![MeshPart { name: collider.name.clone(), triangles: (0..triangles.len()).collect(), look }];
            self.meshes.push(ExportMesh {
                name: collider.name.clone(),
                role: Role::Collider,
                vertex_count,
                triangles,
                surface: Surface::default(),
                parts,
                source: local,
            });
        }
    }

    /// Time of bake frame `frame`, s.
    pub fn time(&self, frame: usize) -> f64 {
        frame as f64 / self.fps
    }

    /// Mesh `mesh`'s positions at bake frame `frame`, m, into `out`.
    pub fn positions(&self, mesh: usize, frame: usize, out: &mut Vec<Vector3<f64>>) {
        out.clear();
        let t = self.time(frame);
        match &self.meshes[mesh].source {
            Source::Garment(g) => {
                let points = self.frames.garment(*g, frame).unwrap_or_default();
                out.extend(points.iter().map(|p| Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))));
            }
            Source::MeshCollider { collider, vertices } => {
                let Some(c) = self.scene.mesh_colliders.get(*collider) else { return };
                let pose = c.placement.world_from_local(t);
                out.extend(vertices.clone().map(|v| (pose * Point3::from(c.local_vertex(v, t))).coords));
            }
            Source::Shape { collider, local } => {
                let Some(c) = self.scene.colliders.get(*collider) else { return };
                let pose = c.world_from_local(t);
                out.extend(local.iter().map(|p| (pose * Point3::from(*p)).coords));
            }
            Source::Still(points) => out.extend(points),
        }
    }

    /// Area-weighted vertex normals of mesh `mesh` at `positions`.
    pub fn normals(&self, mesh: usize, positions: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        vertex_normals(positions, &self.meshes[mesh].triangles)
    }

    /// Whether mesh `mesh` moves (garments and animated or moving colliders).
    pub fn moves(&self, mesh: usize) -> bool {
        match &self.meshes[mesh].source {
            Source::Garment(_) => true,
            Source::MeshCollider { collider, .. } => self
                .scene
                .mesh_colliders
                .get(*collider)
                .is_some_and(|c| c.animation.is_some() || c.placement.motion.is_some()),
            Source::Shape { collider, .. } => {
                self.scene.colliders.get(*collider).is_some_and(|c| c.placement.motion.is_some())
            }
            Source::Still(_) => false,
        }
    }
}

/// A mesh's parts, or one part over its `triangle_count` triangles named `name`.
fn parts_or_whole(name: &str, parts: &[Part], triangle_count: usize) -> Vec<Part> {
    match parts.is_empty() {
        true => vec![Part { name: name.to_owned(), material: None, first_triangle: 0, triangle_count }],
        false => parts.to_vec(),
    }
}

/// The ground: a square of the viewport's size on the plane, as still positions.
fn ground(pose: &nalgebra::Isometry3<f64>) -> (Source, Vec<[u32; 3]>) {
    let h = f64::from(GROUND_HALF_SIZE_M);
    let corners = [[-h, -h], [h, -h], [h, h], [-h, h]];
    let points = corners.iter().map(|&[x, z]| (pose * Point3::new(x, 0.0, z)).coords).collect();
    (Source::Still(points), vec![[0, 2, 1], [0, 3, 2]])
}
