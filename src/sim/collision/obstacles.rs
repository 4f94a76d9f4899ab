//! What the cloth's triangles collide with besides themselves: the sharp
//! features of analytic colliders and rigid triangle meshes.
//!
//! A cloth *particle* meets an analytic collider through its exact signed
//! distance ([`crate::sim::contact`]); what that misses is a sharp feature
//! poking between particles: a needle's tip through the middle of a triangle,
//! a blade's edge or a box's corner through an edge. Those features (box and
//! prism edges and corners, cylinder rims, a cone's rim and apex) become
//! obstacle vertices and edges here, tested against cloth triangles and edges
//! by continuous collision detection. A thin curved side is a feature too: a
//! cloth edge of length L can dip L²/8R into a surface of radius R between its
//! ends (a centimetre into a 3 mm needle), so cylinders and cones also carry
//! their generator lines, and an edge cannot enter the side without crossing
//! one. A sphere has no feature at all, and a coarse cloth draped on a small
//! one bows into it between particles held a thickness off its surface (a
//! triangle of edge L dips about L²/6R below its corners); when the cloth is
//! that coarse for a sphere ([`ClothScale::needs_surface_lattice`]), the
//! sphere carries a geodesic lattice of surface points and edges fine enough
//! that the bow cannot reach the surface between them. Triangle-mesh
//! colliders contribute all their vertices, edges and triangles. Every
//! obstacle vertex is stored in its collider's frame and moves with the
//! collider's pose; obstacles have infinite mass.

use std::sync::Arc;

use nalgebra::{Point3, Vector3};

use super::features::Ownership;
use crate::sim::colliders::{Collider, Shape};
use crate::sim::contact::StepWindow;
use crate::sim::motion::Placement;
use crate::sim::vertex_animation::VertexAnimation;

/// Segments of a rim circle (a needle's or a cylinder's edge), and generator
/// lines along a cylinder's or cone's side.
const RIM_SEGMENTS: usize = 24;

/// Finest geodesic lattice a sphere gets: 10 × 4⁵ + 2 = 10242 points.
const MAX_LATTICE_LEVEL: u32 = 5;

/// How coarse and how thick the cloth is: what decides whether a curved
/// collider needs surface features to keep the cloth's faces, not only its
/// particles, off it. Taken when the simulator is built: a thickness tuned
/// live afterwards does not rebuild the lattice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClothScale {
    /// The cloth's longest triangle edge at rest, m.
    pub longest_edge_m: f64,
    /// The smallest collision thickness of its particles, m.
    pub thinnest_m: f64,
}

impl ClothScale {
    /// The scale of a cloth with `triangles` over `rest_positions` (m) and
    /// particle `thicknesses` (m).
    pub fn of(rest_positions: &[Vector3<f64>], triangles: &[[u32; 3]], thicknesses: impl Iterator<Item = f64>) -> Self {
        let longest_edge_m = longest_edge(rest_positions, triangles);
        ClothScale { longest_edge_m, thinnest_m: thicknesses.fold(f64::INFINITY, f64::min) }
    }

    /// Whether a triangle of the longest edge, its corners resting a
    /// thickness off a sphere of `radius` m, can bow into the sphere: no
    /// point of a triangle of longest edge L dips more than L²/6R below its
    /// corners (the equilateral triangle's centre), and a quarter of the
    /// thickness is kept as margin.
    pub fn needs_surface_lattice(&self, radius: f64) -> bool {
        self.longest_edge_m.powi(2) / (6.0 * radius) > 0.75 * self.thinnest_m
    }

    /// Longest lattice edge a sphere of `radius` m may have for this cloth:
    /// no longer than the cloth's edges, and standing (as a chord s stands
    /// s²/8R inside the sphere) at most a quarter of the thickness inside.
    pub fn lattice_chord(&self, radius: f64) -> f64 {
        self.longest_edge_m.min((2.0 * radius * self.thinnest_m).sqrt())
    }
}

/// A triangle mesh obstacle: rigid, moving like an analytic collider, or
/// deforming (an animated body) with its vertices sampled per frame.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshCollider {
    /// Name from the scene file, for reports.
    pub name: String,
    /// Vertex positions in the collider's frame at time 0, m.
    pub vertices: Vec<Vector3<f64>>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Where it is and how it moves as a whole.
    pub placement: Placement,
    /// Friction coefficient overriding the fabric's, unitless.
    pub friction: Option<f64>,
    /// For a deforming mesh, its vertices (collider frame) over time.
    pub animation: Option<Arc<VertexAnimation>>,
}

impl MeshCollider {
    /// Position of `vertex` in the collider's frame at time `t` s, m.
    pub fn local_vertex(&self, vertex: usize, t: f64) -> Vector3<f64> {
        match &self.animation {
            Some(a) => a.position(vertex, t),
            None => self.vertices.get(vertex).copied().unwrap_or_else(Vector3::zeros),
        }
    }

    /// Every vertex in world space at time `t` s, m.
    pub fn world_vertices(&self, t: f64) -> Vec<Vector3<f64>> {
        let pose = self.placement.world_from_local(t);
        (0..self.vertices.len()).map(|v| (pose * Point3::from(self.local_vertex(v, t))).coords).collect()
    }
}

/// An obstacle body: how it moves and how rough it is.
#[derive(Clone, Debug, PartialEq)]
pub struct Body {
    /// Where it is and how it moves as a whole.
    pub placement: Placement,
    /// Friction coefficient overriding the fabric's, unitless.
    pub friction: Option<f64>,
    /// For a deforming mesh, its vertices over time (indexed from `first_vertex`).
    pub animation: Option<Arc<VertexAnimation>>,
    /// Index of the body's first vertex among all obstacle vertices.
    pub first_vertex: u32,
}

/// All obstacle features in one index space.
#[derive(Clone, Debug, Default)]
pub struct Obstacles {
    /// Per vertex, its body (index into `bodies`).
    pub vertex_collider: Vec<u32>,
    /// Per vertex, its position in its collider's frame, m.
    pub local: Vec<Vector3<f64>>,
    /// Triangles of mesh colliders.
    pub triangles: Vec<[u32; 3]>,
    /// Which triangle owns which vertex and edge (mesh colliders).
    pub ownership: Ownership,
    /// Sharp edges of analytic colliders (tested against cloth edges).
    pub feature_edges: Vec<[u32; 2]>,
    /// Sharp vertices of analytic colliders (tested against cloth triangles).
    pub feature_vertices: Vec<u32>,
    /// The bodies the vertices belong to, analytic colliders first then meshes.
    pub bodies: Vec<Body>,
    /// Index of the first vertex of a triangle mesh: the vertices before it
    /// are analytic colliders' features.
    pub first_mesh_vertex: u32,
    /// Per vertex, whether the cloth pushed off it (or off an edge or
    /// triangle it belongs to) is held off it by the strain projection that
    /// follows the push: every mesh vertex, and the features of analytic
    /// colliders narrower than the cloth's edges, too thin for it to wrap
    /// round.
    pub holds: Vec<bool>,
}

impl Obstacles {
    /// The features of `analytic` colliders (what a cloth of `scale` needs of
    /// them) and the whole of `meshes`.
    pub fn new(analytic: &[Collider], meshes: &[MeshCollider], scale: ClothScale) -> Self {
        let mut o = Obstacles::default();
        for collider in analytic {
            let (points, edges) = match collider.shape {
                Shape::Sphere { radius } if scale.needs_surface_lattice(radius) => {
                    geodesic_lattice(radius, scale.lattice_chord(radius))
                }
                ref shape => sharp_features(shape),
            };
            if points.is_empty() {
                continue;
            }
            let index = o.bodies.len() as u32;
            let base = o.local.len() as u32;
            let body = Body {
                placement: collider.placement,
                friction: collider.friction,
                animation: None,
                first_vertex: base,
            };
            o.bodies.push(body);
            o.local.extend(points);
            o.vertex_collider.resize(o.local.len(), index);
            o.holds.resize(o.local.len(), holds_the_cloth(&collider.shape, scale));
            o.feature_vertices.extend(base..o.local.len() as u32);
            o.feature_edges.extend(edges.iter().map(|e| e.map(|v| v + base)));
        }
        o.first_mesh_vertex = o.local.len() as u32;
        for mesh in meshes {
            let index = o.bodies.len() as u32;
            let base = o.local.len() as u32;
            let animation = mesh.animation.clone();
            o.bodies.push(Body { placement: mesh.placement, friction: mesh.friction, animation, first_vertex: base });
            o.local.extend_from_slice(&mesh.vertices);
            o.vertex_collider.resize(o.local.len(), index);
            o.holds.resize(o.local.len(), true);
            o.triangles.extend(mesh.triangles.iter().map(|t| t.map(|v| v + base)));
        }
        o.ownership = Ownership::new(&o.triangles, o.local.len());
        o
    }

    /// Number of obstacle vertices.
    pub fn vertex_count(&self) -> usize {
        self.local.len()
    }

    /// True when there is nothing to collide with.
    pub fn is_empty(&self) -> bool {
        self.local.is_empty()
    }

    /// World positions of every vertex at the start and end of `window`.
    pub fn positions(&self, window: StepWindow, start: &mut Vec<Vector3<f64>>, end: &mut Vec<Vector3<f64>>) {
        start.clear();
        end.clear();
        for i in 0..self.local.len() {
            start.push(self.position(i, window.t0));
            end.push(self.position(i, window.t1));
        }
    }

    /// World position of vertex `i` at time `t` (s), m.
    pub fn position(&self, i: usize, t: f64) -> Vector3<f64> {
        let body = &self.bodies[self.vertex_collider[i] as usize];
        let local = match &body.animation {
            Some(animation) => animation.position(i - body.first_vertex as usize, t),
            None => self.local[i],
        };
        (body.placement.world_from_local(t) * Point3::from(local)).coords
    }
}

/// Whether the strain projection after a collision pass holds the cloth off
/// the features of `shape` it was pushed off, as it does off a mesh (see
/// [`PassState::pushed_off`](super::PassState::pushed_off)): when the shape's
/// cross-section is narrower than the cloth's longest edge (`scale`). The
/// cloth cannot wrap round such a prop at its resolution: it rests on it as
/// on a point, whose normal does not turn under it. Unheld there, each
/// projection pulled the particles a pass had lifted back down round the tip
/// and the next pass pushed them out again, until the impact zones froze the
/// cloth stretched (`needles`, 3 mm needles under a 10 mm cloth: 190 %
/// largest strain and 108 impact-zone steps; held, 4.5 % and none). A wider
/// shape's edges (a table's, a blade's) are wrapped round, the push's
/// normal turning as the cloth slides over them, and stay unheld.
fn holds_the_cloth(shape: &Shape, scale: ClothScale) -> bool {
    let width = match *shape {
        Shape::Plane => return false,
        Shape::Sphere { radius } | Shape::Cylinder { radius, .. } | Shape::Cone { radius, .. } => 2.0 * radius,
        Shape::Box { half_extents } => {
            let mut extents = [half_extents.x, half_extents.y, half_extents.z];
            extents.sort_unstable_by(f64::total_cmp);
            2.0 * extents[1]
        }
        Shape::Prism { side, .. } => 2.0 * side / 3f64.sqrt(),
    };
    width < scale.longest_edge_m
}

/// Sharp vertices and edges of an analytic shape, in its frame.
fn sharp_features(shape: &Shape) -> (Vec<Vector3<f64>>, Vec<[u32; 2]>) {
    match *shape {
        Shape::Plane | Shape::Sphere { .. } => (Vec::new(), Vec::new()),
        Shape::Box { half_extents: h } => {
            let corners: Vec<Vector3<f64>> =
                (0..8).map(|k| Vector3::new(sign(k & 1) * h.x, sign(k & 2) * h.y, sign(k & 4) * h.z)).collect();
            let edges = (0..8u32)
                .flat_map(|a| [1u32, 2, 4].into_iter().filter(move |bit| a & bit == 0).map(move |bit| [a, a | bit]))
                .collect();
            (corners, edges)
        }
        Shape::Cylinder { radius, half_height } => {
            let mut points = rim(radius, -half_height);
            points.extend(rim(radius, half_height));
            let n = RIM_SEGMENTS as u32;
            let mut edges = rim_edges(0);
            edges.extend(rim_edges(n));
            edges.extend((0..n).map(|k| [k, n + k]));
            (points, edges)
        }
        Shape::Cone { radius, half_height } => {
            let mut points = rim(radius, -half_height);
            let apex = points.len() as u32;
            points.push(Vector3::new(0.0, half_height, 0.0));
            let mut edges = rim_edges(0);
            edges.extend((0..RIM_SEGMENTS as u32).map(|k| [k, apex]));
            (points, edges)
        }
        Shape::Prism { side, half_height } => {
            let circumradius = side / 3f64.sqrt();
            let corner = |deg: f64, y: f64| {
                let (s, c) = deg.to_radians().sin_cos();
                Vector3::new(circumradius * s, y, circumradius * c)
            };
            let points: Vec<Vector3<f64>> =
                [-half_height, half_height].iter().flat_map(|&y| [0.0, 120.0, 240.0].map(|d| corner(d, y))).collect();
            let edges = vec![[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 3], [0, 3], [1, 4], [2, 5]];
            (points, edges)
        }
    }
}

/// Points and edges of a geodesic sphere of `radius` m, every point on the
/// surface: an icosahedron whose triangles are split in four until no edge
/// is longer than `chord` m, or [`MAX_LATTICE_LEVEL`] times.
fn geodesic_lattice(radius: f64, chord: f64) -> (Vec<Vector3<f64>>, Vec<[u32; 2]>) {
    let phi = (1.0 + 5f64.sqrt()) / 2.0;
    let mut points: Vec<Vector3<f64>> = [(-1.0, phi), (1.0, phi), (-1.0, -phi), (1.0, -phi)]
        .iter()
        .flat_map(|&(a, b)| [Vector3::new(a, b, 0.0), Vector3::new(0.0, a, b), Vector3::new(b, 0.0, a)])
        .map(|p| p.normalize())
        .collect();
    let mut triangles = icosahedron_faces(&points);
    for _ in 0..MAX_LATTICE_LEVEL {
        if longest_edge(&points, &triangles) * radius <= chord {
            break;
        }
        let mut midpoints = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, points: &mut Vec<Vector3<f64>>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                points.push((points[a as usize] + points[b as usize]).normalize());
                points.len() as u32 - 1
            })
        };
        triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) =
                    (midpoint(a, b, &mut points), midpoint(b, c, &mut points), midpoint(c, a, &mut points));
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    let mut edges: Vec<[u32; 2]> =
        triangles.iter().flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]]).map(|[a, b]| [a.min(b), a.max(b)]).collect();
    edges.sort_unstable();
    edges.dedup();
    (points.into_iter().map(|p| p * radius).collect(), edges)
}

/// The longest edge of `triangles` over `points`, in the points' unit (0
/// without triangles).
fn longest_edge(points: &[Vector3<f64>], triangles: &[[u32; 3]]) -> f64 {
    let edge = |a: u32, b: u32| (points[a as usize] - points[b as usize]).norm();
    triangles.iter().flat_map(|&[a, b, c]| [edge(a, b), edge(b, c), edge(c, a)]).fold(0.0, f64::max)
}

/// The faces of an icosahedron with unit-sphere `corners`: the triples of
/// corners that are pairwise neighbours (an edge is the shortest distance).
fn icosahedron_faces(corners: &[Vector3<f64>]) -> Vec<[u32; 3]> {
    let edge = (1..corners.len()).map(|b| (corners[0] - corners[b]).norm()).fold(f64::INFINITY, f64::min);
    let near = |a: u32, b: u32| ((corners[a as usize] - corners[b as usize]).norm() - edge).abs() < 1e-9;
    let n = corners.len() as u32;
    (0..n)
        .flat_map(|a| (a + 1..n).flat_map(move |b| (b + 1..n).map(move |c| [a, b, c])))
        .filter(|&[a, b, c]| near(a, b) && near(b, c) && near(c, a))
        .collect()
}

fn sign(bit: usize) -> f64 {
    if bit == 0 { -1.0 } else { 1.0 }
}

/// Corners of the polygon circumscribed about a horizontal circle of
/// `radius` at height `y`: its sides touch the circle at their midpoints, so
/// the polygon encloses the circle and cloth kept off the polygon is kept off
/// the circle (an inscribed one would let the true rim poke through by up to
/// `radius (1 − cos(π/N))`).
fn rim(radius: f64, y: f64) -> Vec<Vector3<f64>> {
    let corner_radius = radius / (std::f64::consts::PI / RIM_SEGMENTS as f64).cos();
    (0..RIM_SEGMENTS)
        .map(|k| {
            let angle = std::f64::consts::TAU * k as f64 / RIM_SEGMENTS as f64;
            Vector3::new(corner_radius * angle.cos(), y, corner_radius * angle.sin())
        })
        .collect()
}

/// Edges closing a rim whose points start at `base`.
fn rim_edges(base: u32) -> Vec<[u32; 2]> {
    let n = RIM_SEGMENTS as u32;
    (0..n).map(|k| [base + k, base + (k + 1) % n]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::motion::Placement;
    use nalgebra::Isometry3;

    /// A cloth fine enough that no curved collider needs surface features.
    const FINE_CLOTH: ClothScale = ClothScale { longest_edge_m: 0.01, thinnest_m: 0.0025 };

    fn collider(shape: Shape) -> Collider {
        let placement = Placement { rest_pose: Isometry3::translation(1.0, 0.0, 0.0), motion: None };
        Collider { name: "c".into(), shape, placement, friction: None }
    }

    #[test]
    fn sharp_features_enclose_their_shape_tightly() {
        let shapes = [
            (Shape::Box { half_extents: Vector3::new(0.01, 0.5, 0.15) }, 0.0),
            (Shape::Cylinder { radius: 0.003, half_height: 0.2 }, 0.003),
            (Shape::Cone { radius: 0.15, half_height: 0.5 }, 0.15),
            (Shape::Prism { side: 0.2, half_height: 0.5 }, 0.0),
        ];
        for (shape, radius) in shapes {
            // How far a circumscribed polygon's corner stands off its circle.
            let excess = radius * (1.0 / (std::f64::consts::PI / RIM_SEGMENTS as f64).cos() - 1.0);
            let (points, edges) = sharp_features(&shape);
            for [a, b] in &edges {
                for k in 0..=8 {
                    let p = points[*a as usize].lerp(&points[*b as usize], k as f64 / 8.0);
                    let d = shape.signed_distance(&p).distance;
                    assert!((-1e-12..=excess + 1e-12).contains(&d), "{shape:?}: {p} at {d} m from the surface");
                }
            }
        }
        let (corners, edges) = sharp_features(&Shape::Box { half_extents: Vector3::repeat(1.0) });
        assert_eq!((corners.len(), edges.len()), (8, 12));
        assert!(edges.iter().all(|[a, b]| (corners[*a as usize] - corners[*b as usize]).norm() == 2.0));
    }

    #[test]
    fn the_cloth_is_held_off_meshes_and_off_props_thinner_than_its_edges() {
        // A 10 mm cloth: a 6 mm needle, a 5 mm rod and a 9 mm cone are
        // thinner than its edges; a 2 cm blade (30 cm wide), a table and a
        // 16 cm cylinder are wrapped round.
        let held = |shape: Shape| {
            let o = Obstacles::new(&[collider(shape)], &[], FINE_CLOTH);
            assert!(!o.holds.is_empty() && o.holds.iter().all(|&h| h == o.holds[0]));
            o.holds[0]
        };
        assert!(held(Shape::Cylinder { radius: 0.003, half_height: 0.2 }));
        assert!(held(Shape::Box { half_extents: Vector3::new(0.0025, 0.5, 0.0025) }));
        assert!(held(Shape::Cone { radius: 0.0045, half_height: 0.1 }));
        assert!(!held(Shape::Box { half_extents: Vector3::new(0.01, 0.5, 0.15) }));
        assert!(!held(Shape::Box { half_extents: Vector3::new(0.5, 0.025, 0.5) }));
        assert!(!held(Shape::Cylinder { radius: 0.08, half_height: 0.5 }));
        assert!(!held(Shape::Prism { side: 0.2, half_height: 0.5 }));
        let mesh = MeshCollider {
            name: "skin".into(),
            vertices: vec![Vector3::zeros(), Vector3::x(), Vector3::y()],
            triangles: vec![[0, 1, 2]],
            placement: Placement { rest_pose: Isometry3::identity(), motion: None },
            friction: None,
            animation: None,
        };
        let pillar = collider(Shape::Cylinder { radius: 0.1, half_height: 0.2 });
        let o = Obstacles::new(&[pillar], &[mesh], FINE_CLOTH);
        let first_mesh = o.first_mesh_vertex as usize;
        assert!(o.holds[..first_mesh].iter().all(|&h| !h) && o.holds[first_mesh..].iter().all(|&h| h));
        assert_eq!(o.holds.len(), o.vertex_count());
    }

    #[test]
    fn a_sphere_gets_a_surface_lattice_only_under_a_coarse_cloth() {
        // bad_mesh: 4.5-6.4 cm triangles on a 15 cm sphere dip 4.5 mm, past
        // the 2.5 mm thickness; drape_sphere's 2.2 cm on 30 cm, 0.28 mm.
        let coarse = ClothScale { longest_edge_m: 0.064, thinnest_m: 0.0025 };
        let fine = ClothScale { longest_edge_m: 0.0224, thinnest_m: 0.0025 };
        assert!(coarse.needs_surface_lattice(0.15));
        assert!(!fine.needs_surface_lattice(0.3));
        // The editor tests' 0.8 m cloth of 24 × 24 on a 25 cm ball: 1.6 mm.
        assert!(!ClothScale { longest_edge_m: 0.049, thinnest_m: 0.0025 }.needs_surface_lattice(0.25));
        let sphere = [collider(Shape::Sphere { radius: 0.15 })];
        assert!(Obstacles::new(&[collider(Shape::Sphere { radius: 0.3 })], &[], fine).is_empty());
        let o = Obstacles::new(&sphere, &[], coarse);
        assert_eq!(o.vertex_count(), 642, "three subdivisions: 10 × 4³ + 2 points");
        assert_eq!(o.feature_edges.len(), 1920);
    }

    #[test]
    fn the_geodesic_lattice_lies_on_its_sphere_with_edges_no_longer_than_asked() {
        let (radius, chord) = (0.15, 0.027);
        let (points, edges) = geodesic_lattice(radius, chord);
        assert!(points.iter().all(|p| (p.norm() - radius).abs() < 1e-12));
        let euler = points.len() as i64 - edges.len() as i64 + (2 * edges.len() / 3) as i64;
        assert_eq!(euler, 2, "a closed triangulated sphere: V − E + F = 2");
        let longest = edges.iter().map(|[a, b]| (points[*a as usize] - points[*b as usize]).norm()).fold(0.0, f64::max);
        assert!(longest <= chord, "longest edge {longest} m");
        // Its chords stand at most a quarter of a 2.5 mm thickness inside.
        assert!(longest * longest / (8.0 * radius) <= 0.0025 / 4.0);
        for [a, b] in &edges {
            let middle = (points[*a as usize] + points[*b as usize]) / 2.0;
            assert!(radius - middle.norm() <= 0.0025 / 4.0 + 1e-12);
        }
    }

    #[test]
    fn obstacle_vertices_follow_their_collider() {
        let o = Obstacles::new(
            &[collider(Shape::Sphere { radius: 1.0 }), collider(Shape::Cone { radius: 0.1, half_height: 0.5 })],
            &[],
            FINE_CLOTH,
        );
        assert_eq!(o.bodies.len(), 1, "a sphere has no sharp feature");
        assert_eq!(o.vertex_count(), RIM_SEGMENTS + 1);
        let (mut start, mut end) = (Vec::new(), Vec::new());
        o.positions(StepWindow { t0: 0.0, t1: 0.1 }, &mut start, &mut end);
        let apex = start[RIM_SEGMENTS];
        assert!((apex - Vector3::new(1.0, 0.5, 0.0)).norm() < 1e-12);
    }

    #[test]
    fn a_deforming_mesh_moves_each_vertex_along_its_own_samples() {
        let frames = vec![vec![Vector3::zeros(), Vector3::x()], vec![Vector3::y(), Vector3::x() * 2.0]];
        let animation = VertexAnimation { fps: 10.0, start_s: 0.0, frames, cycle: false, lead_in: 0 };
        let mesh = MeshCollider {
            name: "skin".into(),
            vertices: vec![Vector3::zeros(), Vector3::x()],
            triangles: vec![],
            placement: Placement { rest_pose: Isometry3::translation(0.0, 0.0, 1.0), motion: None },
            friction: None,
            animation: Some(Arc::new(animation)),
        };
        let o = Obstacles::new(&[], &[mesh], FINE_CLOTH);
        let (mut start, mut end) = (Vec::new(), Vec::new());
        o.positions(StepWindow { t0: 0.0, t1: 0.05 }, &mut start, &mut end);
        assert_eq!(start, [Vector3::new(0.0, 0.0, 1.0), Vector3::new(1.0, 0.0, 1.0)]);
        assert!((end[0] - Vector3::new(0.0, 0.5, 1.0)).norm() < 1e-12, "half way to the next frame: {}", end[0]);
        assert!((end[1] - Vector3::new(1.5, 0.0, 1.0)).norm() < 1e-12);
    }
}
