//! The scene as the renderer sees it: each garment as meshes whose vertices
//! follow the simulated (or baked) positions, with normals recomputed every
//! frame; the colliders tessellated and placed at the frame's time; a ground
//! where the scene has a plane; the camera from the scene file or framed on
//! the first frame.
//!
//! This is the only place that knows both the scene and the renderer: the
//! renderer draws plain meshes, the simulation knows nothing of drawing.

pub mod baked;
pub mod figure;
pub mod fit_map;
pub mod legend;
pub mod offscreen;
pub mod tessellate;

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use glam::{Mat4, Vec3};
use nalgebra::{Isometry3, Vector3};

use self::figure::FigurePath;
use self::tessellate::shape_mesh;
use crate::mesh::normals::{VertexTriangles, vertex_normals};
use crate::mesh::seams::split_at_uv_seams;
use crate::mesh::{Part, Surface, TriMesh};
use crate::render::camera::{DEFAULT_FOV_Y_DEG, DEFAULT_PITCH_DEG, DEFAULT_YAW_DEG};
use crate::render::{Bounds, DrawMesh, LightRig, Material, OrbitCamera, RenderError, Renderer, Vertex, View};
use crate::scene::file::CameraSpec;
use crate::scene::{Garment, Scene};
use crate::sim::colliders::Shape;
use crate::sim::collision::obstacles::MeshCollider;
use crate::sim::motion::Placement;

/// Half size of the drawn ground square, m.
pub const GROUND_HALF_SIZE_M: f32 = 20.0;
/// Spacing of the ground's grid lines, m.
const GROUND_GRID_M: f32 = 0.5;
/// Colour of a body without materials, linear RGB.
const BODY_COLOR: [f32; 3] = [0.6, 0.46, 0.38];

/// Where a deforming mesh's vertices come from each frame.
enum VertexSource {
    /// A garment: its particles start here in the simulated positions.
    Particles(usize),
    /// An animated collider (a body): its vertices at the frame's time.
    Collider(Box<MeshCollider>),
}

/// A deforming mesh's drawing (a garment or a body): pieces (one per material
/// part) that share its vertices, with normals recomputed every frame.
struct DeformingLook {
    /// Where its vertices come from.
    source: VertexSource,
    /// Its triangles (garment-local vertex indices).
    triangles: Vec<[u32; 3]>,
    /// Triangles around each vertex, for the per-frame normals.
    around: VertexTriangles,
    /// Drawn pieces.
    pieces: Vec<Piece>,
}

/// A drawn part of a garment: its own vertices (split at UV seams).
struct Piece {
    /// Index of its mesh in [`Stage::meshes`].
    mesh: usize,
    /// Per drawn vertex, the garment vertex it shows.
    garment_vertex: Vec<u32>,
}

/// A drawn collider (or the ground) and how it moves.
struct PlacedMesh {
    mesh: usize,
    placement: Placement,
}

/// Everything drawn for a scene, ready for a [`Renderer`].
pub struct Stage {
    garments: Vec<DeformingLook>,
    placed: Vec<PlacedMesh>,
    meshes: Vec<DrawMesh>,
    /// Everything the figure sweeps over the range (shadows cover it).
    rest_bounds: Bounds,
    /// The figure's box on the first frame (the camera frames it).
    first_bounds: Bounds,
    /// Where the figure goes (the camera follows it).
    path: FigurePath,
    camera: CameraSpec,
    /// Each garment particle's fit-map value while a map colours the cloth.
    map_values: Option<Vec<f32>>,
}

fn to_mat4(isometry: &Isometry3<f64>) -> Mat4 {
    let m = isometry.to_homogeneous().cast::<f32>();
    Mat4::from_cols_slice(m.as_slice())
}

fn to_vec3(p: &Vector3<f64>) -> Vec3 {
    Vec3::new(p.x as f32, p.y as f32, p.z as f32)
}

impl Stage {
    /// The drawing of `scene` at its initial state (loads the garments' textures).
    pub fn new(scene: &Scene) -> Result<Stage, RenderError> {
        let mut stage = Stage {
            garments: Vec::new(),
            placed: Vec::new(),
            meshes: Vec::new(),
            rest_bounds: Bounds { min: Vec3::ZERO, max: Vec3::ZERO },
            first_bounds: Bounds { min: Vec3::ZERO, max: Vec3::ZERO },
            path: FigurePath::new(scene),
            camera: scene.file.camera.clone(),
            map_values: None,
        };
        let mut first_particle = 0;
        for garment in &scene.garments {
            stage.add_garment(garment, first_particle)?;
            first_particle += garment.mesh.vertex_count();
        }
        let solid = Material::matte([0.42, 0.45, 0.5], 0.5);
        for collider in &scene.colliders {
            let mesh = match shape_mesh(&collider.shape) {
                Some(mesh) => DrawMesh {
                    name: collider.name.clone(),
                    vertices: mesh.vertices,
                    indices: mesh.indices,
                    material: solid.clone(),
                    world_from_model: Mat4::IDENTITY,
                    casts_shadow: true,
                },
                None if collider.shape == Shape::Plane => ground(&collider.name),
                None => continue,
            };
            stage.add_placed(mesh, collider.placement);
        }
        for (index, collider) in scene.mesh_colliders.iter().enumerate() {
            if collider.animation.is_some() {
                let surface = scene.bodies.iter().find(|b| b.collider == index).map(|b| b.surface.clone());
                stage.add_animated(collider, surface.unwrap_or_default());
                continue;
            }
            let normals = vertex_normals(&collider.vertices, &collider.triangles);
            let vertices = collider
                .vertices
                .iter()
                .zip(&normals)
                .map(|(p, n)| Vertex { position: to_vec3(p).into(), normal: to_vec3(n).into(), uv: [0.0; 2] })
                .collect();
            let mesh = DrawMesh {
                name: collider.name.clone(),
                vertices,
                indices: collider.triangles.iter().flatten().copied().collect(),
                material: solid.clone(),
                world_from_model: Mat4::IDENTITY,
                casts_shadow: true,
            };
            stage.add_placed(mesh, collider.placement);
        }
        let rest: Vec<Vector3<f64>> = scene.garments.iter().flat_map(|g| g.mesh.positions.iter().copied()).collect();
        stage.pose_meshes(&rest, 0.0);
        stage.first_bounds = stage.bounds();
        // Shadow everything a body will sweep, not only where it starts.
        let swept = scene.mesh_colliders.iter().filter_map(|c| {
            let animation = c.animation.as_ref()?;
            let pose = c.placement.world_from_local(0.0);
            let points =
                animation.frames.iter().flatten().map(|p| to_vec3(&(pose * nalgebra::Point3::from(*p)).coords));
            Bounds::around(points)
        });
        stage.rest_bounds = swept.fold(stage.bounds(), Bounds::union);
        Ok(stage)
    }

    fn add_placed(&mut self, mesh: DrawMesh, placement: Placement) {
        self.placed.push(PlacedMesh { mesh: self.meshes.len(), placement });
        self.meshes.push(mesh);
    }

    /// An animated collider (a body), drawn with its own materials.
    fn add_animated(&mut self, collider: &MeshCollider, surface: Surface) {
        let mesh = TriMesh {
            positions: collider.vertices.clone(),
            triangles: collider.triangles.clone(),
            quads: Vec::new(),
            surface,
        };
        let whole = [whole_part(&collider.name, &mesh)];
        let parts = if mesh.surface.parts.is_empty() { &whole[..] } else { &mesh.surface.parts[..] };
        let mut pieces = Vec::new();
        for part in parts {
            let color = part.material.and_then(|m| mesh.surface.materials.get(m)).map_or(BODY_COLOR, |m| m.diffuse);
            let material = Material { sheen_color: [0.06; 3], sheen_roughness: 0.6, ..Material::matte(color, 0.55) };
            let name = format!("{}.{}", collider.name, part.name);
            let (mut draw, vertex) = piece_mesh(&name, &mesh, part, material);
            draw.world_from_model = to_mat4(&collider.placement.world_from_local(0.0));
            pieces.push(Piece { mesh: self.meshes.len(), garment_vertex: vertex });
            self.meshes.push(draw);
        }
        self.garments.push(DeformingLook {
            source: VertexSource::Collider(Box::new(collider.clone())),
            triangles: mesh.triangles.clone(),
            around: VertexTriangles::new(&mesh.triangles, mesh.vertex_count()),
            pieces,
        });
    }

    fn add_garment(&mut self, garment: &Garment, first_particle: usize) -> Result<(), RenderError> {
        let mesh = &garment.mesh;
        let surface = &mesh.surface;
        let whole = [whole_part(&garment.name, mesh)];
        let parts = if surface.parts.is_empty() { &whole[..] } else { &surface.parts[..] };
        let appearance = garment.appearance();
        let mut textures: HashMap<&Path, Arc<image::RgbaImage>> = HashMap::new();
        let mut pieces = Vec::new();
        for part in parts {
            let source = part.material.and_then(|m| surface.materials.get(m));
            let base_color = source.map_or(appearance.base_color, |m| m.diffuse);
            let texture = match source.and_then(|m| m.diffuse_texture.as_deref()) {
                Some(path) => Some(match textures.get(path) {
                    Some(t) => t.clone(),
                    None => {
                        let loaded = Arc::new(load_texture(path)?);
                        textures.insert(path, loaded.clone());
                        loaded
                    }
                }),
                None => None,
            };
            let material = Material {
                base_color,
                back_color: appearance.back_color.unwrap_or(base_color),
                metallic: 0.0,
                roughness: appearance.roughness,
                sheen_color: appearance.sheen_color,
                sheen_roughness: appearance.sheen_roughness,
                grid_spacing_m: 0.0,
                texture,
                unlit: 0.0,
            };
            let name = format!("{}.{}", garment.name, part.name);
            let (draw, garment_vertex) = piece_mesh(&name, mesh, part, material);
            pieces.push(Piece { mesh: self.meshes.len(), garment_vertex });
            self.meshes.push(draw);
        }
        self.garments.push(DeformingLook {
            source: VertexSource::Particles(first_particle),
            triangles: mesh.triangles.clone(),
            around: VertexTriangles::new(&mesh.triangles, mesh.vertex_count()),
            pieces,
        });
        Ok(())
    }

    /// The meshes to give [`Renderer::set_meshes`], in their initial pose.
    pub fn meshes(&self) -> &[DrawMesh] {
        &self.meshes
    }

    /// Moves the meshes to `positions` (every garment's particles, concatenated
    /// in scene order, m) and the colliders to time `t_s`, here and in `renderer`.
    pub fn pose(&mut self, renderer: &mut Renderer, positions: &[Vector3<f64>], t_s: f64) {
        self.pose_meshes(positions, t_s);
        for look in &self.garments {
            for piece in &look.pieces {
                renderer.update_vertices(piece.mesh, &self.meshes[piece.mesh].vertices);
            }
        }
        for placed in &self.placed {
            let mesh = &self.meshes[placed.mesh];
            renderer.update_placement(placed.mesh, mesh.world_from_model, None);
        }
    }

    /// Colours the garments by a fit map from now on (call before
    /// [`Self::meshes`] goes to the renderer): their materials become the
    /// map's ramp, their texture coordinates each vertex's value.
    pub fn use_fit_map(&mut self) {
        let material = Material {
            texture: Some(Arc::new(fit_map::ramp_image())),
            unlit: fit_map::UNLIT_SHARE,
            ..Material::matte([1.0; 3], 0.7)
        };
        for look in self.garments.iter().filter(|l| matches!(l.source, VertexSource::Particles(_))) {
            for piece in &look.pieces {
                self.meshes[piece.mesh].material = material.clone();
            }
        }
        self.map_values = Some(Vec::new());
    }

    /// The fit-map value of every garment particle (scene order) for the
    /// next [`Self::pose`] (ignored without [`Self::use_fit_map`]).
    pub fn set_fit_map_values(&mut self, values: Vec<f32>) {
        if self.map_values.is_some() {
            self.map_values = Some(values);
        }
    }

    /// Shows or hides the garments in `renderer` (the body's motion alone).
    pub fn show_garments(&self, renderer: &mut Renderer, visible: bool) {
        for look in self.garments.iter().filter(|l| matches!(l.source, VertexSource::Particles(_))) {
            for piece in &look.pieces {
                renderer.set_visible(piece.mesh, visible);
            }
        }
    }

    fn pose_meshes(&mut self, positions: &[Vector3<f64>], t_s: f64) {
        let mut animated = Vec::new();
        for look in &self.garments {
            let own = match &look.source {
                VertexSource::Particles(first) => {
                    let Some(own) = positions.get(*first..first + look.around.vertex_count()) else { continue };
                    own
                }
                VertexSource::Collider(collider) => {
                    animated.clear();
                    animated.extend((0..collider.vertices.len()).map(|v| collider.local_vertex(v, t_s)));
                    &animated[..]
                }
            };
            let normals = look.around.normals(own, &look.triangles);
            let values = match (&look.source, &self.map_values) {
                (VertexSource::Particles(first), Some(values)) => values.get(*first..),
                _ => None,
            };
            for piece in &look.pieces {
                let vertices = &mut self.meshes[piece.mesh].vertices;
                for (v, &g) in vertices.iter_mut().zip(&piece.garment_vertex) {
                    v.position = to_vec3(&own[g as usize]).into();
                    v.normal = to_vec3(&normals[g as usize]).into();
                    if let Some(values) = values {
                        v.uv = [fit_map::ramp_u(values.get(g as usize).copied().unwrap_or(0.0)), 0.5];
                    }
                }
            }
        }
        for placed in &self.placed {
            self.meshes[placed.mesh].world_from_model = to_mat4(&placed.placement.world_from_local(t_s));
        }
    }

    /// Bounds of the current pose: garments and bounded colliders (not the ground).
    pub fn bounds(&self) -> Bounds {
        let points =
            self.meshes.iter().filter(|m| m.casts_shadow).flat_map(|m| {
                m.vertices.iter().map(move |v| m.world_from_model.transform_point3(Vec3::from(v.position)))
            });
        Bounds::around(points).unwrap_or(Bounds { min: Vec3::splat(-0.5), max: Vec3::splat(0.5) })
    }

    /// The camera at time `t_s` for an image of `aspect`: the scene file's
    /// orbit, with what it leaves out framed on the figure at the first
    /// frame (a three-quarter view of its front), the target following the
    /// figure as it walks.
    pub fn camera(&self, aspect: f32, t_s: f64) -> OrbitCamera {
        let spec = &self.camera;
        let yaw = spec.yaw_deg.map_or(self.path.front_yaw_deg() + DEFAULT_YAW_DEG, |v| v as f32);
        let pitch = spec.pitch_deg.map_or(DEFAULT_PITCH_DEG, |v| v as f32);
        let fov = spec.fov_deg.map_or(DEFAULT_FOV_Y_DEG, |v| v as f32);
        let mut camera = OrbitCamera::framing(&self.first_bounds, aspect, yaw, pitch, fov);
        if let Some(d) = spec.distance_m {
            camera.distance_m = d as f32;
        }
        match spec.target_m {
            Some(target) => camera.target = Vec3::from(target.map(|c| c as f32)),
            None => camera.target += self.path.shift(0.0, t_s),
        }
        if let Some(period) = spec.turntable_period_s {
            camera.yaw_deg += (360.0 * (t_s / period).fract()) as f32;
        }
        camera
    }

    /// The view of the current pose at time `t_s` under `rig`.
    pub fn view(&self, aspect: f32, rig: &LightRig, t_s: f64) -> View {
        self.view_through(self.camera(aspect, t_s), aspect, rig, t_s)
    }

    /// The view of the current pose at time `t_s` under `rig` through
    /// `camera` (e.g. one the user moved).
    pub fn view_through(&self, camera: OrbitCamera, aspect: f32, rig: &LightRig, t_s: f64) -> View {
        let shadow_bounds = self.rest_bounds.union(self.bounds());
        let mut view = View::new(camera, aspect, rig, t_s as f32, shadow_bounds);
        view.ground_extent_m = GROUND_HALF_SIZE_M;
        view
    }
}

/// A part covering every triangle of `mesh`.
fn whole_part(name: &str, mesh: &TriMesh) -> Part {
    Part { name: name.to_owned(), material: None, first_triangle: 0, triangle_count: mesh.triangles.len() }
}

/// The drawn mesh of one part of a mesh: a vertex per distinct (vertex, UV)
/// corner, so texture seams stay sharp while positions stay shared.
fn piece_mesh(name: &str, mesh: &TriMesh, part: &Part, material: Material) -> (DrawMesh, Vec<u32>) {
    let split = split_at_uv_seams(mesh, part.first_triangle..part.first_triangle + part.triangle_count);
    let vertices = split
        .uvs
        .iter()
        .map(|&[u, v]| Vertex { position: [0.0; 3], normal: [0.0, 1.0, 0.0], uv: [u, 1.0 - v] })
        .collect();
    let draw = DrawMesh {
        name: name.to_owned(),
        vertices,
        indices: split.indices,
        material,
        world_from_model: Mat4::IDENTITY,
        casts_shadow: true,
    };
    (draw, split.vertices)
}

/// The ground: a large square on the plane's surface with grid lines.
fn ground(name: &str) -> DrawMesh {
    let h = GROUND_HALF_SIZE_M;
    let corners = [[-h, -h], [h, -h], [h, h], [-h, h]];
    let vertices =
        corners.iter().map(|&[x, z]| Vertex { position: [x, 0.0, z], normal: [0.0, 1.0, 0.0], uv: [x, z] }).collect();
    let material = Material { grid_spacing_m: GROUND_GRID_M, ..Material::matte([0.5, 0.49, 0.47], 0.85) };
    DrawMesh {
        name: name.to_owned(),
        vertices,
        indices: vec![0, 2, 1, 0, 3, 2],
        material,
        world_from_model: Mat4::IDENTITY,
        casts_shadow: false,
    }
}

/// Reads a base-colour texture.
fn load_texture(path: &Path) -> Result<image::RgbaImage, RenderError> {
    let image =
        image::open(path).map_err(|e| RenderError::Texture { path: path.to_owned(), problem: e.to_string() })?;
    Ok(image.to_rgba8())
}
