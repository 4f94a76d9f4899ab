//! glTF 2.0 as one binary `.glb`: every mesh split at its UV seams, with
//! one morph target per exported keyframe (positions and normals as
//! offsets from the first frame) and an animation of the morph weights
//! moving linearly from one keyframe's target to the next; materials as
//! metallic-roughness PBR, cloth with `KHR_materials_sheen`. Optionally
//! quantized (`KHR_mesh_quantization`): positions and offsets as 16-bit
//! integers scaled by the node.

use std::borrow::Cow;
use std::io::{self, Write};

use gltf_json as json;
use json::accessor::{ComponentType, GenericComponentType, Type};
use json::validation::Checked::Valid;
use json::validation::USize64;
use nalgebra::Vector3;

use super::Work;
use super::content::{Content, Look, Role};
use crate::mesh::seams::{SeamSplit, split_at_uv_seams};

/// How the glTF is made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    /// A keyframe (morph target) every this many frames; the last frame is always one.
    pub every: usize,
    /// Positions, offsets and normals as 16-bit integers.
    pub quantize: bool,
}

/// The binary chunk being filled, and the document that describes it.
struct Builder {
    root: json::Root,
    bin: Vec<u8>,
}

impl Builder {
    /// A buffer view over `bytes` (4-byte aligned), for vertex data with `stride` when given.
    fn view(
        &mut self,
        bytes: &[u8],
        target: Option<json::buffer::Target>,
        stride: Option<usize>,
    ) -> json::Index<json::buffer::View> {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: stride.map(json::buffer::Stride),
            extensions: None,
            extras: None,
            name: None,
            target: target.map(Valid),
        })
    }

    /// An accessor of `count` elements of `kind` in a new view of `bytes`.
    /// `bounds`: the lowest and highest value of each component, as stored.
    fn accessor(
        &mut self,
        bytes: &[u8],
        count: usize,
        kind: Kind,
        bounds: Option<(json::Value, json::Value)>,
    ) -> json::Index<json::Accessor> {
        let stride =
            (kind.target == Some(json::buffer::Target::ArrayBuffer) && kind.stride != kind.size).then_some(kind.stride);
        let view = self.view(bytes, kind.target, stride);
        let (min, max) = bounds.map_or((None, None), |(lo, hi)| (Some(lo), Some(hi)));
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(GenericComponentType(kind.component)),
            extensions: None,
            extras: None,
            type_: Valid(kind.shape),
            min,
            max,
            name: None,
            normalized: kind.normalized,
            sparse: None,
        })
    }
}

/// How an accessor's elements are stored.
#[derive(Clone, Copy)]
struct Kind {
    component: ComponentType,
    shape: Type,
    normalized: bool,
    target: Option<json::buffer::Target>,
    /// Bytes per element as stored (vertex data is padded to 4 bytes).
    stride: usize,
    /// Bytes per element.
    size: usize,
}

const VEC3: Kind = Kind {
    component: ComponentType::F32,
    shape: Type::Vec3,
    normalized: false,
    target: Some(json::buffer::Target::ArrayBuffer),
    stride: 12,
    size: 12,
};
const VEC2: Kind = Kind { shape: Type::Vec2, stride: 8, size: 8, ..VEC3 };
const SHORT3: Kind = Kind { component: ComponentType::I16, normalized: true, stride: 8, size: 6, ..VEC3 };
const SCALARS: Kind = Kind { shape: Type::Scalar, target: None, stride: 4, size: 4, ..VEC3 };
const VERTEX_INDEX: Kind = Kind { shape: Type::Scalar, stride: 4, size: 4, ..VEC3 };
const INDICES: Kind = Kind {
    component: ComponentType::U32,
    shape: Type::Scalar,
    normalized: false,
    target: Some(json::buffer::Target::ElementArrayBuffer),
    stride: 4,
    size: 4,
};

/// Writes `content` as a `.glb` into `w`.
pub fn write(content: &Content<'_>, options: Options, w: &mut impl Write, work: &Work<'_>) -> io::Result<()> {
    let mut builder = Builder { root: json::Root::default(), bin: Vec::new() };
    builder.root.asset.generator = Some(format!("drape {}", env!("CARGO_PKG_VERSION")));
    let keyframes = keyframes(&content.frame_numbers, options.every);
    let materials: Vec<_> = content.looks.iter().map(|look| material(&mut builder, look)).collect::<io::Result<_>>()?;
    let times: Vec<f32> = keyframes.iter().map(|&f| ((f - keyframes[0]) as f64 / content.fps) as f32).collect();
    let time_bounds = (json::Value::from(vec![times[0]]), json::Value::from(vec![times[times.len() - 1]]));
    let input = builder.accessor(&f32_bytes(&times), times.len(), SCALARS, Some(time_bounds));
    let (mut nodes, mut channels, mut samplers) = (Vec::new(), Vec::new(), Vec::new());
    for m in 0..content.meshes.len() {
        let animated = content.moves(m) && keyframes.len() > 1;
        let frames: &[usize] = if animated { &keyframes } else { &keyframes[..1] };
        let node = mesh_node(&mut builder, content, m, frames, &materials, options.quantize)?;
        if animated {
            samplers.push(weights_sampler(&mut builder, input, frames.len() - 1));
            channels.push(json::animation::Channel {
                sampler: json::Index::new(samplers.len() as u32 - 1),
                target: json::animation::Target {
                    extensions: None,
                    extras: None,
                    node,
                    path: Valid(json::animation::Property::MorphTargetWeights),
                },
                extensions: None,
                extras: None,
            });
        }
        nodes.push(node);
        work.done((m + 1) * content.frame_numbers.len())?;
    }
    if !channels.is_empty() {
        builder.root.push(json::Animation {
            extensions: None,
            extras: None,
            name: Some("bake".into()),
            channels,
            samplers,
        });
    }
    let scene = builder.root.push(json::Scene { extensions: None, extras: None, name: Some("drape".into()), nodes });
    builder.root.scene = Some(scene);
    finish(builder, options.quantize, w)
}

/// The keyframes: every `every`-th exported frame, and the last.
fn keyframes(frames: &[usize], every: usize) -> Vec<usize> {
    let mut keys: Vec<usize> = frames.iter().step_by(every.max(1)).copied().collect();
    if keys.last() != frames.last() {
        keys.extend(frames.last());
    }
    keys
}

/// The buffer, the extensions used, and the GLB container.
fn finish(mut builder: Builder, quantize: bool, w: &mut impl Write) -> io::Result<()> {
    while !builder.bin.len().is_multiple_of(4) {
        builder.bin.push(0);
    }
    builder.root.push(json::Buffer {
        byte_length: USize64::from(builder.bin.len()),
        extensions: None,
        extras: None,
        name: None,
        uri: None,
    });
    builder.root.extensions_used.push("KHR_materials_sheen".into());
    if quantize {
        builder.root.extensions_used.push("KHR_mesh_quantization".into());
        builder.root.extensions_required.push("KHR_mesh_quantization".into());
    }
    let json = json::serialize::to_vec(&builder.root).map_err(io::Error::other)?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header { magic: *b"glTF", version: 2, length: 0 },
        json: Cow::Owned(json),
        bin: Some(Cow::Owned(builder.bin)),
    };
    glb.to_writer(w).map_err(|e| io::Error::other(e.to_string()))
}

/// A metallic-roughness material; cloth also gets its sheen; a texture is embedded.
fn material(builder: &mut Builder, look: &Look) -> io::Result<json::Index<json::Material>> {
    let mut extensions = json::extensions::material::Material::default();
    if let Some((color, roughness)) = look.sheen {
        let sheen = serde_json::json!({ "sheenColorFactor": color, "sheenRoughnessFactor": roughness });
        extensions.others.insert("KHR_materials_sheen".into(), sheen);
    }
    let texture = match &look.texture {
        Some(path) => Some(embedded_texture(builder, path)?),
        None => None,
    };
    let [r, g, b] = if texture.is_some() { [1.0; 3] } else { look.base_color };
    Ok(builder.root.push(json::Material {
        name: Some(look.name.clone()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor([r, g, b, 1.0]),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(look.roughness),
            base_color_texture: texture.map(|index| json::texture::Info {
                index,
                tex_coord: 0,
                extensions: None,
                extras: None,
            }),
            ..Default::default()
        },
        double_sided: true,
        extensions: Some(extensions),
        ..Default::default()
    }))
}

/// An image file embedded in the binary chunk, as a texture.
fn embedded_texture(builder: &mut Builder, path: &std::path::Path) -> io::Result<json::Index<json::Texture>> {
    let bytes = std::fs::read(path).map_err(|e| io::Error::new(e.kind(), format!("{}: {e}", path.display())))?;
    let jpeg = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("jpg") || e.eq_ignore_ascii_case("jpeg"));
    let view = builder.view(&bytes, None, None);
    let image = builder.root.push(json::Image {
        buffer_view: Some(view),
        mime_type: Some(json::image::MimeType(if jpeg { "image/jpeg" } else { "image/png" }.into())),
        name: path.file_name().map(|n| n.to_string_lossy().into_owned()),
        uri: None,
        extensions: None,
        extras: None,
    });
    Ok(builder.root.push(json::Texture { name: None, sampler: None, source: image, extensions: None, extras: None }))
}

/// The animation sampler of a mesh with `targets` morph targets: all zero at
/// the first keyframe, then target k alone at keyframe k + 1 (a sparse
/// accessor: one value per keyframe, whatever the count).
fn weights_sampler(
    builder: &mut Builder,
    input: json::Index<json::Accessor>,
    targets: usize,
) -> json::animation::Sampler {
    let keys = targets + 1;
    let indices: Vec<u8> = (1..keys).flat_map(|k| ((k * targets + k - 1) as u32).to_le_bytes()).collect();
    let index_view = builder.view(&indices, None, None);
    let value_view = builder.view(&f32_bytes(&vec![1.0; targets]), None, None);
    let output = builder.root.push(json::Accessor {
        buffer_view: None,
        byte_offset: None,
        count: USize64::from(keys * targets),
        component_type: Valid(GenericComponentType(ComponentType::F32)),
        extensions: None,
        extras: None,
        type_: Valid(Type::Scalar),
        min: None,
        max: None,
        name: None,
        normalized: false,
        sparse: Some(json::accessor::sparse::Sparse {
            count: USize64::from(targets),
            indices: json::accessor::sparse::Indices {
                buffer_view: index_view,
                byte_offset: USize64(0),
                component_type: Valid(json::accessor::IndexComponentType(ComponentType::U32)),
                extensions: None,
                extras: None,
            },
            values: json::accessor::sparse::Values {
                buffer_view: value_view,
                byte_offset: USize64(0),
                extensions: None,
                extras: None,
            },
            extensions: None,
            extras: None,
        }),
    });
    json::animation::Sampler {
        extensions: None,
        extras: None,
        input,
        interpolation: Valid(json::animation::Interpolation::Linear),
        output,
    }
}

/// Mesh `m` at its keyframes `frames`: its node, with the mesh, its
/// primitives (one per part) and its morph targets.
fn mesh_node(
    builder: &mut Builder,
    content: &Content<'_>,
    m: usize,
    frames: &[usize],
    materials: &[json::Index<json::Material>],
    quantize: bool,
) -> io::Result<json::Index<json::Node>> {
    let mesh = &content.meshes[m];
    let split = split_at_uv_seams(
        &crate::mesh::TriMesh {
            positions: Vec::new(),
            triangles: mesh.triangles.clone(),
            quads: Vec::new(),
            surface: mesh.surface.clone(),
        },
        0..mesh.triangles.len(),
    );
    let shapes: Vec<Shape> = frames.iter().map(|&f| split_shape(content, m, f, &split)).collect::<io::Result<_>>()?;
    let Shape { points: base, normals: base_normals } = &shapes[0];
    let placement = quantize.then(|| Quantized::fitting(&shapes));
    let position = positions_accessor(builder, base, placement.as_ref());
    let normal = builder.accessor(&vec3_bytes(base_normals), base_normals.len(), VEC3, None);
    let uvs: Vec<f32> = split.uvs.iter().flat_map(|&[u, v]| [u, 1.0 - v]).collect();
    let texcoord =
        (!mesh.surface.uvs.is_empty()).then(|| builder.accessor(&f32_bytes(&uvs), split.uvs.len(), VEC2, None));
    // Which of the bake's (welded) vertices each split vertex is: the map
    // back to the OBJ and the point caches (as floats: glTF attributes
    // cannot be 32-bit integers; exact up to 16 million vertices).
    let welded: Vec<f32> = split.vertices.iter().map(|&v| v as f32).collect();
    let welded = builder.accessor(&f32_bytes(&welded), split.vertices.len(), VERTEX_INDEX, None);
    let mut targets = Vec::new();
    for Shape { points: shape, normals } in &shapes[1..] {
        let offsets: Vec<Vector3<f64>> = shape.iter().zip(base).map(|(a, b)| a - b).collect();
        let normal_offsets: Vec<Vector3<f64>> = normals.iter().zip(base_normals).map(|(a, b)| a - b).collect();
        let positions = offsets_accessor(builder, &offsets, placement.as_ref());
        let normals = match placement {
            Some(_) => builder.accessor(&short_bytes(&normal_offsets, 1.0), normal_offsets.len(), SHORT3, None),
            None => builder.accessor(&vec3_bytes(&normal_offsets), normal_offsets.len(), VEC3, None),
        };
        targets.push(json::mesh::MorphTarget { positions: Some(positions), normals: Some(normals), tangents: None });
    }
    let mut primitives = Vec::new();
    for part in &mesh.parts {
        let indices: Vec<u32> =
            part.triangles.iter().flat_map(|&t| split.indices[3 * t..3 * t + 3].iter().copied()).collect();
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let index = builder.accessor(&bytes, indices.len(), INDICES, None);
        let mut attributes = std::collections::BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), position);
        attributes.insert(Valid(json::mesh::Semantic::Normals), normal);
        if let Some(t) = texcoord {
            attributes.insert(Valid(json::mesh::Semantic::TexCoords(0)), t);
        }
        attributes.insert(Valid(json::mesh::Semantic::Extras("DRAPE_VERTEX".into())), welded);
        primitives.push(json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: None,
            indices: Some(index),
            material: materials.get(part.look).copied(),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: (!targets.is_empty()).then(|| targets.clone()),
        });
    }
    let names: Vec<String> = frames[1..].iter().map(|f| format!("frame_{f:04}")).collect();
    let extras = (!names.is_empty())
        .then(|| serde_json::value::to_raw_value(&serde_json::json!({ "targetNames": names })))
        .transpose()
        .map_err(io::Error::other)?;
    let weights = (!targets.is_empty()).then(|| vec![0.0; targets.len()]);
    let index =
        builder.root.push(json::Mesh { extensions: None, extras, name: Some(mesh.name.clone()), primitives, weights });
    let (translation, scale) = placement.map_or((None, None), |q| (Some(q.centre), Some([q.scale; 3])));
    Ok(builder.root.push(json::Node {
        mesh: Some(index),
        name: Some(mesh.name.clone()),
        translation,
        scale,
        extras: role_extras(mesh.role)?,
        ..Default::default()
    }))
}

/// What a node holds, for readers: `{"drape": "garment"}`.
fn role_extras(role: Role) -> io::Result<Option<Box<serde_json::value::RawValue>>> {
    let name = match role {
        Role::Garment => "garment",
        Role::Body => "body",
        Role::Collider => "collider",
    };
    serde_json::value::to_raw_value(&serde_json::json!({ "drape": name })).map(Some).map_err(io::Error::other)
}

/// A mesh's positions and normals at one frame, on its split vertices.
struct Shape {
    points: Vec<Vector3<f64>>,
    normals: Vec<Vector3<f64>>,
}

/// Mesh `m`'s shape at `frame`.
fn split_shape(content: &Content<'_>, m: usize, frame: usize, split: &SeamSplit) -> io::Result<Shape> {
    let mut points = Vec::new();
    content.positions(m, frame, &mut points);
    if let Some(bad) = points.iter().position(|p| !p.iter().all(|c| (*c as f32).is_finite())) {
        let why = format!("{}: vertex {bad} at frame {frame} is not a finite number", content.meshes[m].name);
        return Err(io::Error::new(io::ErrorKind::InvalidData, why));
    }
    let normals = content.normals(m, &points);
    let pick = |values: &[Vector3<f64>]| {
        split.vertices.iter().map(|&v| values.get(v as usize).copied().unwrap_or_default()).collect()
    };
    Ok(Shape { points: pick(&points), normals: pick(&normals) })
}

/// Positions as 16-bit integers: the node places them (`centre`, uniform
/// `scale`) so every frame's positions, and every offset between two, fit.
#[derive(Clone, Copy)]
struct Quantized {
    centre: [f32; 3],
    scale: f32,
}

impl Quantized {
    /// Fitting every shape: the scale is twice the largest distance from the
    /// centre, so offsets (up to twice that) fit too.
    fn fitting(shapes: &[Shape]) -> Quantized {
        let all = shapes.iter().flat_map(|s| s.points.iter());
        let first = shapes.first().and_then(|s| s.points.first()).copied().unwrap_or_default();
        let (low, high) = all.clone().fold((first, first), |(l, h), p| (l.inf(p), h.sup(p)));
        let centre = (low + high) / 2.0;
        let reach = all.map(|p| (p - centre).amax()).fold(0.0, f64::max);
        let scale = (2.0 * reach).max(1e-9);
        Quantized { centre: [centre.x as f32, centre.y as f32, centre.z as f32], scale: scale as f32 }
    }

    fn local(&self, p: &Vector3<f64>) -> Vector3<f64> {
        (p - Vector3::from(self.centre.map(f64::from))) / f64::from(self.scale)
    }
}

fn positions_accessor(
    builder: &mut Builder,
    points: &[Vector3<f64>],
    q: Option<&Quantized>,
) -> json::Index<json::Accessor> {
    match q {
        None => builder.accessor(&vec3_bytes(points), points.len(), VEC3, Some(bounds(points))),
        Some(q) => {
            let local: Vec<Vector3<f64>> = points.iter().map(|p| q.local(p)).collect();
            let bytes = short_bytes(&local, 1.0);
            builder.accessor(&bytes, local.len(), SHORT3, Some(short_bounds(&bytes)))
        }
    }
}

fn offsets_accessor(
    builder: &mut Builder,
    offsets: &[Vector3<f64>],
    q: Option<&Quantized>,
) -> json::Index<json::Accessor> {
    match q {
        None => builder.accessor(&vec3_bytes(offsets), offsets.len(), VEC3, Some(bounds(offsets))),
        Some(q) => {
            let bytes = short_bytes(offsets, 1.0 / f64::from(q.scale));
            builder.accessor(&bytes, offsets.len(), SHORT3, Some(short_bounds(&bytes)))
        }
    }
}

/// Per-component lowest and highest values, as f32 (what the accessor stores).
fn bounds(points: &[Vector3<f64>]) -> (json::Value, json::Value) {
    let mut low = vec![f32::INFINITY; 3];
    let mut high = vec![f32::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            low[k] = low[k].min(p[k] as f32);
            high[k] = high[k].max(p[k] as f32);
        }
    }
    (json::Value::from(low), json::Value::from(high))
}

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

fn vec3_bytes(points: &[Vector3<f64>]) -> Vec<u8> {
    points.iter().flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]).flat_map(f32::to_le_bytes).collect()
}

/// Vectors times `scale` as normalized 16-bit integers (clamped to ±1),
/// each padded to 8 bytes.
fn short_bytes(vectors: &[Vector3<f64>], scale: f64) -> Vec<u8> {
    let short = |x: f64| ((x * scale).clamp(-1.0, 1.0) * 32767.0).round() as i16;
    vectors.iter().flat_map(|v| [short(v.x), short(v.y), short(v.z), 0]).flat_map(i16::to_le_bytes).collect()
}

/// The lowest and highest stored integers of 16-bit vectors padded to 8
/// bytes (normalized accessors give their bounds as the integers stored).
fn short_bounds(bytes: &[u8]) -> (json::Value, json::Value) {
    let mut low = vec![i64::MAX; 3];
    let mut high = vec![i64::MIN; 3];
    for element in bytes.chunks_exact(8) {
        for k in 0..3 {
            let v = i64::from(i16::from_le_bytes([element[2 * k], element[2 * k + 1]]));
            low[k] = low[k].min(v);
            high[k] = high[k].max(v);
        }
    }
    (json::Value::from(low), json::Value::from(high))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keyframes_step_and_always_end_on_the_last_frame() {
        assert_eq!(keyframes(&[0, 1, 2, 3, 4, 5, 6], 3), [0, 3, 6]);
        assert_eq!(keyframes(&[0, 1, 2, 3, 4, 5], 3), [0, 3, 5]);
        assert_eq!(keyframes(&[4, 5], 1), [4, 5]);
    }

    #[test]
    fn shorts_clamp_and_pad_to_eight_bytes() {
        let bytes = short_bytes(&[Vector3::new(0.5, -2.0, 1.0)], 1.0);
        assert_eq!(bytes.len(), 8);
        assert_eq!(i16::from_le_bytes([bytes[0], bytes[1]]), 16384);
        assert_eq!(i16::from_le_bytes([bytes[2], bytes[3]]), -32767);
        let (low, high) = short_bounds(&bytes);
        assert_eq!((low[2].as_i64(), high[2].as_i64()), (Some(32767), Some(32767)));
    }
}
