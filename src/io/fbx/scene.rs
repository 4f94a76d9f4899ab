//! From an FBX 7 document to a [`Body`]: every Model as a node of one
//! hierarchy (parents first, file order otherwise), every mesh as a part
//! with its geometric transform, skin and blend shapes, the chosen
//! animation stack, and the global axes and units.

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Matrix4, Vector3};

use super::animation::{self, Targets};
use super::deformers::{matrix, shape_channels, skin, stored_skin, vertex_cache};
use super::document::{Document, Object};
use super::geometry::{self, Geometry};
use crate::body::motion::{Motion, skeleton_height};
use crate::body::skeleton::{Bone, Skeleton};
use crate::body::transform::{EulerOrder, Inherit, NodeTransform, geometric_matrix};
use crate::body::{Body, BodyPart, PartKind, Polygons, StackSummary};
use crate::mesh::{Material, Part, TriMesh};

/// Which parts and which animation of a file make the body.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BodyOptions {
    /// Keep only the meshes of these names (all when `None`).
    pub parts: Option<Vec<String>>,
    /// Drop the meshes of these names.
    pub exclude: Vec<String>,
    /// The animation stack by name (the file's first when `None`).
    pub stack: Option<String>,
}

/// Why a document does not make a body.
#[derive(Debug, PartialEq)]
pub enum Problem {
    /// No Model holds a polygon mesh.
    NoMesh,
    /// A vertex cache drives mesh `mesh`.
    VertexCache {
        /// The mesh's name.
        mesh: String,
        /// The cache file as the FBX names it.
        cache: String,
    },
    /// Anything else, said in words.
    Content(String),
}

impl From<String> for Problem {
    fn from(problem: String) -> Problem {
        Problem::Content(problem)
    }
}

/// The file's nodes as a skeleton, and each Model id's bone index.
pub struct Hierarchy {
    /// Every Model, parents first.
    pub skeleton: Skeleton,
    /// The bone index of each Model id.
    pub bone_of: BTreeMap<i64, usize>,
}

/// Builds the body of `document`.
pub fn body(document: &Document, name: String, options: &BodyOptions) -> Result<Body, Problem> {
    let (world_from_file, up_in_file) = axes_and_units(document);
    let mut hierarchy = hierarchy(document)?;
    let meshes = mesh_models(document);
    if meshes.is_empty() {
        return Err(Problem::NoMesh);
    }
    let kept = kept_meshes(&meshes, options)?;
    let all_meshes: Vec<String> = meshes.iter().map(|(m, _, _)| m.name.clone()).collect();
    set_bind_matrices(document, &mut hierarchy);
    let height = skeleton_height(&hierarchy.skeleton, &up_in_file);
    let motion = chosen_motion(document, &hierarchy, options.stack.as_deref(), height)?;
    let application = application(document);
    let mut parts = Vec::new();
    let mut mesh = TriMesh::default();
    for (model, geometry_object, geometry) in kept {
        if let Some(cache) = vertex_cache(document, geometry_object) {
            return Err(Problem::VertexCache { mesh: model.name.clone(), cache });
        }
        let mut part =
            part(document, &hierarchy, model, geometry_object, &geometry, mesh.vertex_count(), &application)?;
        let first_triangle = mesh.triangles.len();
        append_mesh(&mut mesh, &geometry, &materials_of(document, model));
        part.triangles = first_triangle..mesh.triangles.len();
        parts.push(part);
    }
    mark_kinds(&mut parts, &hierarchy.skeleton, motion.as_ref());
    if world_from_file.fixed_view::<3, 3>(0, 0).determinant() < 0.0 {
        mesh.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        mesh.surface.triangle_uvs.iter_mut().for_each(|t| t.swap(1, 2));
    }
    let stacks = stack_summaries(document);
    let source = describe(document, &application);
    let skeleton = hierarchy.skeleton;
    let mut body =
        Body { name, source, mesh, skeleton, parts, meshes: all_meshes, motion, stacks, world_from_file, up_in_file };
    body.mesh.positions = body.bind_pose();
    Ok(body)
}

/// The skeleton and motion of a file that may hold no mesh (a motion library).
pub fn skeleton_and_motion(
    document: &Document,
    stack: Option<&str>,
) -> Result<(Skeleton, Option<Motion>, Vec<StackSummary>), String> {
    let (_, up_in_file) = axes_and_units(document);
    let mut hierarchy = hierarchy(document)?;
    set_bind_matrices(document, &mut hierarchy);
    let height = skeleton_height(&hierarchy.skeleton, &up_in_file);
    let motion = chosen_motion(document, &hierarchy, stack, height)?;
    Ok((hierarchy.skeleton, motion, stack_summaries(document)))
}

fn stack_summaries(document: &Document) -> Vec<StackSummary> {
    let unit = animation::ticks_per_second(document);
    animation::stacks(document)
        .into_iter()
        .map(|s| {
            let seconds = |n: &str| document.number(s, n).filter(|v| v.is_finite()).map_or(0.0, |t| t / unit);
            StackSummary { name: s.name.clone(), start_s: seconds("LocalStart"), end_s: seconds("LocalStop") }
        })
        .collect()
}

fn chosen_motion(
    document: &Document,
    hierarchy: &Hierarchy,
    stack: Option<&str>,
    height: f64,
) -> Result<Option<Motion>, String> {
    let Some(stack) = animation::choose_stack(document, stack)? else { return Ok(None) };
    let bone_of = |id: i64| hierarchy.bone_of.get(&id).copied();
    let targets = Targets { document, skeleton: &hierarchy.skeleton, bone_of: &bone_of };
    animation::motion(&targets, stack, height)
}

/// `world_from_file` (axes to Y up, units to metres) and the file's up vector.
fn axes_and_units(document: &Document) -> (Matrix4<f64>, Vector3<f64>) {
    let settings = document.section("GlobalSettings").map(|node| (node, document));
    let get = |name: &str, default: f64| {
        settings
            .and_then(|(node, _)| node.child("Properties70"))
            .and_then(|list| list.children_named("P").find(|p| p.value(0).and_then(|v| v.string()) == Some(name)))
            .and_then(|p| p.value(4)?.number())
            .filter(|v| v.is_finite())
            .unwrap_or(default)
    };
    let axis = |index: f64| (index.round().clamp(0.0, 2.0)) as usize;
    let sign = |s: f64| if s < 0.0 { -1.0 } else { 1.0 };
    let (up, up_sign) = (axis(get("UpAxis", 1.0)), sign(get("UpAxisSign", 1.0)));
    let (front, front_sign) = (axis(get("FrontAxis", 2.0)), sign(get("FrontAxisSign", 1.0)));
    let (coord, coord_sign) = (axis(get("CoordAxis", 0.0)), sign(get("CoordAxisSign", 1.0)));
    let mut rows: Matrix3<f64> = Matrix3::zeros();
    rows[(0, coord)] = coord_sign;
    rows[(1, up)] = up_sign;
    rows[(2, front)] = front_sign;
    // A malformed set of axes (two the same) falls back to the identity.
    if rows.determinant().abs() < 0.5 {
        rows = Matrix3::identity();
    }
    let centimetres_per_unit = get("UnitScaleFactor", 1.0);
    let metres_per_unit = if centimetres_per_unit > 0.0 { centimetres_per_unit / 100.0 } else { 0.01 };
    let mut up_in_file = Vector3::zeros();
    up_in_file[up] = up_sign;
    ((rows * metres_per_unit).to_homogeneous(), up_in_file)
}

/// The application that last saved the file (`Maya`, `3ds Max`,
/// `Blender`...): a few of them evaluate some things their own way.
pub fn application(document: &Document) -> String {
    let info =
        document.section("FBXHeaderExtension").and_then(|h| h.child("SceneInfo")).and_then(|s| s.child("Properties70"));
    let named = |name: &str| {
        let p = info?.children_named("P").find(|p| p.value(0).and_then(|v| v.string()) == Some(name))?;
        p.value(4)?.string().map(str::to_owned)
    };
    let creator = document.section("FBXHeaderExtension").and_then(|h| h.child_string("Creator")).unwrap_or("");
    named("LastSaved|ApplicationName")
        .or_else(|| named("Original|ApplicationName"))
        .unwrap_or_else(|| if creator.starts_with("Blender") { "Blender".into() } else { String::new() })
}

/// What the file is: its encoding, version and the application that saved it.
pub fn describe(document: &Document, application: &str) -> String {
    let encoding = if document.ascii { "ASCII" } else { "binary" };
    match application.is_empty() {
        true => format!("{encoding} FBX {}", document.version),
        false => format!("{encoding} FBX {} saved by {application}", document.version),
    }
}

/// Every Model as a bone, parents first; otherwise in file order.
pub fn hierarchy(document: &Document) -> Result<Hierarchy, String> {
    let models: Vec<&Object> = document.objects().iter().filter(|o| o.class == "Model").collect();
    let index_of: BTreeMap<i64, usize> = models.iter().enumerate().map(|(i, m)| (m.id, i)).collect();
    // A Model's parent: the last Model it connects to (the FBX SDK's rule).
    let parent_of: Vec<Option<usize>> = models
        .iter()
        .map(|m| {
            document
                .destinations(m)
                .filter(|(o, _)| o.class == "Model")
                .last()
                .and_then(|(o, _)| index_of.get(&o.id).copied())
        })
        .collect();
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); models.len()];
    for (i, parent) in parent_of.iter().enumerate() {
        if let Some(p) = *parent {
            children[p].push(i);
        }
    }
    let mut order = Vec::with_capacity(models.len());
    let mut stack: Vec<usize> = (0..models.len()).rev().filter(|&i| parent_of[i].is_none()).collect();
    while let Some(i) = stack.pop() {
        order.push(i);
        stack.extend(children[i].iter().rev());
    }
    if order.len() != models.len() {
        return Err("the Model hierarchy has a cycle".into());
    }
    let mut bone_of = BTreeMap::new();
    let mut bones = Vec::with_capacity(models.len());
    for &i in &order {
        let model = models[i];
        let parent = parent_of[i].and_then(|p| bone_of.get(&models[p].id).copied());
        bones.push(Bone { name: model.name.clone(), parent, rest: node_transform(document, model)?, bind: None });
        bone_of.insert(model.id, bones.len() - 1);
    }
    Ok(Hierarchy { skeleton: Skeleton { bones }, bone_of })
}

/// A Model's local transform properties (template defaults applied; without
/// a template, the FBX SDK's own defaults).
fn node_transform(document: &Document, model: &Object) -> Result<NodeTransform, String> {
    let vector = |name: &str, default: Vector3<f64>| document.vector(model, name).unwrap_or(default);
    let number = |name: &str, default: f64| document.number(model, name).unwrap_or(default);
    let transform = NodeTransform {
        translation: vector("Lcl Translation", Vector3::zeros()),
        rotation_deg: vector("Lcl Rotation", Vector3::zeros()),
        scaling: vector("Lcl Scaling", Vector3::repeat(1.0)),
        // Spheric XYZ (6) and unknown orders turn as XYZ.
        order: EulerOrder::from_fbx(number("RotationOrder", 0.0) as i64).unwrap_or_default(),
        rotation_active: number("RotationActive", 1.0) != 0.0 && number("RotationSpaceForLimitOnly", 0.0) == 0.0,
        pre_rotation_deg: vector("PreRotation", Vector3::zeros()),
        post_rotation_deg: vector("PostRotation", Vector3::zeros()),
        rotation_offset: vector("RotationOffset", Vector3::zeros()),
        rotation_pivot: vector("RotationPivot", Vector3::zeros()),
        scaling_offset: vector("ScalingOffset", Vector3::zeros()),
        scaling_pivot: vector("ScalingPivot", Vector3::zeros()),
        inherit: Inherit::from_fbx(number("InheritType", 1.0) as i64),
    };
    let values = [
        transform.translation,
        transform.rotation_deg,
        transform.scaling,
        transform.pre_rotation_deg,
        transform.post_rotation_deg,
        transform.rotation_offset,
        transform.rotation_pivot,
        transform.scaling_offset,
        transform.scaling_pivot,
    ];
    if values.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
        return Err(format!("Model '{}' has a transform that is not finite", model.name));
    }
    Ok(transform)
}

/// Bind matrices of the bones: clusters' `TransformLink`s, else the first
/// bind pose that lists the node.
fn set_bind_matrices(document: &Document, hierarchy: &mut Hierarchy) {
    let mut bind: BTreeMap<usize, Matrix4<f64>> = BTreeMap::new();
    for pose in document.objects().iter().filter(|o| o.class == "Pose" && o.subclass == "BindPose") {
        for entry in document.node(pose).children_named("PoseNode") {
            let node =
                entry.child_value("Node").and_then(|v| v.int()).and_then(|id| hierarchy.bone_of.get(&id).copied());
            if let (Some(bone), Some(m)) = (node, matrix(entry.child_value("Matrix"))) {
                bind.entry(bone).or_insert(m);
            }
        }
    }
    for cluster in document.objects().iter().filter(|o| o.class == "Deformer" && o.subclass == "Cluster") {
        let bone = document
            .sources(cluster)
            .find(|(o, _)| o.class == "Model")
            .and_then(|(o, _)| hierarchy.bone_of.get(&o.id).copied());
        if let (Some(bone), Some(m)) = (bone, matrix(document.node(cluster).child_value("TransformLink"))) {
            bind.insert(bone, m);
        }
    }
    for (bone, m) in bind {
        hierarchy.skeleton.bones[bone].bind = Some(m);
    }
}

/// Every Model with a mesh Geometry (its first, in connection order) that
/// has polygons, read, in file order. A mesh without polygons (an edge
/// loop, a point cloud) cannot touch cloth and is left out.
fn mesh_models(document: &Document) -> Vec<(&Object, &Object, Result<Geometry, String>)> {
    let models = document.objects().iter().filter(|o| o.class == "Model");
    models
        .filter_map(|m| {
            let object = document.sources(m).map(|(o, _)| o).find(|o| o.class == "Geometry" && o.subclass == "Mesh")?;
            let node = document.node(object);
            if node.child("Vertices").is_none() || node.child("PolygonVertexIndex").is_none() {
                return None;
            }
            let geometry = geometry::read(node).map_err(|e| format!("mesh '{}': {e}", m.name));
            match &geometry {
                Ok(g) if g.triangles.is_empty() => None,
                _ => Some((m, object, geometry)),
            }
        })
        .collect()
}

/// The meshes `options` keeps; an unknown name is an error listing the parts.
fn kept_meshes<'a>(
    meshes: &[(&'a Object, &'a Object, Result<Geometry, String>)],
    options: &BodyOptions,
) -> Result<Vec<(&'a Object, &'a Object, Geometry)>, Problem> {
    let names: Vec<&str> = meshes.iter().map(|(m, _, _)| m.name.as_str()).collect();
    let asked = options.parts.iter().flatten().chain(&options.exclude);
    if let Some(unknown) = asked.into_iter().find(|n| !names.contains(&n.as_str())) {
        let list: Vec<String> = names.iter().map(|n| format!("'{n}'")).collect();
        return Err(format!("there is no mesh '{unknown}'; the file's meshes are {}", list.join(", ")).into());
    }
    let mut kept = Vec::new();
    for (model, object, geometry) in meshes {
        let chosen =
            options.parts.as_ref().is_none_or(|p| p.contains(&model.name)) && !options.exclude.contains(&model.name);
        if chosen {
            kept.push((*model, *object, geometry.clone()?));
        }
    }
    if kept.is_empty() {
        return Err("no mesh is left once the parts are chosen: keep at least one".to_owned().into());
    }
    Ok(kept)
}

/// A mesh Model's part: its points, polygons, geometric transform, skin and blend shapes.
fn part(
    document: &Document,
    hierarchy: &Hierarchy,
    model: &Object,
    geometry_object: &Object,
    geometry: &Geometry,
    first_vertex: usize,
    application: &str,
) -> Result<BodyPart, String> {
    let node = hierarchy.bone_of.get(&model.id).copied().ok_or("a mesh's Model is not in the hierarchy")?;
    let vector = |name: &str, default: Vector3<f64>| {
        document.vector(model, name).filter(|v| v.iter().all(|c| c.is_finite())).unwrap_or(default)
    };
    let geometric = geometric_matrix(
        &vector("GeometricTranslation", Vector3::zeros()),
        &vector("GeometricRotation", Vector3::zeros()),
        &vector("GeometricScaling", Vector3::repeat(1.0)),
    );
    let vertex_count = geometry.positions.len();
    let bind = hierarchy.skeleton.bind_matrices();
    let skin = match stored_skin(document, geometry_object).map_err(|e| format!("mesh '{}': {e}", model.name))? {
        Some(stored) => {
            let bone_of = |bone: &Object| {
                let index = hierarchy.bone_of.get(&bone.id).copied()?;
                Some((index, bind[index]))
            };
            let mut skin = skin(&stored, vertex_count, &geometric, &bone_of, &bind[node]);
            if application.starts_with("Maya") {
                // The mesh's place when it was bound (its geometry matrix,
                // shared by every instance of it).
                let bound =
                    stored.clusters.iter().find_map(|c| Some(c.transform_link? * c.transform?)).unwrap_or(bind[node]);
                skin.node_at_bind_inverse = bound.try_inverse();
            }
            (!skin.clusters.is_empty()).then_some(skin)
        }
        None => None,
    };
    let shapes = shape_channels(document, geometry_object, vertex_count, application.starts_with("Blender"))
        .map_err(|e| format!("mesh '{}': {e}", model.name))?;
    Ok(BodyPart {
        name: model.name.clone(),
        node,
        geometric,
        first_vertex,
        triangles: 0..0,
        points: geometry.positions.clone(),
        shapes,
        kind: if skin.is_some() { PartKind::Skinned } else { PartKind::Static },
        skin,
        polygons: Polygons { corners: geometry.corners.clone(), starts: geometry.polygon_starts.clone() },
    })
}

/// Unskinned parts whose node, or a node above it, the motion animates are rigid.
fn mark_kinds(parts: &mut [BodyPart], skeleton: &Skeleton, motion: Option<&Motion>) {
    let mut animated = vec![false; skeleton.bones.len()];
    for node in motion.map(|m| m.nodes.as_slice()).unwrap_or_default() {
        if let Some(a) = animated.get_mut(node.bone) {
            *a = true;
        }
    }
    for (i, bone) in skeleton.bones.iter().enumerate() {
        if let Some(p) = bone.parent {
            animated[i] |= animated[p];
        }
    }
    for part in parts.iter_mut().filter(|p| p.kind == PartKind::Static) {
        if animated.get(part.node).copied().unwrap_or(false) {
            part.kind = PartKind::Rigid;
        }
    }
}

/// The materials a Model lists (by which its polygons' material indices go).
fn materials_of(document: &Document, model: &Object) -> Vec<Material> {
    document
        .sources(model)
        .map(|(o, _)| o)
        .filter(|o| o.class == "Material")
        .map(|m| {
            let diffuse = document.vector(m, "DiffuseColor").unwrap_or(Vector3::repeat(0.8));
            Material {
                name: m.name.clone(),
                diffuse: [diffuse.x as f32, diffuse.y as f32, diffuse.z as f32],
                diffuse_texture: None,
            }
        })
        .collect()
}

/// Appends a part's triangles, UVs and materials to the body's mesh (one
/// surface part per run of a material).
fn append_mesh(mesh: &mut TriMesh, geometry: &Geometry, materials: &[Material]) {
    let base = mesh.vertex_count() as u32;
    let uv_base = mesh.surface.uvs.len() as u32;
    mesh.positions.extend(&geometry.positions);
    let with_uvs = !geometry.surface.triangle_uvs.is_empty();
    if mesh.surface.triangle_uvs.len() < mesh.triangles.len() && with_uvs {
        // Earlier parts without UVs get the first UV of this one.
        mesh.surface.triangle_uvs.resize(mesh.triangles.len(), [uv_base; 3]);
    }
    mesh.surface.uvs.extend(&geometry.surface.uvs);
    let mut used: BTreeMap<usize, usize> = BTreeMap::new();
    let mut start = 0;
    while start < geometry.triangles.len() {
        let material = geometry.triangle_materials[start];
        let run = geometry.triangle_materials[start..].iter().take_while(|&&m| m == material).count();
        let index = *used.entry(material).or_insert_with(|| {
            let m = materials.get(material).cloned().unwrap_or_else(|| Material {
                name: format!("material{material}"),
                diffuse: [0.8; 3],
                diffuse_texture: None,
            });
            mesh.surface.materials.push(m);
            mesh.surface.materials.len() - 1
        });
        let name = mesh.surface.materials[index].name.clone();
        mesh.surface.parts.push(Part {
            name,
            material: Some(index),
            first_triangle: mesh.triangles.len() + start,
            triangle_count: run,
        });
        start += run;
    }
    mesh.triangles.extend(geometry.triangles.iter().map(|t| t.map(|v| v + base)));
    if with_uvs {
        mesh.surface.triangle_uvs.extend(geometry.surface.triangle_uvs.iter().map(|t| t.map(|v| v + uv_base)));
    } else if !mesh.surface.triangle_uvs.is_empty() {
        mesh.surface.triangle_uvs.resize(mesh.triangles.len(), [0; 3]);
    }
}
