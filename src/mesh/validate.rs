//! Mesh validation: what is wrong with a garment mesh, what was repaired, and
//! what cannot be simulated at all.

use std::fmt;

use nalgebra::Vector3;

use super::topology::Topology;
use super::weld::find_coincident;
use super::{Part, TriMesh};

/// Vertices closer than this fraction of the mesh's bounding-box diagonal are one
/// vertex.
const WELD_TOLERANCE_OF_DIAGONAL: f64 = 1e-6;

/// A triangle whose area is below this fraction of its longest edge squared is
/// degenerate (its smallest angle is below ~1e-9 rad).
const DEGENERATE_AREA_RATIO: f64 = 1e-9;

/// Problems that make a mesh unusable.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    /// No triangles at all.
    #[error("the mesh has no triangles")]
    Empty,
    /// A coordinate is NaN or infinite.
    #[error("vertex {vertex} has a non-finite coordinate ({x}, {y}, {z})")]
    NonFinite {
        /// Vertex index (0-based).
        vertex: usize,
        /// Coordinates as read.
        x: f64,
        /// Coordinates as read.
        y: f64,
        /// Coordinates as read.
        z: f64,
    },
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index}, but there are only {count} vertices")]
    IndexOutOfRange {
        /// Triangle index (0-based).
        triangle: usize,
        /// The offending vertex index (0-based).
        index: u32,
        /// Number of vertices.
        count: usize,
    },
    /// Nothing is left once degenerate triangles are removed.
    #[error("all {0} triangles are degenerate (zero area)")]
    AllDegenerate(usize),
}

/// What validation found and repaired. Every count is a warning; none stops the
/// simulation.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct MeshReport {
    /// Vertices merged into a coincident earlier vertex (UV seams, group borders,
    /// duplicates in the file).
    pub welded_vertices: usize,
    /// Distinct vertices of the source file at the position of another (counted
    /// by the file reader; welded).
    pub duplicate_vertices: usize,
    /// Zero-area triangles, removed.
    pub degenerate_triangles: usize,
    /// Vertices used by no triangle, removed.
    pub isolated_vertices: usize,
    /// Edges shared by more than two triangles (kept; they get no bending element).
    pub non_manifold_edges: usize,
    /// Interior edges whose two triangles disagree on winding (kept; simulation
    /// does not depend on winding, shading of those faces may look flipped).
    pub inconsistent_windings: usize,
}

impl MeshReport {
    /// True when nothing was found.
    pub fn is_clean(&self) -> bool {
        *self == MeshReport { welded_vertices: self.welded_vertices, ..Default::default() }
    }

    /// One line per finding worth a warning (welding alone is normal and is not
    /// listed).
    pub fn warnings(&self) -> Vec<String> {
        let mut lines = Vec::new();
        let mut add = |count: usize, what: &str| {
            if count > 0 {
                lines.push(format!("{count} {what}"));
            }
        };
        add(self.duplicate_vertices, "duplicate vertex(es) at the position of another, welded into one");
        add(self.degenerate_triangles, "degenerate (zero-area) triangle(s) removed");
        add(self.isolated_vertices, "isolated vertex(es) used by no triangle removed");
        add(self.non_manifold_edges, "non-manifold edge(s) (shared by 3+ triangles) kept without bending");
        add(self.inconsistent_windings, "edge(s) with inconsistent triangle winding kept");
        lines
    }
}

impl fmt::Display for MeshReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} vertices welded", self.welded_vertices)?;
        for w in self.warnings() {
            write!(f, "; {w}")?;
        }
        Ok(())
    }
}

/// Checks `mesh`, welds coincident vertices, removes degenerate triangles and
/// isolated vertices (keeping the order of what remains), and reports.
pub fn clean(mut mesh: TriMesh) -> Result<(TriMesh, MeshReport), MeshError> {
    check_finite(&mesh.positions)?;
    check_indices(&mesh)?;
    if mesh.triangles.is_empty() {
        return Err(MeshError::Empty);
    }
    let mut report = MeshReport::default();

    let diagonal = mesh.bounds().map_or(0.0, |(lo, hi)| (hi - lo).norm());
    let welding = find_coincident(&mesh.positions, WELD_TOLERANCE_OF_DIAGONAL * diagonal.max(1e-12));
    report.welded_vertices = welding.merged;
    let weld = |v: u32| welding.representative[v as usize];
    for tri in &mut mesh.triangles {
        *tri = tri.map(weld);
    }
    for quad in &mut mesh.quads {
        *quad = quad.map(weld);
    }

    let keep: Vec<bool> = (0..mesh.triangles.len()).map(|t| !is_degenerate(&mesh, t)).collect();
    report.degenerate_triangles = keep.iter().filter(|k| !**k).count();
    if report.degenerate_triangles == mesh.triangles.len() {
        return Err(MeshError::AllDegenerate(mesh.triangles.len()));
    }
    retain_triangles(&mut mesh, &keep);
    mesh.quads.retain(|q| (0..4).all(|i| (i + 1..4).all(|j| q[i] != q[j])));

    report.isolated_vertices = remove_unused_vertices(&mut mesh) - welding.merged;
    let topology = Topology::new(&mesh.triangles);
    report.non_manifold_edges = topology.non_manifold_edges();
    report.inconsistent_windings = topology.inconsistent_windings;
    Ok((mesh, report))
}

fn check_finite(positions: &[Vector3<f64>]) -> Result<(), MeshError> {
    match positions.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(vertex) => {
            let p = positions[vertex];
            Err(MeshError::NonFinite { vertex, x: p.x, y: p.y, z: p.z })
        }
        None => Ok(()),
    }
}

fn check_indices(mesh: &TriMesh) -> Result<(), MeshError> {
    let count = mesh.positions.len();
    for (triangle, tri) in mesh.triangles.iter().enumerate() {
        if let Some(&index) = tri.iter().find(|&&i| i as usize >= count) {
            return Err(MeshError::IndexOutOfRange { triangle, index, count });
        }
    }
    Ok(())
}

fn is_degenerate(mesh: &TriMesh, t: usize) -> bool {
    let [a, b, c] = mesh.triangle_corners(t);
    let longest_sq = [(b - a), (c - b), (a - c)].iter().map(|e| e.norm_squared()).fold(0.0, f64::max);
    let twice_area = (b - a).cross(&(c - a)).norm();
    longest_sq == 0.0 || twice_area <= 2.0 * DEGENERATE_AREA_RATIO * longest_sq
}

/// Keeps the triangles flagged in `keep`, with their UV corners and part ranges.
fn retain_triangles(mesh: &mut TriMesh, keep: &[bool]) {
    let kept_before = |end: usize| keep[..end].iter().filter(|k| **k).count();
    let parts: Vec<Part> = mesh
        .surface
        .parts
        .iter()
        .map(|p| {
            let first = kept_before(p.first_triangle);
            Part {
                first_triangle: first,
                triangle_count: kept_before(p.first_triangle + p.triangle_count) - first,
                ..p.clone()
            }
        })
        .filter(|p| p.triangle_count > 0)
        .collect();
    mesh.surface.parts = parts;
    let mut flags = keep.iter();
    mesh.triangles.retain(|_| *flags.next().unwrap_or(&false));
    if !mesh.surface.triangle_uvs.is_empty() {
        let mut flags = keep.iter();
        mesh.surface.triangle_uvs.retain(|_| *flags.next().unwrap_or(&false));
    }
}

/// Drops vertices no triangle uses, renumbering the rest in their original order.
/// Returns how many were dropped.
fn remove_unused_vertices(mesh: &mut TriMesh) -> usize {
    let mut used = vec![false; mesh.positions.len()];
    for &v in mesh.triangles.iter().flatten() {
        used[v as usize] = true;
    }
    let mut new_index = vec![u32::MAX; used.len()];
    for (next, (old, _)) in used.iter().enumerate().filter(|(_, u)| **u).enumerate() {
        new_index[old] = next as u32;
    }
    let renumber = |v: u32| new_index[v as usize];
    for tri in &mut mesh.triangles {
        *tri = tri.map(renumber);
    }
    mesh.quads.retain(|q| q.iter().all(|&v| used[v as usize]));
    for quad in &mut mesh.quads {
        *quad = quad.map(renumber);
    }
    let mut flags = used.iter();
    mesh.positions.retain(|_| *flags.next().unwrap_or(&false));
    used.len() - mesh.positions.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    #[test]
    fn a_clean_grid_passes_unchanged() {
        let grid = generate::grid(1.0, 4);
        let (mesh, report) = clean(grid.clone()).unwrap();
        assert!(report.is_clean(), "{report}");
        assert_eq!(mesh, grid);
    }

    /// The defects of the `bad_mesh` scene, each found and repaired.
    #[test]
    fn duplicate_isolated_and_degenerate_are_each_reported() {
        let mut mesh = generate::grid(1.0, 3); // 9 vertices, 8 triangles
        assert_eq!(mesh.triangles[0][0], 0);
        mesh.positions.push(mesh.positions[0]); // 9: duplicate of vertex 0
        mesh.triangles[0][0] = 9;
        mesh.positions.push(Vector3::new(0.3, 0.0, 0.4)); // 10: isolated
        mesh.triangles.push([0, 1, 1]); // zero area
        mesh.surface.triangle_uvs.clear();
        let (cleaned, report) = clean(mesh).unwrap();
        assert_eq!(report.welded_vertices, 1);
        assert_eq!(report.isolated_vertices, 1);
        assert_eq!(report.degenerate_triangles, 1);
        assert_eq!(cleaned.positions.len(), 9);
        assert_eq!(cleaned.triangles, generate::grid(1.0, 3).triangles);
        assert_eq!(report.warnings().len(), 2);
    }

    #[test]
    fn three_triangles_on_an_edge_are_counted_non_manifold() {
        let mut mesh = generate::grid(1.0, 3);
        let [a, _, b] = mesh.triangles[0]; // the quad's diagonal: already two triangles
        mesh.positions.push(Vector3::new(0.0, 1.0, 0.0));
        mesh.triangles.push([a, b, 9]);
        let (_, report) = clean(mesh).unwrap();
        assert_eq!(report.non_manifold_edges, 1);
    }

    #[test]
    fn unusable_meshes_are_refused_with_the_reason() {
        let empty = TriMesh::default();
        assert_eq!(clean(empty).unwrap_err(), MeshError::Empty);

        let mut nan = generate::grid(1.0, 2);
        nan.positions[3].y = f64::NAN;
        assert!(matches!(clean(nan).unwrap_err(), MeshError::NonFinite { vertex: 3, .. }));

        let mut out_of_range = generate::grid(1.0, 2);
        out_of_range.triangles[1][2] = 7;
        assert_eq!(clean(out_of_range).unwrap_err(), MeshError::IndexOutOfRange { triangle: 1, index: 7, count: 4 });

        let mut flat = generate::grid(1.0, 2);
        for p in &mut flat.positions {
            p.z = 0.0;
        }
        assert!(matches!(clean(flat).unwrap_err(), MeshError::AllDegenerate(2)));
    }
}
