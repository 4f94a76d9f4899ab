//! A mesh Geometry: control points, polygons (fanned into triangles), the
//! first UV set and the material of each polygon.

use std::collections::BTreeMap;

use nalgebra::Vector3;

use super::tree::Node;
use crate::mesh::Surface;

/// Most control points, polygon corners or UVs accepted from one mesh (a
/// guard against absurd files, far above any body).
pub const MAX_ARRAY: usize = 50_000_000;

/// A mesh as stored: control points in the mesh's frame (file units), its
/// polygons, and the triangles drawn from them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    /// Control points, mesh frame, file units.
    pub positions: Vec<Vector3<f64>>,
    /// Every polygon's control points, polygons one after another.
    pub corners: Vec<u32>,
    /// Where each polygon starts in `corners` (one more entry: the end).
    pub polygon_starts: Vec<u32>,
    /// Triangles (polygons fanned), grouped by material, file order within.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle, the material index of its polygon (ascending runs).
    pub triangle_materials: Vec<usize>,
    /// UVs and the UV of each triangle corner.
    pub surface: Surface,
}

/// Reads a `Geometry` node of subclass `Mesh`.
pub fn read(node: &Node) -> Result<Geometry, String> {
    let coordinates = node.child_floats("Vertices")?;
    let indices = node.child_ints("PolygonVertexIndex")?;
    if coordinates.len() / 3 > MAX_ARRAY || indices.len() > MAX_ARRAY {
        return Err("the mesh is larger than drape accepts".into());
    }
    let positions: Vec<Vector3<f64>> = coordinates.chunks_exact(3).map(|c| Vector3::new(c[0], c[1], c[2])).collect();
    if let Some(bad) = positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("vertex {bad} of the mesh is not a finite position"));
    }
    let (corners, polygon_starts) = polygons(&indices, positions.len())?;
    let uvs = uv_layer(node, &corners)?;
    let materials = material_layer(node, polygon_starts.len() - 1);
    let mut geometry = Geometry { positions, corners, polygon_starts, ..Default::default() };
    fan(&mut geometry, uvs.as_ref(), &materials);
    if let Some(layer) = uvs {
        geometry.surface.uvs = layer.uvs;
    }
    Ok(geometry)
}

/// Polygons from `PolygonVertexIndex`, where the last corner of each is
/// stored as `-(index + 1)`: the corners and where each polygon starts.
fn polygons(indices: &[i64], vertex_count: usize) -> Result<(Vec<u32>, Vec<u32>), String> {
    let mut corners = Vec::with_capacity(indices.len());
    let mut starts = vec![0];
    for (i, &c) in indices.iter().enumerate() {
        // `!c` is `-(c + 1)` without overflow.
        let (index, last) = if c < 0 { (!c, true) } else { (c, false) };
        let index = usize::try_from(index).ok().filter(|&v| v < vertex_count).ok_or_else(|| {
            format!("PolygonVertexIndex entry {i} refers to vertex {index}, but the mesh has {vertex_count}")
        })?;
        corners.push(index as u32);
        if last {
            starts.push(corners.len() as u32);
        }
    }
    // A last polygon without its end mark is closed where the list ends.
    if starts.last().is_some_and(|&s| s as usize != corners.len()) {
        starts.push(corners.len() as u32);
    }
    Ok((corners, starts))
}

/// A UV set: the UVs and, per polygon corner, which one it uses.
struct UvLayer {
    uvs: Vec<[f32; 2]>,
    index: Vec<u32>,
}

/// The first UV set, mapped by polygon corner or by control point.
fn uv_layer(node: &Node, corners: &[u32]) -> Result<Option<UvLayer>, String> {
    let Some(layer) = node.child("LayerElementUV") else { return Ok(None) };
    let uvs: Vec<[f32; 2]> = layer.child_floats("UV")?.chunks_exact(2).map(|c| [c[0] as f32, c[1] as f32]).collect();
    let direct = !matches!(layer.child_string("ReferenceInformationType"), Some("IndexToDirect") | Some("Index"));
    let per_entry: Vec<u32> = match direct {
        true => (0..uvs.len() as u32).collect(),
        false => layer.child_ints("UVIndex")?.into_iter().map(|i| u32::try_from(i).unwrap_or(u32::MAX)).collect(),
    };
    let index: Option<Vec<u32>> = match layer.child_string("MappingInformationType") {
        Some("ByPolygonVertex") => (per_entry.len() >= corners.len()).then(|| per_entry[..corners.len()].to_vec()),
        Some("ByControlPoint") | Some("ByVertice") | Some("ByVertex") => {
            corners.iter().map(|&v| per_entry.get(v as usize).copied()).collect()
        }
        _ => None,
    };
    let valid = |index: &Vec<u32>| !uvs.is_empty() && index.iter().all(|&i| (i as usize) < uvs.len());
    Ok(index.filter(valid).map(|index| UvLayer { uvs, index }))
}

/// Material index per polygon (all 0 without a layer or when `AllSame`).
fn material_layer(node: &Node, polygon_count: usize) -> Vec<usize> {
    let Some(layer) = node.child("LayerElementMaterial") else { return vec![0; polygon_count] };
    let Ok(indices) = layer.child_ints("Materials") else { return vec![0; polygon_count] };
    let index = |i: i64| usize::try_from(i).unwrap_or(0);
    match layer.child_string("MappingInformationType") {
        Some("ByPolygon") if indices.len() >= polygon_count => {
            indices[..polygon_count].iter().map(|&i| index(i)).collect()
        }
        _ => vec![indices.first().map_or(0, |&i| index(i)); polygon_count],
    }
}

/// Fans every polygon of three or more corners into triangles, grouped by
/// material (file order within a material), with their corners' UVs.
fn fan(geometry: &mut Geometry, uvs: Option<&UvLayer>, materials: &[usize]) {
    // Per material, each triangle's points and UVs.
    type Corners = ([u32; 3], [u32; 3]);
    let mut by_material: BTreeMap<usize, Vec<Corners>> = BTreeMap::new();
    for (p, bounds) in geometry.polygon_starts.windows(2).enumerate() {
        let (first, end) = (bounds[0] as usize, bounds[1] as usize);
        for k in first + 1..end.saturating_sub(1) {
            let picks = [first, k, k + 1];
            let vertices = picks.map(|i| geometry.corners[i]);
            let corner_uvs = uvs.map_or([0; 3], |layer| picks.map(|i| layer.index[i]));
            by_material.entry(materials.get(p).copied().unwrap_or(0)).or_default().push((vertices, corner_uvs));
        }
    }
    for (material, run) in by_material {
        for (vertices, corner_uvs) in run {
            geometry.triangles.push(vertices);
            geometry.triangle_materials.push(material);
            if uvs.is_some() {
                geometry.surface.triangle_uvs.push(corner_uvs);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::fbx::tree::Value;

    fn child(name: &str, value: Value) -> Node {
        Node { name: name.into(), values: vec![value], children: vec![] }
    }

    fn text(name: &str, value: &str) -> Node {
        child(name, Value::String(value.into()))
    }

    fn quad_and_triangle() -> Node {
        let uv = Node {
            name: "LayerElementUV".into(),
            values: vec![],
            children: vec![
                text("MappingInformationType", "ByControlPoint"),
                text("ReferenceInformationType", "Direct"),
                child("UV", Value::Floats(vec![0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 0.5, 2.0])),
            ],
        };
        let material = Node {
            name: "LayerElementMaterial".into(),
            values: vec![],
            children: vec![text("MappingInformationType", "ByPolygon"), child("Materials", Value::Ints(vec![1, 0]))],
        };
        Node {
            name: "Geometry".into(),
            values: vec![],
            children: vec![
                child("Vertices", Value::Floats(vec![0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0., 0.5, 2., 0.])),
                child("PolygonVertexIndex", Value::Ints(vec![0, 1, 2, -4, 3, 2, -5])),
                uv,
                material,
            ],
        }
    }

    #[test]
    fn polygons_are_fanned_and_grouped_by_material() {
        let g = read(&quad_and_triangle()).unwrap();
        assert_eq!(g.polygon_starts, vec![0, 4, 7]);
        // The triangle (material 0) comes before the quad's two (material 1).
        assert_eq!(g.triangles, vec![[3, 2, 4], [0, 1, 2], [0, 2, 3]]);
        assert_eq!(g.triangle_materials, vec![0, 1, 1]);
        // UVs by control point: each corner uses its vertex's UV.
        assert_eq!(g.surface.triangle_uvs, vec![[3, 2, 4], [0, 1, 2], [0, 2, 3]]);
    }

    #[test]
    fn indices_outside_the_mesh_are_errors() {
        let mut node = quad_and_triangle();
        node.children[1] = child("PolygonVertexIndex", Value::Ints(vec![0, 1, -10]));
        assert!(read(&node).unwrap_err().contains("refers to vertex 9"));
    }
}
