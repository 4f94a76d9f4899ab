//! A mesh's deformers: its skin (clusters, weights, skinning type) and its
//! blend shapes (channels, in-between targets); vertex caches are refused.

use nalgebra::{Matrix4, Vector3};

use super::document::{Document, Object};
use super::tree::Value;
use crate::body::blend_shape::{ShapeChannel, ShapeTarget};
use crate::body::skin::{Cluster, Skin, SkinningMethod};

/// A cluster as stored: its bone, weights and bind matrices.
pub struct StoredCluster<'a> {
    /// The bone's Model.
    pub bone: &'a Object,
    /// `Transform`: `bone_from_mesh` at bind.
    pub transform: Option<Matrix4<f64>>,
    /// `TransformLink`: the bone's `file_from_bone` at bind.
    pub transform_link: Option<Matrix4<f64>>,
    /// (vertex, weight) pairs.
    pub weights: Vec<(i64, f64)>,
}

/// The deformers of `geometry` of class `Deformer` and subclass `subclass`, in connection order.
fn deformers<'a>(
    document: &'a Document,
    geometry: &Object,
    subclass: &'a str,
) -> impl Iterator<Item = &'a Object> + 'a {
    document.sources(geometry).map(|(o, _)| o).filter(move |o| o.class == "Deformer" && o.subclass == subclass)
}

/// The cache file of an active vertex cache driving `geometry`, if one
/// does (drape reads the skin, blend shapes and node animation an FBX
/// holds, not external caches).
pub fn vertex_cache(document: &Document, geometry: &Object) -> Option<String> {
    let active = |d: &&Object| document.number(d, "Active").is_none_or(|a| a != 0.0);
    let cache = deformers(document, geometry, "VertexCacheDeformer").find(active)?;
    let file = document.sources(cache).map(|(o, _)| o).find(|o| o.class == "Cache").and_then(|c| {
        let text = |name| document.property(c, name)?.first()?.string().map(str::to_owned);
        text("CacheFileName").or_else(|| text("CacheAbsoluteFileName"))
    });
    Some(file.unwrap_or_else(|| "an external file".into()))
}

/// A skin as stored: its clusters, skinning type and per-vertex
/// dual-quaternion shares (vertex, share).
pub struct StoredSkin<'a> {
    /// The clusters, in connection order.
    pub clusters: Vec<StoredCluster<'a>>,
    /// `SkinningType`.
    pub method: SkinningMethod,
    /// `Indexes` and `BlendWeights` paired.
    pub shares: Vec<(i64, f64)>,
}

/// A cluster's bone: its index in the skeleton and its bind `file_from_bone`.
pub type BoneOf<'a> = dyn Fn(&Object) -> Option<(usize, Matrix4<f64>)> + 'a;

/// The first skin of `geometry`, as stored.
pub fn stored_skin<'a>(document: &'a Document, geometry: &Object) -> Result<Option<StoredSkin<'a>>, String> {
    let Some(skin) = deformers(document, geometry, "Skin").next() else { return Ok(None) };
    let node = document.node(skin);
    let method = match node.child_string("SkinningType") {
        Some("Rigid") => SkinningMethod::Rigid,
        Some("DualQuaternion") => SkinningMethod::DualQuaternion,
        Some("Blend") => SkinningMethod::Blend,
        _ => SkinningMethod::Linear,
    };
    let shares = match (node.child_ints("Indexes"), node.child_floats("BlendWeights")) {
        (Ok(i), Ok(w)) => i.into_iter().zip(w).collect(),
        _ => Vec::new(),
    };
    let mut clusters = Vec::new();
    for cluster in document.sources(skin).map(|(o, _)| o).filter(|o| o.class == "Deformer" && o.subclass == "Cluster") {
        let Some(bone) = document.sources(cluster).map(|(o, _)| o).find(|o| o.class == "Model") else { continue };
        let node = document.node(cluster);
        let weights = match (node.child_ints("Indexes"), node.child_floats("Weights")) {
            (Ok(i), Ok(w)) if i.len() == w.len() => i.into_iter().zip(w).collect(),
            (Ok(i), Ok(w)) => {
                return Err(format!("cluster '{}' has {} indexes but {} weights", cluster.name, i.len(), w.len()));
            }
            _ => Vec::new(), // a cluster that deforms nothing
        };
        let transform = matrix(node.child_value("Transform"));
        let transform_link = matrix(node.child_value("TransformLink"));
        clusters.push(StoredCluster { bone, transform, transform_link, weights });
    }
    Ok(Some(StoredSkin { clusters, method, shares }))
}

/// A 4×4 matrix stored as 16 finite numbers, column by column.
pub fn matrix(value: Option<&Value>) -> Option<Matrix4<f64>> {
    let numbers = value?.floats()?;
    (numbers.len() == 16 && numbers.iter().all(|v| v.is_finite())).then(|| Matrix4::from_column_slice(&numbers))
}

/// The skin of a mesh of `vertex_count` points from its stored clusters:
/// `bone_of` gives each cluster's bone index, `mesh_at_bind` the
/// mesh node's `file_from_node` when a cluster lacks its `Transform`.
pub fn skin(
    stored: &StoredSkin<'_>,
    vertex_count: usize,
    geometric: &Matrix4<f64>,
    bone_of: &BoneOf<'_>,
    mesh_at_bind: &Matrix4<f64>,
) -> Skin {
    let (method, shares) = (stored.method, &stored.shares);
    let mut clusters = Vec::new();
    let mut weights: Vec<Vec<(u32, f64)>> = vec![Vec::new(); vertex_count];
    for c in &stored.clusters {
        let Some((bone, bone_bind)) = bone_of(c.bone) else { continue };
        let bone_from_mesh = match (c.transform, c.transform_link) {
            (Some(transform), Some(_)) => transform,
            _ => bone_bind.try_inverse().unwrap_or_else(Matrix4::identity) * mesh_at_bind,
        };
        let index = clusters.len() as u32;
        clusters.push(Cluster { bone, bone_from_geometry: bone_from_mesh * geometric });
        for &(vertex, weight) in &c.weights {
            // Vertices outside the mesh are ignored, as the FBX SDK does.
            if let Some(slot) = usize::try_from(vertex).ok().and_then(|v| weights.get_mut(v)) {
                slot.push((index, weight));
            }
        }
    }
    let default_share = if method == SkinningMethod::DualQuaternion { 1.0 } else { 0.0 };
    let mut share = Vec::new();
    if !shares.is_empty() {
        share = vec![default_share; vertex_count];
        for &(vertex, s) in shares.iter() {
            if let Some(slot) = usize::try_from(vertex).ok().and_then(|v| share.get_mut(v)) {
                *slot = if s.is_finite() { s.clamp(0.0, 1.0) } else { default_share };
            }
        }
    }
    let method = if method == SkinningMethod::Blend && share.is_empty() { SkinningMethod::Linear } else { method };
    Skin::from_weights(method, clusters, weights, share)
}

/// The blend-shape channels of `geometry`: every BlendShape's channels in
/// connection order, each with its targets (in-betweens) by full weight.
/// `blender` files reuse `FullWeights` as per-point weights of one target.
pub fn shape_channels(
    document: &Document,
    geometry: &Object,
    vertex_count: usize,
    blender: bool,
) -> Result<Vec<ShapeChannel>, String> {
    let mut channels = Vec::new();
    for blend_shape in deformers(document, geometry, "BlendShape") {
        for channel in document.sources(blend_shape).map(|(o, _)| o).filter(|o| o.subclass == "BlendShapeChannel") {
            channels.push(shape_channel(document, channel, vertex_count, blender)?);
        }
    }
    Ok(channels)
}

fn shape_channel(
    document: &Document,
    channel: &Object,
    vertex_count: usize,
    blender: bool,
) -> Result<ShapeChannel, String> {
    let node = document.node(channel);
    let percent = document
        .number(channel, "DeformPercent")
        .or_else(|| node.child_number("DeformPercent"))
        .filter(|p| p.is_finite())
        .unwrap_or(0.0);
    let full_weights = node.child_floats("FullWeights").unwrap_or_default();
    let shapes: Vec<&Object> =
        document.sources(channel).map(|(o, _)| o).filter(|o| o.class == "Geometry" && o.subclass == "Shape").collect();
    let mut targets = Vec::new();
    for (i, shape) in shapes.iter().enumerate() {
        let shape_node = document.node(shape);
        let indices = shape_node.child_ints("Indexes")?;
        let offsets = shape_node.child_floats("Vertices")?;
        if offsets.len() != 3 * indices.len() {
            return Err(format!(
                "shape '{}' has {} indexes but {} offsets",
                shape.name,
                indices.len(),
                offsets.len() / 3
            ));
        }
        let per_point = blender && shapes.len() == 1 && full_weights.len() == indices.len() && indices.len() != 1;
        let mut target = ShapeTarget {
            full_weight: match per_point {
                true => 1.0,
                false => full_weights.get(i).map_or(1.0, |w| w / 100.0),
            },
            indices: Vec::with_capacity(indices.len()),
            offsets: Vec::with_capacity(indices.len()),
        };
        for (k, (&index, offset)) in indices.iter().zip(offsets.chunks_exact(3)).enumerate() {
            let Some(index) = u32::try_from(index).ok().filter(|&v| (v as usize) < vertex_count) else { continue };
            let scale = if per_point { full_weights[k] / 100.0 } else { 1.0 };
            let offset = Vector3::new(offset[0], offset[1], offset[2]) * scale;
            if offset.iter().all(|c| c.is_finite()) {
                target.indices.push(index);
                target.offsets.push(offset);
            }
        }
        targets.push(target);
    }
    targets.sort_by(|a, b| a.full_weight.total_cmp(&b.full_weight));
    Ok(ShapeChannel { name: channel.name.clone(), percent, targets })
}
