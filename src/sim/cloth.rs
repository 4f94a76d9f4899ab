//! The cloth as the solver sees it: particles with lumped masses, stretch and
//! shear springs, and bending hinges, built from one or more garment meshes.
//!
//! Stiffness is a material property; each element's share follows from its rest
//! geometry so that refining the mesh leaves the cloth's behaviour unchanged:
//!
//! * a **stretch spring** on a mesh edge of rest length `L` gets
//!   `k = k_stretch · A / L²`, where `A` is the total area of the triangles
//!   beside it. On a square grid this makes each spring carry exactly the strip
//!   of cloth it stands for (`k = k_stretch`), at any spacing.
//! * a **shear spring** on each diagonal of a source quad gets
//!   `k = k_shear · 2 A_quad / L²`, which gives a square grid the in-plane shear
//!   modulus `k_shear`. Where the source had only triangles, the spring between
//!   the two vertices opposite each interior edge plays that role, with
//!   `A = 2 (A₀ + A₁)`.
//! * a **bending hinge** on each interior edge carries the flexural rigidity
//!   directly (see [`super::forces::hinge_weights`]).
//! * **masses** are the area density times one third of the area of the
//!   triangles around each vertex, unless the fabric sets a vertex mass.

use std::collections::{HashMap, HashSet};
use std::ops::Range;

use nalgebra::Vector3;

use super::fabric::Fabric;
use super::forces::{SpringStiffness, hinge_weights};
use crate::mesh::TriMesh;
use crate::mesh::topology::Topology;

/// What a spring models; decides which fabric coefficients it takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpringKind {
    /// Structural: resists stretch along the cloth (a mesh edge).
    Stretch,
    /// Resists in-plane shear (a quad diagonal, or across a triangle pair).
    Shear,
}

/// One garment's share of the cloth.
#[derive(Clone, Debug)]
pub struct GarmentRange {
    /// Its particles.
    pub vertices: Range<usize>,
    /// Its springs.
    pub springs: Range<usize>,
    /// Its bending hinges.
    pub hinges: Range<usize>,
    /// Its fabric parameters.
    pub fabric: Fabric,
}

/// Particles and elements of every garment, in one index space.
#[derive(Clone, Debug)]
pub struct Cloth {
    /// Rest positions, m.
    pub rest_positions: Vec<Vector3<f64>>,
    /// Particle masses, kg.
    pub mass: Vec<f64>,
    /// Springs: end particles.
    pub spring_ends: Vec<[u32; 2]>,
    /// Springs: kind.
    pub spring_kind: Vec<SpringKind>,
    /// Springs: rest length, m.
    pub rest_length: Vec<f64>,
    /// Springs: rest area they stand for over rest length squared (unitless);
    /// spring stiffness = fabric stiffness × this.
    pub spring_area_ratio: Vec<f64>,
    /// Hinges: the shared edge's two vertices, then the two opposite vertices.
    pub hinge_vertices: Vec<[u32; 4]>,
    /// Hinges: bending weights (1/m), see [`hinge_weights`].
    pub hinge_weights: Vec<[f64; 4]>,
    /// Triangles of every garment, in particle indices.
    pub triangles: Vec<[u32; 3]>,
    /// Garment of each triangle.
    pub triangle_garment: Vec<u32>,
    /// Garments, in input order.
    pub garments: Vec<GarmentRange>,
    /// Garment index of each particle.
    pub garment_of_vertex: Vec<u32>,
}

impl Cloth {
    /// Builds the cloth of `garments` (world-space meshes with their fabrics).
    pub fn new<'a>(garments: impl IntoIterator<Item = (&'a TriMesh, Fabric)>) -> Self {
        let mut cloth = Cloth {
            rest_positions: Vec::new(),
            mass: Vec::new(),
            spring_ends: Vec::new(),
            spring_kind: Vec::new(),
            rest_length: Vec::new(),
            spring_area_ratio: Vec::new(),
            hinge_vertices: Vec::new(),
            hinge_weights: Vec::new(),
            triangles: Vec::new(),
            triangle_garment: Vec::new(),
            garments: Vec::new(),
            garment_of_vertex: Vec::new(),
        };
        for (mesh, fabric) in garments {
            cloth.add_garment(mesh, fabric);
        }
        cloth
    }

    /// Number of particles.
    pub fn vertex_count(&self) -> usize {
        self.rest_positions.len()
    }

    /// Number of springs.
    pub fn spring_count(&self) -> usize {
        self.spring_ends.len()
    }

    /// Fabric of particle `i`.
    pub fn fabric_of(&self, i: usize) -> &Fabric {
        &self.garments[self.garment_of_vertex[i] as usize].fabric
    }

    /// Gives garment `g` a new fabric; its particles' masses follow (from its
    /// rest triangles' areas, or the fabric's vertex mass). Topology and
    /// rest shape are unchanged.
    pub fn set_fabric(&mut self, g: usize, fabric: Fabric) {
        let vertices = self.garments[g].vertices.clone();
        match fabric.vertex_mass_kg {
            Some(m) => self.mass[vertices].iter_mut().for_each(|mass| *mass = m),
            None => {
                self.mass[vertices].iter_mut().for_each(|mass| *mass = 0.0);
                let triangles = self.triangles.iter().zip(&self.triangle_garment).filter(|(_, tg)| **tg as usize == g);
                for (tri, _) in triangles {
                    let [a, b, c] = tri.map(|v| self.rest_positions[v as usize]);
                    let area = 0.5 * (b - a).cross(&(c - a)).norm();
                    let third = fabric.area_density_kg_per_m2 * area / 3.0;
                    for v in tri {
                        self.mass[*v as usize] += third;
                    }
                }
            }
        }
        self.garments[g].fabric = fabric;
    }

    /// Stiffness (N/m) and damping (N·s/m) of spring `s` under its garment's fabric.
    pub fn spring_coefficients(&self, s: usize, fabric: &Fabric) -> (SpringStiffness, f64) {
        let ratio = self.spring_area_ratio[s];
        match self.spring_kind[s] {
            SpringKind::Stretch => {
                let k = fabric.stretch_stiffness_n_per_m * ratio;
                let stiffness = SpringStiffness { tension: k, compression: k * fabric.compression_ratio };
                (stiffness, fabric.stretch_damping_n_s_per_m * ratio)
            }
            SpringKind::Shear => (
                SpringStiffness::symmetric(fabric.shear_stiffness_n_per_m * ratio),
                fabric.shear_damping_n_s_per_m * ratio,
            ),
        }
    }

    fn add_garment(&mut self, mesh: &TriMesh, fabric: Fabric) {
        let offset = self.vertex_count() as u32;
        let garment = self.garments.len() as u32;
        let vertices = self.vertex_count()..self.vertex_count() + mesh.vertex_count();
        let springs_start = self.spring_count();
        let hinges_start = self.hinge_vertices.len();

        let areas: Vec<f64> = (0..mesh.triangles.len()).map(|t| mesh.triangle_area(t)).collect();
        let topology = Topology::new(&mesh.triangles);
        self.rest_positions.extend_from_slice(&mesh.positions);
        self.triangles.extend(mesh.triangles.iter().map(|t| t.map(|v| v + offset)));
        self.triangle_garment.extend(std::iter::repeat_n(garment, mesh.triangles.len()));
        self.mass.extend(lumped_masses(mesh, &areas, &fabric));
        self.garment_of_vertex.extend(std::iter::repeat_n(garment, mesh.vertex_count()));

        let shapes = SpringLayout::new(mesh, &topology, &areas);
        for (ends, kind, area) in shapes.springs {
            let rest = (mesh.positions[ends[0] as usize] - mesh.positions[ends[1] as usize]).norm();
            self.spring_ends.push(ends.map(|v| v + offset));
            self.spring_kind.push(kind);
            self.rest_length.push(rest);
            self.spring_area_ratio.push(area / (rest * rest));
        }
        for (ids, share) in bending_hinges(mesh, &topology) {
            let weights = hinge_weights(&ids.map(|v| mesh.positions[v as usize])).map(|w| w * share.sqrt());
            self.hinge_weights.push(weights);
            self.hinge_vertices.push(ids.map(|v| v + offset));
        }
        self.garments.push(GarmentRange {
            vertices,
            springs: springs_start..self.spring_count(),
            hinges: hinges_start..self.hinge_vertices.len(),
            fabric,
        });
    }
}

/// The bending hinges of `mesh` (edge vertices, then opposite vertices) with
/// the share of the bending energy each carries.
///
/// A hinge measures the fold across its edge from the two triangles beside it
/// only, so on a mesh of quads split one way (right triangles) each hinge sees
/// the curvature along one of the two rows of vertices it touches, and the
/// rows can bend out of step: a cantilever of such a grid hangs ~25 % lower
/// than its rigidity says, at any resolution. Quads therefore bend through the
/// hinges of both of their splits, each with half the energy; hinges the two
/// splits share (between triangles that are not quad halves) keep the whole.
fn bending_hinges(mesh: &TriMesh, topology: &Topology) -> Vec<([u32; 4], f64)> {
    let as_ids = |h: &crate::mesh::topology::Hinge| [h.edge[0], h.edge[1], h.opposite[0], h.opposite[1]];
    if mesh.quads.is_empty() {
        return topology.hinges.iter().map(|h| (as_ids(h), 1.0)).collect();
    }
    let halves: HashSet<[u32; 3]> = mesh
        .quads
        .iter()
        .flat_map(|&[a, b, c, d]| [sorted_triangle(&[a, b, c]), sorted_triangle(&[a, c, d])])
        .collect();
    let other_split: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .filter(|t| !halves.contains(&sorted_triangle(t)))
        .copied()
        .chain(mesh.quads.iter().flat_map(|&[a, b, c, d]| [[a, b, d], [b, c, d]]))
        .collect();
    let key = |ids: &[u32; 4]| {
        let (mut edge, mut opposite) = ([ids[0], ids[1]], [ids[2], ids[3]]);
        edge.sort_unstable();
        opposite.sort_unstable();
        [edge[0], edge[1], opposite[0], opposite[1]]
    };
    // Each split contributes half; a hinge both splits have is kept once, whole.
    let mut hinges: Vec<([u32; 4], f64)> = Vec::new();
    let mut index: HashMap<[u32; 4], usize> = HashMap::new();
    for hinge in topology.hinges.iter().chain(&Topology::new(&other_split).hinges) {
        let ids = as_ids(hinge);
        let slot = *index.entry(key(&ids)).or_insert_with(|| {
            hinges.push((ids, 0.0));
            hinges.len() - 1
        });
        hinges[slot].1 += 0.5;
    }
    hinges
}

/// Lumped masses: a third of each triangle's mass to each corner, or the
/// fabric's explicit vertex mass.
fn lumped_masses(mesh: &TriMesh, areas: &[f64], fabric: &Fabric) -> Vec<f64> {
    if let Some(m) = fabric.vertex_mass_kg {
        return vec![m; mesh.vertex_count()];
    }
    let mut mass = vec![0.0; mesh.vertex_count()];
    for (tri, area) in mesh.triangles.iter().zip(areas) {
        for &v in tri {
            mass[v as usize] += fabric.area_density_kg_per_m2 * area / 3.0;
        }
    }
    mass
}

/// Which vertex pairs get springs, of what kind, standing for how much area.
struct SpringLayout {
    springs: Vec<([u32; 2], SpringKind, f64)>,
}

impl SpringLayout {
    fn new(mesh: &TriMesh, topology: &Topology, areas: &[f64]) -> Self {
        let sorted = |a: u32, b: u32| [a.min(b), a.max(b)];
        let mut diagonals: HashMap<[u32; 2], f64> = HashMap::new();
        let mut quad_triangles: HashSet<[u32; 3]> = HashSet::new();
        let triangle_index: HashMap<[u32; 3], usize> =
            mesh.triangles.iter().enumerate().map(|(t, tri)| (sorted_triangle(tri), t)).collect();
        for &[a, b, c, d] in &mesh.quads {
            let halves = [sorted_triangle(&[a, b, c]), sorted_triangle(&[a, c, d])];
            let quad_area: f64 = halves.iter().filter_map(|h| triangle_index.get(h)).map(|&t| areas[t]).sum();
            quad_triangles.extend(halves);
            for diagonal in [sorted(a, c), sorted(b, d)] {
                *diagonals.entry(diagonal).or_default() += 2.0 * quad_area;
            }
        }

        let mut springs = Vec::new();
        let edge_set: HashSet<[u32; 2]> = topology.edges.iter().map(|e| e.vertices).collect();
        let mut edge_area: HashMap<[u32; 2], f64> = HashMap::new();
        for (tri, area) in mesh.triangles.iter().zip(areas) {
            for k in 0..3 {
                *edge_area.entry(sorted(tri[k], tri[(k + 1) % 3])).or_default() += area;
            }
        }
        for edge in &topology.edges {
            if !diagonals.contains_key(&edge.vertices) {
                springs.push((edge.vertices, SpringKind::Stretch, edge_area[&edge.vertices]));
            }
        }
        let mut shear: Vec<([u32; 2], f64)> = diagonals.into_iter().collect();
        for edge in topology.edges.iter().filter(|e| e.is_interior()) {
            let [t0, t1] = edge.triangles.map(|t| t as usize);
            let in_quad = |t: usize| quad_triangles.contains(&sorted_triangle(&mesh.triangles[t]));
            if in_quad(t0) || in_quad(t1) {
                continue;
            }
            let [a, b] = edge.vertices;
            let across = sorted(third(&mesh.triangles[t0], a, b), third(&mesh.triangles[t1], a, b));
            if across[0] != across[1] && !edge_set.contains(&across) {
                shear.push((across, 2.0 * (areas[t0] + areas[t1])));
            }
        }
        shear.sort_by_key(|x| x.0);
        shear.dedup_by(|x, y| x.0 == y.0);
        springs.extend(shear.into_iter().map(|(ends, area)| (ends, SpringKind::Shear, area)));
        SpringLayout { springs }
    }
}

fn sorted_triangle(tri: &[u32; 3]) -> [u32; 3] {
    let mut t = *tri;
    t.sort_unstable();
    t
}

fn third(tri: &[u32; 3], a: u32, b: u32) -> u32 {
    tri.iter().copied().find(|&v| v != a && v != b).unwrap_or(tri[0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;
    use crate::sim::fabric::tests::cotton;
    use crate::sim::forces::hinge_curvature;

    #[test]
    fn grid_springs_stand_for_their_strip_of_cloth() {
        for n in [5, 9, 17] {
            let mesh = generate::grid(1.0, n);
            let cloth = Cloth::new([(&mesh, cotton())]);
            let cells = (n - 1) * (n - 1);
            let stretch = (0..cloth.spring_count()).filter(|&s| cloth.spring_kind[s] == SpringKind::Stretch);
            assert_eq!(stretch.clone().count(), 2 * n * (n - 1));
            assert_eq!(cloth.spring_count() - stretch.clone().count(), 2 * cells, "two diagonals per quad");
            // Interior stretch springs carry a full strip (ratio 1), boundary ones half.
            for s in stretch {
                let ratio = cloth.spring_area_ratio[s];
                assert!((ratio - 1.0).abs() < 1e-9 || (ratio - 0.5).abs() < 1e-9, "{ratio}");
            }
            for s in (0..cloth.spring_count()).filter(|&s| cloth.spring_kind[s] == SpringKind::Shear) {
                assert!((cloth.spring_area_ratio[s] - 1.0).abs() < 1e-9);
            }
            let total: f64 = cloth.mass.iter().sum();
            assert!((total - 0.135).abs() < 1e-12, "mass = density × area");
        }
    }

    #[test]
    fn a_new_fabric_brings_its_masses_and_nothing_else_changes() {
        let mut cloth = Cloth::new([(&generate::grid(1.0, 8), cotton())]);
        let (springs, hinges) = (cloth.spring_ends.clone(), cloth.hinge_vertices.clone());
        let mut denser = cotton();
        denser.area_density_kg_per_m2 = 0.4;
        cloth.set_fabric(0, denser.clone());
        assert!((cloth.mass.iter().sum::<f64>() - 0.4).abs() < 1e-12, "mass = new density × area");
        assert_eq!(Cloth::new([(&generate::grid(1.0, 8), denser)]).mass, cloth.mass);
        assert_eq!((cloth.spring_ends.clone(), cloth.hinge_vertices.clone()), (springs, hinges));
    }

    #[test]
    fn explicit_vertex_mass_overrides_area_density() {
        let mesh = generate::grid(1.0, 4);
        let mut fabric = cotton();
        fabric.vertex_mass_kg = Some(0.01);
        let cloth = Cloth::new([(&mesh, fabric)]);
        assert!(cloth.mass.iter().all(|&m| m == 0.01));
    }

    #[test]
    fn triangle_only_mesh_gets_shear_springs_across_its_edges() {
        let mut mesh = generate::grid(1.0, 3);
        mesh.quads.clear();
        let cloth = Cloth::new([(&mesh, cotton())]);
        let shear = cloth.spring_kind.iter().filter(|k| **k == SpringKind::Shear).count();
        let interior_edges = Topology::new(&mesh.triangles).hinges.len();
        assert_eq!(shear, interior_edges, "one across each interior edge");
        assert_eq!(cloth.spring_count() - shear, Topology::new(&mesh.triangles).edges.len());
    }

    /// Maps a flat mesh in the XZ plane onto a cylinder of radius `radius` whose
    /// axis runs along Z (isometric: arc length along X is kept).
    fn bend_onto_cylinder(mesh: &TriMesh, radius: f64) -> Vec<Vector3<f64>> {
        mesh.positions
            .iter()
            .map(|p| {
                let angle = p.x / radius;
                Vector3::new(radius * angle.sin(), radius * (1.0 - angle.cos()), p.z)
            })
            .collect()
    }

    fn bending_energy(cloth: &Cloth, positions: &[Vector3<f64>], rigidity: f64) -> f64 {
        let energy: f64 = cloth
            .hinge_vertices
            .iter()
            .zip(&cloth.hinge_weights)
            .map(|(ids, w)| hinge_curvature(w, &ids.map(|v| positions[v as usize])).norm_squared())
            .sum();
        0.5 * rigidity * energy
    }

    /// An equilateral-ish triangle mesh (rows shifted by half a spacing), no quads.
    fn triangle_lattice(size: f64, n: usize) -> TriMesh {
        let h = size / (n - 1) as f64;
        let row_h = h * 3f64.sqrt() / 2.0;
        let rows = (size / row_h) as usize + 1;
        let mut mesh = TriMesh::default();
        for r in 0..rows {
            for c in 0..n {
                let shift = if r % 2 == 1 { 0.5 * h } else { 0.0 };
                mesh.positions.push(Vector3::new(c as f64 * h + shift - 0.5 * size, 0.0, r as f64 * row_h));
            }
        }
        let id = |r: usize, c: usize| (r * n + c) as u32;
        for r in 0..rows - 1 {
            for c in 0..n - 1 {
                if r % 2 == 0 {
                    mesh.triangles.push([id(r, c), id(r + 1, c), id(r, c + 1)]);
                    mesh.triangles.push([id(r, c + 1), id(r + 1, c), id(r + 1, c + 1)]);
                } else {
                    mesh.triangles.push([id(r, c), id(r + 1, c), id(r + 1, c + 1)]);
                    mesh.triangles.push([id(r, c), id(r + 1, c + 1), id(r, c + 1)]);
                }
            }
        }
        mesh
    }

    /// Static tip deflection of a clamped strip of `segments` square cells
    /// under a small gravity `g`, over the Euler-Bernoulli beam's `w l⁴ / 8G`.
    fn cantilever_deflection_ratio(segments: usize, rows: usize) -> f64 {
        let (length, g) = (0.05, 0.1);
        let fabric = cotton();
        let dx = length / segments as f64;
        let columns = segments + 3; // two clamped columns behind the edge
        let mesh = generate::rectangle(dx * (columns - 1) as f64, dx * (rows - 1) as f64, columns, rows);
        let cloth = Cloth::new([(&mesh, fabric.clone())]);
        let free: Vec<usize> = (0..mesh.vertex_count()).filter(|i| i % columns >= 3).collect();
        let slot: HashMap<usize, usize> = free.iter().enumerate().map(|(k, &i)| (i, k)).collect();
        let mut stiffness = nalgebra::DMatrix::<f64>::zeros(free.len(), free.len());
        for (ids, w) in cloth.hinge_vertices.iter().zip(&cloth.hinge_weights) {
            for a in 0..4 {
                for b in 0..4 {
                    if let (Some(&i), Some(&j)) = (slot.get(&(ids[a] as usize)), slot.get(&(ids[b] as usize))) {
                        stiffness[(i, j)] += fabric.bend_stiffness_n_m * w[a] * w[b];
                    }
                }
            }
        }
        let load = nalgebra::DVector::from_iterator(free.len(), free.iter().map(|&i| -cloth.mass[i] * g));
        let sag = stiffness.lu().solve(&load).unwrap();
        let tip: f64 = free.iter().zip(sag.iter()).filter(|(i, _)| *i % columns == columns - 1).map(|(_, y)| y).sum();
        let beam = fabric.area_density_kg_per_m2 * g * length.powi(4) / (8.0 * fabric.bend_stiffness_n_m);
        -tip / rows as f64 / beam
    }

    /// A grid strip bends like the Euler-Bernoulli beam of its rigidity
    /// (first-order error from the clamp), narrow or wide: the hinges of both
    /// quad splits keep its rows from bending out of step (with one split's
    /// hinges alone it hangs ~25 % lower at every resolution).
    #[test]
    fn clamped_grid_strip_sags_like_the_beam_of_its_rigidity() {
        for rows in [2, 5] {
            let errors: Vec<f64> = [16, 32, 64].iter().map(|&n| cantilever_deflection_ratio(n, rows) - 1.0).collect();
            assert!(errors[2].abs() < 0.04, "rows {rows}: {errors:?}");
            for pair in errors.windows(2) {
                assert!((pair[1] / pair[0] - 0.5).abs() < 0.1, "rows {rows}: first order, {errors:?}");
            }
        }
    }

    /// The bending energy of a cloth rolled onto a cylinder converges to the
    /// plate energy ½ B κ² A as the mesh is refined (the deficit is the boundary
    /// strip, whose edges carry no hinge, so it halves with the spacing). An
    /// equilateral lattice, bent across its rows, converges to the same energy.
    #[test]
    fn rolled_cloth_bending_energy_converges_to_the_plate_energy() {
        let (rigidity, radius) = (1.6e-5, 0.2);
        let ratio = |mesh: &TriMesh| {
            let cloth = Cloth::new([(mesh, cotton())]);
            let plate = 0.5 * rigidity * mesh.area() / (radius * radius);
            bending_energy(&cloth, &bend_onto_cylinder(mesh, radius), rigidity) / plate
        };
        for (name, mesh_at) in [
            ("grid", &(|n| generate::grid(0.5, n)) as &dyn Fn(usize) -> TriMesh),
            ("lattice", &|n| triangle_lattice(0.5, n)),
        ] {
            let deficits: Vec<f64> = [17, 33, 65].iter().map(|&n| 1.0 - ratio(&mesh_at(n))).collect();
            assert!(deficits[2].abs() < 0.03, "{name}: {deficits:?}");
            for pair in deficits.windows(2) {
                assert!((pair[1] / pair[0] - 0.5).abs() < 0.1, "{name}: first order, {deficits:?}");
            }
        }
    }
}
