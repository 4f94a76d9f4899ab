//! The independent intersection checker: is the cloth anywhere inside itself or
//! inside a collider at the end of a frame?
//!
//! It shares nothing with the solver's collision code, so that "zero
//! intersections" means something: its own broad phase (a uniform grid of
//! triangle boxes) and an exact triangle-triangle test ([`super::triangles`])
//! for cloth against cloth, against mesh colliders, and against a fine
//! tessellation of each analytic collider made here (its chords lie inside the
//! convex surface, so it never reports a triangle that does not cut the true
//! solid). The ground is tested exactly. Vertices inside an analytic collider
//! are found with parry3d's point projection (parry's GJK intersection test
//! was measured to report false hits for a triangle 2.6 mm above a 3 mm
//! needle, so it is not used).
//!
//! The work is spread over the cores (grid cells, mesh triangles, vertices);
//! the counts do not depend on how.

use nalgebra::{Point3, Vector3};
use parry3d::math::Vector;
use parry3d::shape::{Ball, Cone, ConvexPolyhedron, Cuboid, Cylinder, Shape as ParryShape};
use rayon::prelude::*;
use rustc_hash::FxHashMap;

use super::triangles::triangles_intersect;
use crate::sim::colliders::{Collider, Shape};
use crate::sim::collision::obstacles::MeshCollider;

/// A particle deeper than this inside a collider counts as penetrating, m
/// (`SCENES.md`).
pub const PENETRATION_DEPTH: f64 = 5e-4;

/// What the checker found in one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Intersections {
    /// Pairs of cloth triangles sharing no vertex that intersect.
    pub cloth_pairs: u32,
    /// Cloth triangles intersecting a collider (counted once per collider).
    pub collider_pairs: u32,
    /// Cloth vertices more than [`PENETRATION_DEPTH`] inside a collider.
    pub penetrating_vertices: u32,
}

impl Intersections {
    /// Intersecting triangle pairs of every kind.
    pub fn pairs(&self) -> u32 {
        self.cloth_pairs + self.collider_pairs
    }
}

/// An analytic collider as parry3d sees it (for points inside).
enum Solid {
    /// The half-space below the local XZ plane.
    Ground,
    /// A convex parry shape.
    Convex(Box<dyn ParryShape>),
}

/// Checks cloth frames against themselves and a scene's colliders.
pub struct Checker {
    triangles: Vec<[u32; 3]>,
    solids: Vec<(Solid, Collider)>,
    surfaces: Vec<MeshCollider>,
}

impl Checker {
    /// A checker for cloth `triangles` (particle indices) among `colliders`
    /// and `meshes`.
    pub fn new(triangles: Vec<[u32; 3]>, colliders: &[Collider], meshes: &[MeshCollider]) -> Self {
        let solids = colliders.iter().map(|c| (solid(&c.shape), c.clone())).collect();
        let mut surfaces = meshes.to_vec();
        surfaces.extend(colliders.iter().filter_map(|c| {
            let (vertices, triangles) = tessellate(&c.shape)?;
            Some(MeshCollider {
                name: c.name.clone(),
                vertices,
                triangles,
                placement: c.placement,
                friction: None,
                animation: None,
            })
        }));
        Checker { triangles, solids, surfaces }
    }

    /// Checks the cloth at `positions` with the colliders as they are at time
    /// `t` s.
    pub fn check(&self, positions: &[Vector3<f64>], t: f64) -> Intersections {
        // One grid of the cloth's boxes serves its own pairs and every mesh.
        let cloth_boxes = self.boxes(positions, &self.triangles);
        let grid = BoxGrid::new(&cloth_boxes);
        let cloth = grid.as_ref().map(|grid| (&cloth_boxes[..], grid));
        let cloth_pairs = cloth.map_or(0, |cloth| self.cloth_pairs(positions, cloth));
        let mut found = Intersections { cloth_pairs, ..Default::default() };
        for (solid, collider) in &self.solids {
            let pose = collider.world_from_local(t);
            if let Solid::Ground = solid {
                let below = |v: &u32| pose.inverse_transform_point(&Point3::from(positions[*v as usize])).y <= 0.0;
                found.collider_pairs += self.triangles.par_iter().filter(|tri| tri.iter().any(below)).count() as u32;
            }
            let inside = |p: &Vector3<f64>| {
                let local = pose.inverse_transform_point(&Point3::from(*p)).coords;
                solid.depth(&local) > PENETRATION_DEPTH
            };
            found.penetrating_vertices += positions.par_iter().filter(|p| inside(p)).count() as u32;
        }
        if let Some(cloth) = cloth {
            for mesh in &self.surfaces {
                found.collider_pairs += self.mesh_pairs(positions, mesh, t, cloth);
            }
        }
        found
    }

    /// Intersecting pairs of cloth triangles that share no vertex, from
    /// the triangles' boxes and their grid.
    fn cloth_pairs(&self, positions: &[Vector3<f64>], (boxes, grid): (&[BoxBounds], &BoxGrid)) -> u32 {
        let corners = |t: usize| self.triangles[t].map(|v| positions[v as usize]);
        let adjacent = |a: &[u32; 3], b: &[u32; 3]| a.iter().any(|v| b.contains(v));
        let intersecting = overlapping_pairs_where(grid, boxes, |i, j| {
            let (a, b) = (&self.triangles[i], &self.triangles[j]);
            !adjacent(a, b) && triangles_intersect(&corners(i), &corners(j))
        });
        intersecting.len() as u32
    }

    /// Cloth triangles intersecting a mesh collider's triangles, from the
    /// cloth triangles' boxes and their grid.
    fn mesh_pairs(
        &self,
        positions: &[Vector3<f64>],
        mesh: &MeshCollider,
        t: f64,
        (cloth_boxes, grid): (&[BoxBounds], &BoxGrid),
    ) -> u32 {
        let world = mesh.world_vertices(t);
        let mesh_boxes = self.boxes(&world, &mesh.triangles);
        // Each chunk of the mesh marks the cloth triangles it cuts; a cloth
        // triangle counts once however many chunks cut it.
        let hit = (0..mesh_boxes.len())
            .into_par_iter()
            .step_by(MESH_CHUNK)
            .map(|first| {
                let mut hit = vec![false; cloth_boxes.len()];
                let chunk = first..(first + MESH_CHUNK).min(mesh_boxes.len());
                for_each_overlapping_pair_between(grid, cloth_boxes, &mesh_boxes[chunk], |c, m| {
                    if !hit[c] {
                        let cloth = self.triangles[c].map(|v| positions[v as usize]);
                        hit[c] = triangles_intersect(&cloth, &mesh.triangles[first + m].map(|v| world[v as usize]));
                    }
                });
                hit
            })
            .reduce_with(|mut a, b| {
                a.iter_mut().zip(b).for_each(|(a, b)| *a |= b);
                a
            });
        hit.map_or(0, |hit| hit.iter().filter(|h| **h).count() as u32)
    }

    /// Axis-aligned boxes of `triangles` (indices into `positions`).
    fn boxes(&self, positions: &[Vector3<f64>], triangles: &[[u32; 3]]) -> Vec<BoxBounds> {
        triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| positions[v as usize]);
                (a.inf(&b).inf(&c), a.sup(&b).sup(&c))
            })
            .collect()
    }
}

impl Solid {
    /// How deep `p` (in the solid's frame) is inside, m (0 outside).
    fn depth(&self, p: &Vector3<f64>) -> f64 {
        match self {
            Solid::Ground => (-p.y).max(0.0),
            Solid::Convex(shape) => {
                let q = Vector::new(p.x as f32, p.y as f32, p.z as f32);
                let projection = shape.project_local_point(q, false);
                if projection.is_inside { (q - projection.point).length() as f64 } else { 0.0 }
            }
        }
    }
}

/// parry3d's version of an analytic shape.
fn solid(shape: &Shape) -> Solid {
    let v = |x: f64, y: f64, z: f64| Vector::new(x as f32, y as f32, z as f32);
    let convex = |s: Box<dyn ParryShape>| Solid::Convex(s);
    match *shape {
        Shape::Plane => Solid::Ground,
        Shape::Sphere { radius } => convex(Box::new(Ball::new(radius as f32))),
        Shape::Box { half_extents: h } => convex(Box::new(Cuboid::new(v(h.x, h.y, h.z)))),
        Shape::Cylinder { radius, half_height } => convex(Box::new(Cylinder::new(half_height as f32, radius as f32))),
        Shape::Cone { radius, half_height } => convex(Box::new(Cone::new(half_height as f32, radius as f32))),
        Shape::Prism { side, half_height } => {
            let r = side / 3f64.sqrt();
            let points: Vec<Vector> = [-half_height, half_height]
                .iter()
                .flat_map(|&y| [0.0f64, 120.0, 240.0].map(|d| v(r * d.to_radians().sin(), y, r * d.to_radians().cos())))
                .collect();
            match ConvexPolyhedron::from_convex_hull(&points) {
                Some(hull) => convex(Box::new(hull)),
                None => convex(Box::new(Ball::new(0.0))),
            }
        }
    }
}

/// Segments around a tessellated circle: chords sag less than 0.05 % of the
/// radius.
const AROUND: usize = 96;

/// Vertices (m, in the shape's frame) and triangles of a closed surface.
type Surface = (Vec<Vector3<f64>>, Vec<[u32; 3]>);

/// A closed triangle surface of an analytic shape, in its frame; `None` for
/// the ground (tested exactly instead).
fn tessellate(shape: &Shape) -> Option<Surface> {
    let ring = |r: f64, y: f64| -> Vec<Vector3<f64>> {
        (0..AROUND)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / AROUND as f64;
                Vector3::new(r * a.cos(), y, r * a.sin())
            })
            .collect()
    };
    let n = AROUND as u32;
    // A surface of revolution from rings of points (bottom to top) and caps.
    let revolve = |rings: Vec<Vec<Vector3<f64>>>, bottom: Option<f64>, top: Option<f64>| {
        let mut v: Vec<Vector3<f64>> = rings.concat();
        let mut t = Vec::new();
        for r in 0..rings.len() as u32 - 1 {
            for k in 0..n {
                let (a, b) = (r * n + k, r * n + (k + 1) % n);
                t.push([a, b + n, b]);
                t.push([a, a + n, b + n]);
            }
        }
        for (cap, ring, flip) in [(bottom, 0, true), (top, rings.len() as u32 - 1, false)] {
            if let Some(y) = cap {
                let centre = v.len() as u32;
                v.push(Vector3::new(0.0, y, 0.0));
                for k in 0..n {
                    let (a, b) = (ring * n + k, ring * n + (k + 1) % n);
                    t.push(if flip { [centre, a, b] } else { [centre, b, a] });
                }
            }
        }
        (v, t)
    };
    match *shape {
        Shape::Plane => None,
        Shape::Sphere { radius } => {
            let bands = AROUND / 2;
            let rings = (1..bands)
                .map(|i| {
                    let polar = std::f64::consts::PI * i as f64 / bands as f64;
                    ring(radius * polar.sin(), -radius * polar.cos())
                })
                .collect();
            Some(revolve(rings, Some(-radius), Some(radius)))
        }
        Shape::Cylinder { radius, half_height } => Some(revolve(
            vec![ring(radius, -half_height), ring(radius, half_height)],
            Some(-half_height),
            Some(half_height),
        )),
        Shape::Cone { radius, half_height } => {
            Some(revolve(vec![ring(radius, -half_height), ring(1e-9 * radius, half_height)], Some(-half_height), None))
        }
        Shape::Box { half_extents: h } => {
            let v: Vec<Vector3<f64>> = (0..8)
                .map(|k| {
                    Vector3::new(
                        if k & 1 == 0 { -h.x } else { h.x },
                        if k & 2 == 0 { -h.y } else { h.y },
                        if k & 4 == 0 { -h.z } else { h.z },
                    )
                })
                .collect();
            let quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
            let t = quads.iter().flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]]).collect();
            Some((v, t))
        }
        Shape::Prism { side, half_height } => {
            let r = side / 3f64.sqrt();
            let v: Vec<Vector3<f64>> = [-half_height, half_height]
                .iter()
                .flat_map(|&y| {
                    [0.0f64, 120.0, 240.0].map(|d| Vector3::new(r * d.to_radians().sin(), y, r * d.to_radians().cos()))
                })
                .collect();
            let t = vec![[0, 2, 1], [3, 4, 5], [0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5]];
            Some((v, t))
        }
    }
}

/// An axis-aligned box: lowest and highest corner, m.
type BoxBounds = (Vector3<f64>, Vector3<f64>);

/// True when the boxes share a point.
fn overlap(a: &BoxBounds, b: &BoxBounds) -> bool {
    (0..3).all(|d| a.0[d] <= b.1[d] && b.0[d] <= a.1[d])
}

/// Mesh triangles per parallel task of the cloth-against-mesh test.
const MESH_CHUNK: usize = 1024;

/// The lowest and highest grid cell a box reaches into.
type CellRange = ([i64; 3], [i64; 3]);

/// A uniform grid over boxes whose cells are about twice an average box:
/// each cell lists the boxes that reach into it.
struct BoxGrid {
    cell: f64,
    /// The cells each box reaches into.
    ranges: Vec<CellRange>,
    members: FxHashMap<[i64; 3], Vec<u32>>,
    /// The bounds of all the boxes.
    all: BoxBounds,
}

impl BoxGrid {
    /// The grid of `boxes` (None when there are none).
    fn new(boxes: &[BoxBounds]) -> Option<BoxGrid> {
        let all = boxes.iter().copied().reduce(|(lo, hi), (l, h)| (lo.inf(&l), hi.sup(&h)))?;
        let mean_size = boxes.iter().map(|(lo, hi)| (hi - lo).amax()).sum::<f64>() / boxes.len() as f64;
        let cell = mean_size.max(1e-6) * 2.0;
        let ranges: Vec<CellRange> = boxes.par_iter().map(|b| cell_range(cell, b)).collect();
        let mut members: FxHashMap<[i64; 3], Vec<u32>> = FxHashMap::default();
        for (i, &(lo, hi)) in ranges.iter().enumerate() {
            for key in cells(lo, hi) {
                members.entry(key).or_default().push(i as u32);
            }
        }
        Some(BoxGrid { cell, ranges, members, all })
    }

    /// The lowest and highest cell a box reaches into.
    fn range(&self, b: &BoxBounds) -> CellRange {
        cell_range(self.cell, b)
    }

    /// The boxes listed in `cell`.
    fn members(&self, cell: &[i64; 3]) -> &[u32] {
        self.members.get(cell).map_or(&[], Vec::as_slice)
    }
}

/// The lowest and highest cell of a grid of `cell`-wide cells (m) that a box
/// reaches into.
fn cell_range(cell: f64, (lo, hi): &BoxBounds) -> CellRange {
    let index = |x: f64| (x / cell).floor() as i64;
    ([0, 1, 2].map(|k| index(lo[k])), [0, 1, 2].map(|k| index(hi[k])))
}

/// Every cell from `lo` to `hi` (both included).
fn cells(lo: [i64; 3], hi: [i64; 3]) -> impl Iterator<Item = [i64; 3]> {
    (lo[0]..=hi[0]).flat_map(move |x| (lo[1]..=hi[1]).flat_map(move |y| (lo[2]..=hi[2]).map(move |z| [x, y, z])))
}

/// Every pair `(i, j)` (i < j) of overlapping `boxes` (gridded in `grid`)
/// for which `keep(i, j)` holds, each once, in an order that does not
/// depend on the thread count.
fn overlapping_pairs_where(
    grid: &BoxGrid,
    boxes: &[BoxBounds],
    keep: impl Fn(usize, usize) -> bool + Sync,
) -> Vec<(usize, usize)> {
    let mut occupied: Vec<(&[i64; 3], &Vec<u32>)> = grid.members.iter().collect();
    occupied.sort_unstable_by_key(|(c, _)| **c);
    let ranges = &grid.ranges;
    occupied
        .par_iter()
        .flat_map_iter(|&(cell, members)| {
            let keep = &keep;
            members.iter().enumerate().flat_map(move |(k, &i)| {
                members[k + 1..].iter().filter_map(move |&j| {
                    let (i, j) = (i.min(j) as usize, i.max(j) as usize);
                    // Each pair is reported only in the lowest cell both boxes occupy.
                    let lowest = [0, 1, 2].map(|d| ranges[i].0[d].max(ranges[j].0[d]));
                    (lowest == *cell && overlap(&boxes[i], &boxes[j]) && keep(i, j)).then_some((i, j))
                })
            })
        })
        .collect()
}

/// Calls `f(i, j)` once for every box `i` of `first` (gridded in `grid`)
/// overlapping a box `j` of `second` (pairs within one set are never formed).
fn for_each_overlapping_pair_between(
    grid: &BoxGrid,
    first: &[BoxBounds],
    second: &[BoxBounds],
    mut f: impl FnMut(usize, usize),
) {
    let all = grid.all;
    let (all_lo, all_hi) = grid.range(&all);
    // The last box of `second` each box of `first` was offered to, so that a
    // pair sharing several cells is reported once.
    let mut offered = vec![usize::MAX; first.len()];
    for (j, b) in second.iter().enumerate().filter(|(_, b)| overlap(b, &all)) {
        let (lo, hi) = grid.range(b);
        let (lo, hi) = ([0, 1, 2].map(|k| lo[k].max(all_lo[k])), [0, 1, 2].map(|k| hi[k].min(all_hi[k])));
        for cell in cells(lo, hi) {
            for &i in grid.members(&cell) {
                let i = i as usize;
                if offered[i] != j && overlap(&first[i], b) {
                    offered[i] = j;
                    f(i, j);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::generate;

    /// Boxes from a deterministic scatter: `count` boxes up to `size` wide in a 1 m cube.
    fn scattered_boxes(count: usize, size: f64, salt: f64) -> Vec<BoxBounds> {
        let unit = |i: usize, k: usize| ((i * 7 + k) as f64 * 12.9898 + salt).sin() * 43_758.545 % 1.0;
        (0..count)
            .map(|i| {
                let lo = Vector3::from_fn(|k, _| unit(i, k).abs());
                (lo, lo + Vector3::from_fn(|k, _| size * unit(i, k + 3).abs()))
            })
            .collect()
    }

    #[test]
    fn pairs_between_two_sets_are_exactly_the_overlapping_ones_each_once() {
        let (first, second) = (scattered_boxes(300, 0.08, 0.3), scattered_boxes(200, 0.15, 0.7));
        let mut expected = Vec::new();
        for (i, a) in first.iter().enumerate() {
            for (j, b) in second.iter().enumerate() {
                if overlap(a, b) {
                    expected.push((i, j));
                }
            }
        }
        let mut found = Vec::new();
        let grid = BoxGrid::new(&first).unwrap();
        for_each_overlapping_pair_between(&grid, &first, &second, |i, j| found.push((i, j)));
        let reported = found.len();
        found.sort_unstable();
        found.dedup();
        expected.sort_unstable();
        assert_eq!(found.len(), reported, "no pair twice");
        assert!(expected.len() > 50, "the scatter overlaps: {}", expected.len());
        assert_eq!(found, expected);
    }
    use crate::sim::motion::Placement;
    use nalgebra::Isometry3;

    fn collider(shape: Shape, at: Vector3<f64>) -> Collider {
        let placement = Placement { rest_pose: Isometry3::translation(at.x, at.y, at.z), motion: None };
        Collider { name: "c".into(), shape, placement, friction: None }
    }

    #[test]
    fn a_flat_cloth_is_clean_and_a_folded_through_one_is_not() {
        let mesh = generate::grid(1.0, 6);
        let checker = Checker::new(mesh.triangles.clone(), &[], &[]);
        assert_eq!(checker.check(&mesh.positions, 0.0), Intersections::default());
        // Fold the last row back across the cloth: the strip it drags cuts
        // through the flat middle.
        let mut crossing = mesh.positions.clone();
        for (i, p) in crossing.iter_mut().enumerate() {
            if i / 6 == 5 {
                *p = Vector3::new(p.x, 0.0, -0.45 + 0.02);
            }
        }
        crossing.iter_mut().filter(|p| p.z > 0.3 && p.z < 0.45).for_each(|p| p.y = 0.05);
        let found = checker.check(&crossing, 0.0);
        assert!(found.cloth_pairs > 0, "{found:?}");
    }

    #[test]
    fn cloth_through_a_sphere_and_below_the_ground_is_caught() {
        let mut mesh = generate::grid(1.0, 9);
        let ball = collider(Shape::Sphere { radius: 0.2 }, Vector3::zeros());
        let ground = collider(Shape::Plane, Vector3::new(0.0, -0.5, 0.0));
        let checker = Checker::new(mesh.triangles.clone(), &[ball, ground], &[]);
        let found = checker.check(&mesh.positions, 0.0);
        assert!(
            found.collider_pairs > 0 && found.penetrating_vertices > 0,
            "the flat cloth cuts the sphere: {found:?}"
        );
        for p in &mut mesh.positions {
            p.y = 0.3;
        }
        assert_eq!(checker.check(&mesh.positions, 0.0), Intersections::default());
        for p in &mut mesh.positions {
            p.y = -0.6;
        }
        let found = checker.check(&mesh.positions, 0.0);
        assert_eq!(found.penetrating_vertices, 81, "every vertex is 10 cm below the ground");
    }

    /// A mesh collider of several parallel chunks (a wall of 48 × 48 quads)
    /// standing through a flat cloth: the cloth triangles it cuts are counted
    /// once each, exactly as a test of every pair counts them.
    #[test]
    fn cloth_cut_by_a_large_mesh_counts_each_cut_triangle_once() {
        let cloth = generate::grid(1.0, 20);
        let wall = generate::grid(0.8, 49);
        let upright = |p: &Vector3<f64>| Vector3::new(p.x + 0.013, p.z, 0.0371);
        let mesh = MeshCollider {
            name: "wall".into(),
            vertices: wall.positions.iter().map(upright).collect(),
            triangles: wall.triangles.clone(),
            placement: Placement { rest_pose: Isometry3::identity(), motion: None },
            friction: None,
            animation: None,
        };
        assert!(mesh.triangles.len() > 2 * MESH_CHUNK, "the wall spans several chunks");
        let checker = Checker::new(cloth.triangles.clone(), &[], std::slice::from_ref(&mesh));
        let corners = |vertices: &[Vector3<f64>], t: &[u32; 3]| t.map(|v| vertices[v as usize]);
        let expected = cloth
            .triangles
            .iter()
            .filter(|c| {
                let c = corners(&cloth.positions, c);
                mesh.triangles.iter().any(|m| triangles_intersect(&c, &corners(&mesh.vertices, m)))
            })
            .count() as u32;
        assert!(expected >= 20, "the wall cuts a row of the cloth: {expected}");
        let found = checker.check(&cloth.positions, 0.0);
        assert_eq!((found.collider_pairs, found.cloth_pairs), (expected, 0));
    }

    #[test]
    fn grid_broad_phase_reports_every_overlapping_pair_once() {
        let boxes: Vec<(Vector3<f64>, Vector3<f64>)> = (0..40)
            .map(|i| {
                let x = (i as f64 * 0.37).sin();
                let lo = Vector3::new(x, (i % 5) as f64 * 0.2, (i % 3) as f64 * 0.3);
                (lo, lo + Vector3::repeat(0.25 + 0.1 * (i % 4) as f64))
            })
            .collect();
        let grid = BoxGrid::new(&boxes).expect("boxes to grid");
        let mut found = overlapping_pairs_where(&grid, &boxes, |_, _| true);
        let mut brute = Vec::new();
        for i in 0..boxes.len() {
            for j in i + 1..boxes.len() {
                if (0..3).all(|d| boxes[i].0[d] <= boxes[j].1[d] && boxes[j].0[d] <= boxes[i].1[d]) {
                    brute.push((i, j));
                }
            }
        }
        found.sort();
        assert_eq!(found, brute);
    }
}
