//! Procedural cloths that scene files can ask for without an OBJ: the square grid
//! of `SCENES.md` and the tube of the `twist` scene.

use nalgebra::Vector3;

use super::{Part, Surface, TriMesh};

/// A square cloth of `resolution` × `resolution` vertices and side `size_m`,
/// lying flat in the XZ plane, centred on the origin, front side facing +Y.
///
/// Each quad is split into two triangles with alternating diagonals (a
/// checkerboard), which keeps the cloth free of a preferred shear direction. The
/// quads are recorded so that both diagonals become shear springs. Vertex
/// `row * resolution + col` sits at `x = -size/2 + col·h`, `z = -size/2 + row·h`.
pub fn grid(size_m: f64, resolution: usize) -> TriMesh {
    rectangle(size_m, size_m, resolution, resolution)
}

/// A rectangular cloth `length_m` along X by `width_m` along Z with `columns`
/// vertices along X and `rows` along Z, flat in the XZ plane, centred on the
/// origin, front side facing +Y; triangulated like [`grid`]. Vertex
/// `row * columns + col` sits at `x = -length/2 + col·length/(columns−1)`,
/// `z = -width/2 + row·width/(rows−1)`.
pub fn rectangle(length_m: f64, width_m: f64, columns: usize, rows: usize) -> TriMesh {
    let (dx, dz) = (length_m / (columns - 1) as f64, width_m / (rows - 1) as f64);
    let index = |row: usize, col: usize| (row * columns + col) as u32;
    let positions = (0..rows)
        .flat_map(|row| {
            (0..columns)
                .map(move |col| Vector3::new(-0.5 * length_m + col as f64 * dx, 0.0, -0.5 * width_m + row as f64 * dz))
        })
        .collect();
    let uvs = (0..rows)
        .flat_map(|row| {
            (0..columns).map(move |col| [col as f32 / (columns - 1) as f32, row as f32 / (rows - 1) as f32])
        })
        .collect();
    let mut quads = Vec::with_capacity((rows - 1) * (columns - 1));
    for row in 0..rows - 1 {
        for col in 0..columns - 1 {
            // Counter-clockwise seen from +Y: (row, col) → (row+1, col) → (row+1, col+1) → (row, col+1).
            let corners = [index(row, col), index(row + 1, col), index(row + 1, col + 1), index(row, col + 1)];
            let quad = if (row + col) % 2 == 0 { corners } else { [corners[1], corners[2], corners[3], corners[0]] };
            quads.push(quad);
        }
    }
    from_quads(positions, quads, uvs, None, "grid")
}

/// A round cloth of radius `radius_m` cut from a square grid of `across`
/// vertices over the diameter (the threads of a woven run along X and Z):
/// the grid's quads whose four corners lie within the radius, flat in the XZ
/// plane, centred on the origin, front side facing +Y, triangulated like
/// [`grid`]. Vertices keep the grid's row-major order.
pub fn disc(radius_m: f64, across: usize) -> TriMesh {
    let square = grid(2.0 * radius_m, across);
    let inside = |v: u32| square.positions[v as usize].xz().norm() <= radius_m * (1.0 + 1e-12);
    let kept: Vec<[u32; 4]> = square.quads.iter().filter(|q| q.iter().all(|&v| inside(v))).copied().collect();
    let mut new_index = vec![u32::MAX; square.positions.len()];
    for &v in kept.iter().flatten() {
        new_index[v as usize] = 0;
    }
    let mut positions = Vec::new();
    let mut uvs = Vec::new();
    for (old, slot) in new_index.iter_mut().enumerate() {
        if *slot == 0 {
            *slot = positions.len() as u32;
            positions.push(square.positions[old]);
            uvs.push(square.surface.uvs[old]);
        }
    }
    let quads = kept.iter().map(|q| q.map(|v| new_index[v as usize])).collect();
    from_quads(positions, quads, uvs, None, "disc")
}

/// An open tube of radius `radius_m` and length `length_m` along the X axis,
/// centred on the origin, with `around` vertices per ring and `along` rings;
/// front side facing outward.
///
/// Vertex `ring * around + k` sits at angle `2πk/around` on ring `ring`. The UVs
/// wrap once around, so the seam at `k = 0` has its own UV column (`u = 1`).
pub fn tube(radius_m: f64, length_m: f64, around: usize, along: usize) -> TriMesh {
    let ring_spacing = length_m / (along - 1) as f64;
    let angle = |k: usize| std::f64::consts::TAU * k as f64 / around as f64;
    let positions = (0..along)
        .flat_map(|ring| {
            (0..around).map(move |k| {
                let x = -0.5 * length_m + ring as f64 * ring_spacing;
                Vector3::new(x, radius_m * angle(k).cos(), radius_m * angle(k).sin())
            })
        })
        .collect();
    let uv_columns = around + 1;
    let uvs = (0..along)
        .flat_map(|ring| (0..uv_columns).map(move |k| [k as f32 / around as f32, ring as f32 / (along - 1) as f32]))
        .collect();
    let vertex = |ring: usize, k: usize| (ring * around + k % around) as u32;
    let uv = |ring: usize, k: usize| (ring * uv_columns + k) as u32;
    let mut quads = Vec::with_capacity((along - 1) * around);
    let mut quad_uvs = Vec::with_capacity(quads.capacity());
    for ring in 0..along - 1 {
        for k in 0..around {
            let corners = [(ring, k), (ring, k + 1), (ring + 1, k + 1), (ring + 1, k)];
            let rotate = (ring + k) % 2 == 1;
            let pick = |f: &dyn Fn(usize, usize) -> u32| {
                let q = corners.map(|(r, c)| f(r, c));
                if rotate { [q[1], q[2], q[3], q[0]] } else { q }
            };
            quads.push(pick(&vertex));
            quad_uvs.push(pick(&uv));
        }
    }
    from_quads(positions, quads, uvs, Some(quad_uvs), "tube")
}

/// Assembles a mesh from quads: triangles `(a, b, c)`, `(a, c, d)` per quad, UV
/// corners either from `quad_uvs` or equal to the vertex indices.
fn from_quads(
    positions: Vec<Vector3<f64>>,
    quads: Vec<[u32; 4]>,
    uvs: Vec<[f32; 2]>,
    quad_uvs: Option<Vec<[u32; 4]>>,
    name: &str,
) -> TriMesh {
    let split = |[a, b, c, d]: [u32; 4]| [[a, b, c], [a, c, d]];
    let triangles: Vec<[u32; 3]> = quads.iter().flat_map(|&q| split(q)).collect();
    let triangle_uvs = match quad_uvs {
        Some(q) => q.iter().flat_map(|&q| split(q)).collect(),
        None => triangles.clone(),
    };
    let part = Part { name: name.to_owned(), material: None, first_triangle: 0, triangle_count: triangles.len() };
    TriMesh {
        positions,
        triangles,
        quads,
        surface: Surface { uvs, triangle_uvs, materials: Vec::new(), parts: vec![part] },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::topology::Topology;

    #[test]
    fn grid_has_expected_counts_area_and_upward_normals() {
        let mesh = grid(1.0, 5);
        assert_eq!(mesh.vertex_count(), 25);
        assert_eq!(mesh.triangles.len(), 2 * 16);
        assert_eq!(mesh.quads.len(), 16);
        assert!((mesh.area() - 1.0).abs() < 1e-12);
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = mesh.triangle_corners(t);
            assert!((b - a).cross(&(c - a)).y > 0.0, "triangle {t} faces down");
        }
        let topo = Topology::new(&mesh.triangles);
        assert_eq!(topo.inconsistent_windings, 0);
        assert_eq!(topo.boundary_edges(), 16);
    }

    #[test]
    fn grid_alternates_its_diagonals() {
        let mesh = grid(1.0, 3);
        // Cell (0,0) splits along 0-4, cell (0,1) along 1-5... check by the first
        // triangle's first corner: it is the diagonal's start.
        let diagonal = |q: [u32; 4]| [q[0].min(q[2]), q[0].max(q[2])];
        assert_eq!(diagonal(mesh.quads[0]), [0, 4]);
        assert_eq!(diagonal(mesh.quads[1]), [2, 4]);
    }

    #[test]
    fn rectangle_spans_its_sides_with_its_counts() {
        let mesh = rectangle(0.2, 0.05, 9, 3);
        assert_eq!(mesh.vertex_count(), 27);
        assert_eq!(mesh.triangles.len(), 2 * 8 * 2);
        assert!((mesh.area() - 0.2 * 0.05).abs() < 1e-15);
        assert_eq!(mesh.positions[0], Vector3::new(-0.1, 0.0, -0.025));
        assert_eq!(mesh.positions[26], Vector3::new(0.1, 0.0, 0.025));
    }

    #[test]
    fn disc_is_the_grid_cut_round() {
        let (radius, across) = (0.15, 41);
        let mesh = disc(radius, across);
        let spacing = 2.0 * radius / (across - 1) as f64;
        assert!(mesh.positions.iter().all(|p| p.xz().norm() <= radius + 1e-12));
        // Every grid cell well inside the circle is kept, none outside it.
        let inner = std::f64::consts::PI * (radius - 1.5 * spacing).powi(2);
        let outer = std::f64::consts::PI * radius * radius;
        assert!(inner < mesh.area() && mesh.area() < outer, "{}", mesh.area());
        assert_eq!(mesh.triangles.len(), 2 * mesh.quads.len());
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = mesh.triangle_corners(t);
            assert!((b - a).cross(&(c - a)).y > 0.0, "triangle {t} faces down");
        }
        let topo = Topology::new(&mesh.triangles);
        assert_eq!(topo.inconsistent_windings, 0);
    }

    #[test]
    fn tube_is_closed_around_with_outward_normals_and_a_uv_seam() {
        let (radius, around, along) = (0.15, 16, 5);
        let mesh = tube(radius, 1.0, around, along);
        assert_eq!(mesh.vertex_count(), around * along);
        assert_eq!(mesh.surface.uvs.len(), (around + 1) * along);
        let topo = Topology::new(&mesh.triangles);
        assert_eq!(topo.boundary_edges(), 2 * around, "only the two end rings are open");
        assert_eq!(topo.inconsistent_windings, 0);
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = mesh.triangle_corners(t);
            let centre = (a + b + c) / 3.0;
            let radial = Vector3::new(0.0, centre.y, centre.z);
            assert!((b - a).cross(&(c - a)).dot(&radial) > 0.0, "triangle {t} faces in");
        }
        let max_u = mesh.surface.triangle_uvs.iter().flatten().map(|&i| mesh.surface.uvs[i as usize][0]);
        assert_eq!(max_u.fold(0.0f32, f32::max), 1.0);
    }
}
