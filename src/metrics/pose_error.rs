//! How far a body as drape evaluates it is from the same character as
//! another application exported it (an OBJ written by Maya, 3ds Max,
//! MotionBuilder or Blender at a known frame): the check that drape reads a
//! designer's character the way their application shows it.
//!
//! The OBJ's groups are matched to the body's meshes by name (Maya names a
//! group after the node and its parents: `g pCube1 group1`), and each
//! polygon corner is compared with the same corner of the file's polygon,
//! in the file's own axes and units. Where an application reordered the
//! polygons, each corner is compared with the nearest one of the group.

use std::path::Path;

use nalgebra::Vector3;

use crate::body::{Body, BodyPart};

/// One mesh of a reference OBJ: its group names and its polygons' corners.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceMesh {
    /// The names on its `g` / `o` line.
    pub names: Vec<String>,
    /// Corner positions, polygons one after another, file units.
    pub corners: Vec<Vector3<f64>>,
    /// Corners per polygon.
    pub arities: Vec<u32>,
}

/// Reads the meshes of a reference OBJ (groups split by material are one
/// mesh again; `g default` and empty groups are left out).
pub fn read_reference(path: &Path) -> Result<Vec<ReferenceMesh>, String> {
    let options =
        tobj::LoadOptions { triangulate: false, ignore_points: true, ignore_lines: true, ..Default::default() };
    let (models, _) = tobj::load_obj(path, &options).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut meshes: Vec<ReferenceMesh> = Vec::new();
    for model in models {
        let m = &model.mesh;
        let arities: Vec<u32> = match m.face_arities.is_empty() {
            true => vec![3; m.indices.len() / 3],
            false => m.face_arities.clone(),
        };
        let corners = m.indices.iter().filter_map(|&i| {
            let p = m.positions.get(3 * i as usize..3 * i as usize + 3)?;
            Some(Vector3::new(p[0], p[1], p[2]))
        });
        let names: Vec<String> = model.name.split_whitespace().map(decode_fbx_ascii).collect();
        match meshes.last_mut().filter(|last| last.names == names) {
            Some(last) => {
                last.corners.extend(corners);
                last.arities.extend(arities);
            }
            None => meshes.push(ReferenceMesh { names, corners: corners.collect(), arities }),
        }
    }
    meshes.retain(|m| !m.corners.is_empty() && m.names != ["default"]);
    Ok(meshes)
}

/// A name as FBX exporters write it into OBJ files: characters an OBJ
/// name cannot hold are spelled `FBXASCnnn` (their code in decimal).
fn decode_fbx_ascii(name: &str) -> String {
    let mut out = Vec::new();
    let mut rest = name.as_bytes();
    while !rest.is_empty() {
        if let Some(tail) = rest.strip_prefix(b"FBXASC")
            && let Some(code) = tail.get(..3).and_then(|d| std::str::from_utf8(d).ok()?.parse::<u8>().ok())
        {
            out.push(code);
            rest = &tail[3..];
            continue;
        }
        out.push(rest[0]);
        rest = &rest[1..];
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The comparison of one reference mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshError {
    /// The reference mesh's group names.
    pub reference: String,
    /// The body part it was matched to, if any.
    pub part: Option<String>,
    /// Largest distance between matching corners, file units.
    pub max_distance: f64,
    /// The reference mesh's bounding-box diagonal, file units.
    pub diagonal: f64,
    /// Whether corners were matched by order (else by nearest position).
    pub ordered: bool,
}

impl MeshError {
    /// The largest distance as a percentage of the mesh's size.
    pub fn percent_of_diagonal(&self) -> f64 {
        if self.diagonal > 0.0 { 100.0 * self.max_distance / self.diagonal } else { 0.0 }
    }
}

/// Compares `positions` (the body's vertices, file space) with `reference`.
pub fn compare(body: &Body, positions: &[Vector3<f64>], reference: &[ReferenceMesh]) -> Vec<MeshError> {
    let mut used = vec![false; body.parts.len()];
    reference
        .iter()
        .map(|mesh| {
            let part = match_part(body, mesh, &used);
            if let Some(p) = part {
                used[p] = true;
            }
            let diagonal = diagonal(&mesh.corners);
            let Some(p) = part else {
                return MeshError {
                    reference: mesh.names.join(" "),
                    part: None,
                    max_distance: f64::INFINITY,
                    diagonal,
                    ordered: false,
                };
            };
            let ours = corner_positions(&body.parts[p], positions);
            let ordered = same_polygons(&body.parts[p], mesh);
            let max_distance = match ordered {
                true => polygon_distances(&ours, &mesh.corners, &mesh.arities),
                false => nearest_distances(&ours, &mesh.corners),
            };
            MeshError {
                reference: mesh.names.join(" "),
                part: Some(body.parts[p].name.clone()),
                max_distance,
                diagonal,
                ordered,
            }
        })
        .collect()
}

/// The part a reference mesh stands for: the one whose node and ancestors
/// bear its group names, else one named like the whole line or one of its
/// names, else the only part.
fn match_part(body: &Body, mesh: &ReferenceMesh, used: &[bool]) -> Option<usize> {
    let mut wanted = mesh.names.clone();
    wanted.sort();
    let free = |p: &usize| !used[*p];
    let lineage = |part: &BodyPart| {
        let mut names = Vec::new();
        let mut node = Some(part.node);
        while let Some(n) = node {
            let bone = &body.skeleton.bones[n];
            names.push(bone.name.clone());
            node = bone.parent;
        }
        names.sort();
        names
    };
    let all = 0..body.parts.len();
    let whole = mesh.names.join(" ");
    all.clone()
        .filter(free)
        .find(|&p| lineage(&body.parts[p]) == wanted)
        .or_else(|| all.clone().filter(free).find(|&p| body.parts[p].name == whole))
        .or_else(|| all.clone().filter(free).find(|&p| mesh.names.contains(&body.parts[p].name)))
        .or_else(|| {
            // Blender names a mesh's OBJ group `Object_Mesh`.
            let prefix = |n: &str| n.split('_').next().unwrap_or(n).to_owned();
            all.clone().filter(free).find(|&p| mesh.names.iter().any(|n| prefix(n) == body.parts[p].name))
        })
        .or_else(|| (body.parts.len() == 1).then_some(0))
}

/// The part's polygon corners at `positions` (the body's vertices).
fn corner_positions(part: &BodyPart, positions: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    part.polygons.corners.iter().filter_map(|&c| positions.get(part.first_vertex + c as usize).copied()).collect()
}

/// Whether the part's polygons and the reference's have the same sizes in the same order.
fn same_polygons(part: &BodyPart, mesh: &ReferenceMesh) -> bool {
    let sizes = part.polygons.starts.windows(2).map(|w| w[1] - w[0]);
    part.polygons.starts.len() == mesh.arities.len() + 1 && sizes.eq(mesh.arities.iter().copied())
}

/// The largest distance between the corners of each polygon and the same
/// polygon of the reference, its corners in the same cycle in either
/// direction (an application may start a polygon elsewhere, or reverse it
/// for a mirrored node).
fn polygon_distances(ours: &[Vector3<f64>], theirs: &[Vector3<f64>], arities: &[u32]) -> f64 {
    let mut start = 0;
    let mut worst: f64 = 0.0;
    for &n in arities {
        let n = n as usize;
        let (Some(a), Some(b)) = (ours.get(start..start + n), theirs.get(start..start + n)) else {
            return f64::INFINITY;
        };
        let arrangement = |shift: usize, reversed: bool| {
            (0..n)
                .map(|k| {
                    let j = if reversed { (shift + n - k) % n } else { (shift + k) % n };
                    (a[k] - b[j]).norm()
                })
                .fold(0.0, f64::max)
        };
        let best = (0..n)
            .flat_map(|shift| [arrangement(shift, false), arrangement(shift, true)])
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(best);
        start += n;
    }
    worst
}

/// The largest distance from any of `ours` to the nearest of `theirs`, and back.
fn nearest_distances(ours: &[Vector3<f64>], theirs: &[Vector3<f64>]) -> f64 {
    let one_way = |a: &[Vector3<f64>], b: &[Vector3<f64>]| {
        a.iter().map(|p| b.iter().map(|q| (p - q).norm()).fold(f64::INFINITY, f64::min)).fold(0.0, f64::max)
    };
    one_way(ours, theirs).max(one_way(theirs, ours))
}

/// The bounding-box diagonal of `points`.
fn diagonal(points: &[Vector3<f64>]) -> f64 {
    let Some(first) = points.first() else { return 0.0 };
    let (low, high) = points.iter().fold((*first, *first), |(l, h), p| (l.inf(p), h.sup(p)));
    (high - low).norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaped_names_are_decoded() {
        assert_eq!(decode_fbx_ascii("CubeFBXASC046001"), "Cube.001");
        assert_eq!(decode_fbx_ascii("FBXASC0500FBXASC032Sided"), "20 Sided");
        assert_eq!(decode_fbx_ascii("FBXASC9"), "FBXASC9");
    }

    #[test]
    fn polygons_match_in_any_cyclic_order_and_direction() {
        let square = [Vector3::zeros(), Vector3::x(), Vector3::new(1.0, 1.0, 0.0), Vector3::y()];
        let reversed = [square[2], square[1], square[0], square[3]];
        assert_eq!(polygon_distances(&square, &reversed, &[4]), 0.0);
        let moved: Vec<_> = square.iter().map(|p| p + Vector3::z() * 0.5).collect();
        assert_eq!(polygon_distances(&square, &moved, &[4]), 0.5);
    }

    #[test]
    fn nearest_distances_go_both_ways() {
        let a = [Vector3::zeros(), Vector3::x()];
        let b = [Vector3::zeros()];
        assert_eq!(nearest_distances(&a, &b), 1.0);
        assert_eq!(diagonal(&[Vector3::zeros(), Vector3::new(3.0, 4.0, 0.0)]), 5.0);
    }
}
