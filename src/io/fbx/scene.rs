//! From an FBX document to a [`Body`]: the mesh, the bones above its skin
//! clusters, the clusters' weights and bind matrices, the animation curves,
//! and the global axes and units.

use std::collections::{BTreeMap, HashMap};

use fbxcel_dom::v7400::Document;
use fbxcel_dom::v7400::object::ObjectHandle;
use nalgebra::{Matrix3, Matrix4, Vector3};

use super::nodes::{child_string, float_array, int_array, number_property, vector_property};
use crate::body::Body;
use crate::body::curve::{Curve, Interpolation};
use crate::body::motion::{BoneChannels, Motion, skeleton_height};
use crate::body::skeleton::{Bone, Skeleton};
use crate::body::skin::{Skin, strongest_influences};
use crate::body::transform::{EulerOrder, NodeTransform};
use crate::mesh::{Material, Part, Surface, TriMesh};

/// FBX time unit: ticks per second.
const TICKS_PER_SECOND: f64 = 46_186_158_000.0;
/// Most vertices, polygon corners or keys accepted from one array (a guard
/// against absurd files, far above any body).
const MAX_ARRAY: usize = 50_000_000;

/// The objects of one node type, by id.
fn objects_named<'a>(document: &'a Document, node_name: &str) -> Vec<ObjectHandle<'a>> {
    document.objects().filter(|o| o.node().name() == node_name).collect()
}

/// Objects connected to `object` as sources (its children in FBX terms), with labels.
fn sources<'a>(object: &ObjectHandle<'a>) -> Vec<(ObjectHandle<'a>, Option<&'a str>)> {
    object.source_objects().filter_map(|c| Some((c.object_handle()?, c.label()))).collect()
}

/// Objects `object` is connected to (its parents in FBX terms).
fn destinations<'a>(object: &ObjectHandle<'a>) -> Vec<ObjectHandle<'a>> {
    object.destination_objects().filter_map(|c| c.object_handle()).collect()
}

fn id(object: &ObjectHandle<'_>) -> i64 {
    object.object_id().raw()
}

/// Builds the body of `document`.
pub fn body(document: &Document, name: String) -> Result<Body, String> {
    let (world_from_file, up_in_file) = axes_and_units(document);
    let (model, geometry) = skinned_mesh(document)?;
    let MeshData { positions, triangles, surface } = read_geometry(&geometry, &model)?;
    let clusters = clusters_of(&geometry);
    let (mut skeleton, bone_of_model) = skeleton_of(&clusters, &model)?;
    rest_at_bind(document, &mut skeleton, &bone_of_model, &clusters);
    let skin = skin_of(&clusters, &bone_of_model, &skeleton, positions)?;
    let motion = animation(document, &skeleton, &bone_of_model, &up_in_file)?;
    let mut body = Body {
        name,
        mesh: TriMesh { positions: Vec::new(), triangles, quads: Vec::new(), surface },
        skeleton,
        skin,
        motion,
        world_from_file,
        up_in_file,
    };
    body.mesh.positions = body.bind_pose();
    Ok(body)
}

/// `world_from_file` (axes to Y up, units to metres) and the file's up vector.
fn axes_and_units(document: &Document) -> (Matrix4<f64>, Vector3<f64>) {
    let settings = document.tree().root().first_child_by_name("GlobalSettings");
    let get = |name: &str, default: f64| settings.as_ref().and_then(|s| number_property(s, name)).unwrap_or(default);
    let axis = |index: f64| (index.round() as usize).min(2);
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
    let metres_per_unit = if centimetres_per_unit.is_finite() && centimetres_per_unit > 0.0 {
        centimetres_per_unit / 100.0
    } else {
        0.01
    };
    let mut up_in_file = Vector3::zeros();
    up_in_file[up] = up_sign;
    ((rows * metres_per_unit).to_homogeneous(), up_in_file)
}

/// The first mesh Model with a skinned Geometry, else the first with any Geometry.
fn skinned_mesh(document: &Document) -> Result<(ObjectHandle<'_>, ObjectHandle<'_>), String> {
    let mut unskinned = None;
    for model in objects_named(document, "Model").into_iter().filter(|m| m.subclass() == "Mesh") {
        for (geometry, _) in sources(&model).into_iter().filter(|(o, _)| o.node().name() == "Geometry") {
            if !clusters_of(&geometry).is_empty() {
                return Ok((model, geometry));
            }
            unskinned.get_or_insert((model, geometry));
        }
    }
    unskinned.ok_or_else(|| "the file has no mesh: a body needs a Model of type Mesh with its Geometry".to_owned())
}

/// A mesh as read: positions in the mesh's frame (file units), triangles, and
/// UVs and materials.
struct MeshData {
    positions: Vec<Vector3<f64>>,
    triangles: Vec<[u32; 3]>,
    surface: Surface,
}

/// A triangle's vertex indices and UV indices.
struct Corners {
    vertices: [u32; 3],
    uvs: [u32; 3],
}

/// A UV layer: the UVs and, per polygon corner, which one it uses.
struct UvLayer {
    uvs: Vec<[f32; 2]>,
    index: Vec<u32>,
}

/// Positions (mesh frame, file units), triangles (polygons fanned), UVs and materials.
fn read_geometry(geometry: &ObjectHandle<'_>, model: &ObjectHandle<'_>) -> Result<MeshData, String> {
    let node = geometry.node();
    let coordinates = float_array(&node, "Vertices")?;
    let corners = int_array(&node, "PolygonVertexIndex")?;
    if coordinates.len() / 3 > MAX_ARRAY || corners.len() > MAX_ARRAY {
        return Err("the mesh is larger than drape accepts".into());
    }
    let positions: Vec<Vector3<f64>> = coordinates.chunks_exact(3).map(|c| Vector3::new(c[0], c[1], c[2])).collect();
    if let Some(bad) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("vertex {bad} of the mesh is not a finite position"));
    }
    let polygons = polygons(&corners, positions.len())?;
    let uv_of_corner = uv_layer(&node, corners.len())?;
    let material_of_polygon = material_layer(&node, polygons.len());

    let mut surface = Surface::default();
    if let Some(layer) = &uv_of_corner {
        surface.uvs = layer.uvs.clone();
    }
    // Triangles grouped by material (parts are contiguous runs), file order within.
    let mut by_material: BTreeMap<usize, Vec<Corners>> = BTreeMap::new();
    for (p, (first_corner, polygon)) in polygons.iter().enumerate() {
        let material = material_of_polygon.get(p).copied().unwrap_or(0);
        for k in 1..polygon.len().saturating_sub(1) {
            let picks = [0, k, k + 1];
            let vertices = picks.map(|i| polygon[i]);
            let uvs = match &uv_of_corner {
                Some(layer) => picks.map(|i| layer.index.get(first_corner + i).copied().unwrap_or(0)),
                None => [0; 3],
            };
            by_material.entry(material).or_default().push(Corners { vertices, uvs });
        }
    }
    let materials: Vec<ObjectHandle<'_>> =
        sources(model).into_iter().filter(|(o, _)| o.node().name() == "Material").map(|(o, _)| o).collect();
    let mut triangles = Vec::new();
    for (material, run) in by_material {
        let source = materials.get(material);
        let name = source.and_then(|m| m.name()).map_or_else(|| format!("material{material}"), str::to_owned);
        let diffuse = source.and_then(|m| vector_property(&m.node(), "DiffuseColor")).unwrap_or(Vector3::repeat(0.8));
        surface.materials.push(Material {
            name: name.clone(),
            diffuse: [diffuse.x as f32, diffuse.y as f32, diffuse.z as f32],
            diffuse_texture: None,
        });
        surface.parts.push(Part {
            name,
            material: Some(surface.materials.len() - 1),
            first_triangle: triangles.len(),
            triangle_count: run.len(),
        });
        for corners in run {
            triangles.push(corners.vertices);
            if uv_of_corner.is_some() {
                surface.triangle_uvs.push(corners.uvs);
            }
        }
    }
    if triangles.is_empty() {
        return Err("the mesh has no polygons".into());
    }
    Ok(MeshData { positions, triangles, surface })
}

/// Polygons from `PolygonVertexIndex` (the last corner of each is stored as
/// `-(index + 1)`), each with the position of its first corner in the array.
fn polygons(corners: &[i64], vertex_count: usize) -> Result<Vec<(usize, Vec<u32>)>, String> {
    let mut polygons = Vec::new();
    let mut current = Vec::new();
    let mut first = 0;
    for (i, &c) in corners.iter().enumerate() {
        // `!c` is `-(c + 1)` without overflow.
        let (index, last) = if c < 0 { (!c, true) } else { (c, false) };
        let index = usize::try_from(index).ok().filter(|&v| v < vertex_count).ok_or_else(|| {
            format!("PolygonVertexIndex entry {i} refers to vertex {index}, but the mesh has {vertex_count}")
        })?;
        current.push(index as u32);
        if last {
            polygons.push((first, std::mem::take(&mut current)));
            first = i + 1;
        }
    }
    if !current.is_empty() {
        return Err("PolygonVertexIndex ends inside a polygon (the last corner is not marked)".into());
    }
    Ok(polygons)
}

/// The first UV layer as (UVs, UV index per polygon corner), when mapped by polygon corner.
fn uv_layer(
    node: &fbxcel_dom::fbxcel::tree::v7400::NodeHandle<'_>,
    corner_count: usize,
) -> Result<Option<UvLayer>, String> {
    let Some(layer) = node.first_child_by_name("LayerElementUV") else { return Ok(None) };
    if child_string(&layer, "MappingInformationType") != Some("ByPolygonVertex") {
        return Ok(None);
    }
    let uvs: Vec<[f32; 2]> = float_array(&layer, "UV")?.chunks_exact(2).map(|c| [c[0] as f32, c[1] as f32]).collect();
    let index: Vec<u32> = match child_string(&layer, "ReferenceInformationType") {
        Some("IndexToDirect") | Some("Index") => int_array(&layer, "UVIndex")?
            .into_iter()
            .map(|i| u32::try_from(i).ok().filter(|&i| (i as usize) < uvs.len()).unwrap_or(0))
            .collect(),
        _ => (0..corner_count as u32).map(|i| i.min(uvs.len().saturating_sub(1) as u32)).collect(),
    };
    Ok((index.len() == corner_count && !uvs.is_empty()).then_some(UvLayer { uvs, index }))
}

/// Material index per polygon (all 0 without a layer or when `AllSame`).
fn material_layer(node: &fbxcel_dom::fbxcel::tree::v7400::NodeHandle<'_>, polygon_count: usize) -> Vec<usize> {
    let Some(layer) = node.first_child_by_name("LayerElementMaterial") else { return Vec::new() };
    let Ok(indices) = int_array(&layer, "Materials") else { return Vec::new() };
    match child_string(&layer, "MappingInformationType") {
        Some("ByPolygon") if indices.len() == polygon_count => {
            indices.into_iter().map(|i| usize::try_from(i).unwrap_or(0)).collect()
        }
        _ => vec![indices.first().and_then(|&i| usize::try_from(i).ok()).unwrap_or(0); polygon_count],
    }
}

/// The Cluster deformers of a geometry's Skin deformers.
fn clusters_of<'a>(geometry: &ObjectHandle<'a>) -> Vec<ObjectHandle<'a>> {
    sources(geometry)
        .into_iter()
        .filter(|(o, _)| o.node().name() == "Deformer" && o.subclass() == "Skin")
        .flat_map(|(skin, _)| sources(&skin))
        .map(|(o, _)| o)
        .filter(|o| o.node().name() == "Deformer" && o.subclass() == "Cluster")
        .collect()
}

/// The bone Model a cluster follows.
fn cluster_bone<'a>(cluster: &ObjectHandle<'a>) -> Option<ObjectHandle<'a>> {
    sources(cluster).into_iter().map(|(o, _)| o).find(|o| o.node().name() == "Model")
}

/// The parent Model of a Model.
fn parent_model<'a>(model: &ObjectHandle<'a>) -> Option<ObjectHandle<'a>> {
    destinations(model).into_iter().find(|o| o.node().name() == "Model")
}

/// The Models from the roots down to every cluster's bone (parents first),
/// and the bone index of each Model id. A static body has one bone: the mesh's Model.
fn skeleton_of(
    clusters: &[ObjectHandle<'_>],
    mesh_model: &ObjectHandle<'_>,
) -> Result<(Skeleton, HashMap<i64, usize>), String> {
    let mut chains: Vec<Vec<ObjectHandle<'_>>> = Vec::new();
    let leaves: Vec<ObjectHandle<'_>> = match clusters.is_empty() {
        true => vec![*mesh_model],
        false => clusters.iter().filter_map(cluster_bone).collect(),
    };
    for leaf in leaves {
        let mut chain = vec![leaf];
        while let Some(parent) = chain.last().and_then(parent_model) {
            if chain.len() > 10_000 || chain.iter().any(|o| id(o) == id(&parent)) {
                return Err("the Model hierarchy has a cycle".into());
            }
            chain.push(parent);
        }
        chain.reverse();
        chains.push(chain);
    }
    let mut skeleton = Skeleton::default();
    let mut bone_of_model = HashMap::new();
    for chain in chains {
        let mut parent = None;
        for model in chain {
            let index = match bone_of_model.get(&id(&model)) {
                Some(&index) => index,
                None => {
                    let name = model.name().unwrap_or("").to_owned();
                    if skeleton.find(&name).is_some() {
                        return Err(format!("two bones are called '{name}': bone names must be unique"));
                    }
                    skeleton.bones.push(Bone { name, parent, rest: node_transform(&model)? });
                    bone_of_model.insert(id(&model), skeleton.bones.len() - 1);
                    skeleton.bones.len() - 1
                }
            };
            parent = Some(index);
        }
    }
    Ok((skeleton, bone_of_model))
}

/// Global bind matrices of the BindPose, by Model id.
fn bind_pose_matrices(document: &Document) -> HashMap<i64, Matrix4<f64>> {
    let mut matrices = HashMap::new();
    for pose in objects_named(document, "Pose").into_iter().filter(|p| p.subclass() == "BindPose") {
        for entry in pose.node().children_by_name("PoseNode") {
            let node = entry.first_child_by_name("Node").and_then(|n| n.attributes().first()?.get_i64());
            let values =
                float_array(&entry, "Matrix").ok().filter(|m| m.len() == 16 && m.iter().all(|v| v.is_finite()));
            if let (Some(node), Some(values)) = (node, values) {
                matrices.entry(node).or_insert_with(|| Matrix4::from_column_slice(&values));
            }
        }
    }
    matrices
}

/// Sets each bone's rest transform to its bind pose (a file's `Lcl` values
/// are whatever pose it was saved in): clusters' `TransformLink`s, else the
/// BindPose, else `Lcl`. Only plain nodes (XYZ order, no pre/post rotation,
/// pivots or offsets) are re-expressed; others keep `Lcl`.
fn rest_at_bind(
    document: &Document,
    skeleton: &mut Skeleton,
    bone_of_model: &HashMap<i64, usize>,
    clusters: &[ObjectHandle<'_>],
) {
    let mut bind = bind_pose_matrices(document)
        .into_iter()
        .filter_map(|(model, m)| Some((*bone_of_model.get(&model)?, m)))
        .collect::<HashMap<usize, Matrix4<f64>>>();
    for cluster in clusters {
        let bone = cluster_bone(cluster).and_then(|m| bone_of_model.get(&id(&m)).copied());
        if let (Some(bone), Ok(link)) = (bone, matrix(cluster, "TransformLink")) {
            bind.insert(bone, link);
        }
    }
    let mut world: Vec<Matrix4<f64>> = Vec::with_capacity(skeleton.bones.len());
    for (i, bone) in skeleton.bones.iter_mut().enumerate() {
        let parent = bone.parent.and_then(|p| world.get(p).copied()).unwrap_or_else(Matrix4::identity);
        let own = bind.get(&i).copied().unwrap_or_else(|| parent * bone.rest.matrix());
        let plain = bone.rest.order == EulerOrder::Xyz
            && [bone.rest.pre_rotation_deg, bone.rest.post_rotation_deg, bone.rest.rotation_offset]
                .iter()
                .chain(&[bone.rest.rotation_pivot, bone.rest.scaling_offset, bone.rest.scaling_pivot])
                .all(|v| v.norm() == 0.0);
        let local = parent.try_inverse().map(|p| p * own).and_then(|m| NodeTransform::from_matrix(&m));
        if let (true, Some(local)) = (plain, local) {
            bone.rest = local;
        }
        world.push(parent * bone.rest.matrix());
    }
}

/// A Model's local transform properties.
fn node_transform(model: &ObjectHandle<'_>) -> Result<NodeTransform, String> {
    let node = model.node();
    let vector = |name: &str, default: Vector3<f64>| vector_property(&node, name).unwrap_or(default);
    let order_value = number_property(&node, "RotationOrder").unwrap_or(0.0) as i64;
    let order = EulerOrder::from_fbx(order_value).ok_or_else(|| {
        format!(
            "Model '{}' has RotationOrder {order_value}, which drape does not support (use an Euler order such as XYZ)",
            model.name().unwrap_or("")
        )
    })?;
    // Pre/Post rotation and pivots count only when RotationActive says so (FBX SDK rule).
    let active = number_property(&node, "RotationActive").unwrap_or(0.0) != 0.0;
    let gated = |name: &str| if active { vector(name, Vector3::zeros()) } else { Vector3::zeros() };
    let transform = NodeTransform {
        translation: vector("Lcl Translation", Vector3::zeros()),
        rotation_deg: vector("Lcl Rotation", Vector3::zeros()),
        scaling: vector("Lcl Scaling", Vector3::repeat(1.0)),
        order,
        pre_rotation_deg: gated("PreRotation"),
        post_rotation_deg: gated("PostRotation"),
        rotation_offset: vector("RotationOffset", Vector3::zeros()),
        rotation_pivot: vector("RotationPivot", Vector3::zeros()),
        scaling_offset: vector("ScalingOffset", Vector3::zeros()),
        scaling_pivot: vector("ScalingPivot", Vector3::zeros()),
    };
    let values = [transform.translation, transform.rotation_deg, transform.scaling];
    if values.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
        return Err(format!("Model '{}' has a non-finite transform", model.name().unwrap_or("")));
    }
    Ok(transform)
}

/// A 4×4 matrix stored as 16 doubles, column by column.
fn matrix(cluster: &ObjectHandle<'_>, name: &str) -> Result<Matrix4<f64>, String> {
    let values = float_array(&cluster.node(), name)?;
    match values.len() == 16 && values.iter().all(|v| v.is_finite()) {
        true => Ok(Matrix4::from_column_slice(&values)),
        false => Err(format!("{name} of cluster '{}' is not 16 finite numbers", cluster.name().unwrap_or(""))),
    }
}

/// Weights and bind matrices.
fn skin_of(
    clusters: &[ObjectHandle<'_>],
    bone_of_model: &HashMap<i64, usize>,
    skeleton: &Skeleton,
    bind_positions: Vec<Vector3<f64>>,
) -> Result<Skin, String> {
    let vertex_count = bind_positions.len();
    let mut weights: Vec<Vec<(u32, f32)>> = vec![Vec::new(); vertex_count];
    let mut bone_from_mesh = vec![Matrix4::identity(); skeleton.bones.len()];
    // A static body (no clusters): the mesh Model's own transform places it.
    let mut file_from_mesh = skeleton.world_matrices(&skeleton.rest_pose()).last().copied().unwrap_or_default();
    for cluster in clusters {
        let Some(bone) = cluster_bone(cluster).and_then(|m| bone_of_model.get(&id(&m)).copied()) else { continue };
        let name = cluster.name().unwrap_or("");
        let node = cluster.node();
        let (indexes, values) = match (int_array(&node, "Indexes"), float_array(&node, "Weights")) {
            (Ok(i), Ok(w)) => (i, w),
            _ => (Vec::new(), Vec::new()), // a cluster that deforms nothing
        };
        if indexes.len() != values.len() {
            return Err(format!("cluster '{name}' has {} indexes but {} weights", indexes.len(), values.len()));
        }
        // `Transform` is stored relative to the bone (bone_from_mesh at bind),
        // although the FBX SDK presents it in global space as TransformLink ×
        // Transform; `TransformLink` is the bone's global bind matrix.
        let mesh_in_bone = matrix(cluster, "Transform")?;
        let bone_bind = matrix(cluster, "TransformLink")?;
        bone_from_mesh[bone] = mesh_in_bone;
        file_from_mesh = bone_bind * mesh_in_bone;
        for (&vertex, &weight) in indexes.iter().zip(&values) {
            let slot = usize::try_from(vertex).ok().and_then(|v| weights.get_mut(v));
            let slot =
                slot.ok_or_else(|| format!("cluster '{name}' weights vertex {vertex}, the mesh has {vertex_count}"))?;
            slot.push((bone as u32, weight as f32));
        }
    }
    let influences = weights.into_iter().map(|w| strongest_influences(w).unwrap_or([(0, 0.0); 4])).collect();
    Ok(Skin { bind_positions, influences, bone_from_mesh, file_from_mesh })
}

/// The first animation stack's curves on the skeleton's bones.
fn animation(
    document: &Document,
    skeleton: &Skeleton,
    bone_of_model: &HashMap<i64, usize>,
    up_in_file: &Vector3<f64>,
) -> Result<Option<Motion>, String> {
    let Some(stack) = objects_named(document, "AnimationStack").into_iter().next() else { return Ok(None) };
    let layers: Vec<_> = sources(&stack).into_iter().filter(|(o, _)| o.node().name() == "AnimationLayer").collect();
    let Some((layer, _)) = layers.into_iter().next() else { return Ok(None) };
    let mut bones: BTreeMap<String, BoneChannels> = BTreeMap::new();
    let (mut first, mut last) = (f64::INFINITY, f64::NEG_INFINITY);
    for (curve_node, _) in sources(&layer).into_iter().filter(|(o, _)| o.node().name() == "AnimationCurveNode") {
        // The curve node drives one property of one Model.
        let target = curve_node.destination_objects().find_map(|c| {
            let object = c.object_handle()?;
            let bone = *bone_of_model.get(&id(&object))?;
            Some((bone, c.label()?))
        });
        let Some((bone, property)) = target else { continue };
        let channels = bones.entry(skeleton.bones[bone].name.clone()).or_default();
        let slot = match property {
            "Lcl Translation" => &mut channels.translation,
            "Lcl Rotation" => &mut channels.rotation,
            "Lcl Scaling" => &mut channels.scaling,
            _ => continue,
        };
        for (curve, label) in sources(&curve_node).into_iter().filter(|(o, _)| o.node().name() == "AnimationCurve") {
            let axis = match label {
                Some("d|X") => 0,
                Some("d|Y") => 1,
                Some("d|Z") => 2,
                _ => continue,
            };
            let curve = read_curve(&curve)?;
            if let (Some(&a), Some(&b)) = (curve.times_s.first(), curve.times_s.last()) {
                first = first.min(a);
                last = last.max(b);
            }
            slot[axis] = Some(curve);
        }
    }
    if bones.is_empty() {
        return Ok(None);
    }
    let stack_node = stack.node();
    let start = number_property(&stack_node, "LocalStart").map_or(first, |t| t / TICKS_PER_SECOND);
    let stop = number_property(&stack_node, "LocalStop").map_or(last, |t| t / TICKS_PER_SECOND);
    let reference_height = skeleton_height(skeleton, up_in_file);
    Ok(Some(Motion { bones, start_s: start, end_s: stop.max(start), reference_height, source: skeleton.clone() }))
}

/// One AnimationCurve: keys, values and per-key interpolation.
fn read_curve(curve: &ObjectHandle<'_>) -> Result<Curve, String> {
    let node = curve.node();
    let times = int_array(&node, "KeyTime")?;
    let values = float_array(&node, "KeyValueFloat")?;
    if times.len() != values.len() || times.len() > MAX_ARRAY {
        return Err(format!("an animation curve has {} key times but {} values", times.len(), values.len()));
    }
    let times_s: Vec<f64> = times.iter().map(|&t| t as f64 / TICKS_PER_SECOND).collect();
    if times_s.windows(2).any(|w| w[1] < w[0]) || values.iter().any(|v| !v.is_finite()) {
        return Err("an animation curve has keys out of time order or non-finite values".into());
    }
    let flags = int_array(&node, "KeyAttrFlags").unwrap_or_default();
    let data = float_array(&node, "KeyAttrDataFloat").unwrap_or_default();
    let counts = int_array(&node, "KeyAttrRefCount").unwrap_or_default();
    // Each attribute entry applies to the next `count` keys.
    let mut interpolation = Vec::with_capacity(times.len());
    for (entry, &count) in counts.iter().enumerate() {
        let flag = flags.get(entry).copied().unwrap_or(0x04);
        for _ in 0..count.max(0) {
            let key = interpolation.len();
            if key >= times.len() {
                break;
            }
            interpolation.push(match flag {
                f if f & 0x02 != 0 => Interpolation::Constant,
                f if f & 0x08 != 0 => Interpolation::Cubic {
                    right_slope: data.get(4 * entry).copied().unwrap_or(0.0),
                    next_left_slope: data.get(4 * entry + 1).copied().unwrap_or(0.0),
                },
                _ => Interpolation::Linear,
            });
        }
    }
    interpolation.resize(times.len(), Interpolation::Linear);
    Ok(Curve { times_s, values, interpolation })
}
