//! Triangle meshes of the analytic collider shapes, in their local frames, for
//! drawing (the simulation uses the exact shapes, not these).

use std::f32::consts::TAU;

use crate::render::Vertex;
use crate::sim::colliders::Shape;

/// Segments around a revolved shape.
const AROUND: usize = 64;
/// Rings from pole to pole of a sphere.
const SPHERE_RINGS: usize = 32;

/// A mesh in the shape's local frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShapeMesh {
    /// Vertices with outward normals.
    pub vertices: Vec<Vertex>,
    /// Triangles, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
}

impl ShapeMesh {
    /// Adds a quad strip between two rings of `AROUND + 1` vertices starting at `a` and `b`.
    fn ring_strip(&mut self, a: u32, b: u32) {
        for i in 0..AROUND as u32 {
            self.indices.extend([a + i, b + i, a + i + 1, a + i + 1, b + i, b + i + 1]);
        }
    }

    /// Adds a ring of `AROUND + 1` vertices at radius `r` and height `y`, with
    /// the normal `(n_r, n_y)` in the meridian plane; returns its first index.
    fn ring(&mut self, r: f32, y: f32, n_r: f32, n_y: f32, v: f32) -> u32 {
        let first = self.vertices.len() as u32;
        for i in 0..=AROUND {
            let angle = TAU * i as f32 / AROUND as f32;
            let (s, c) = angle.sin_cos();
            self.vertices.push(Vertex {
                position: [r * s, y, r * c],
                normal: [n_r * s, n_y, n_r * c],
                uv: [i as f32 / AROUND as f32, v],
            });
        }
        first
    }

    /// A flat disc of radius `r` at height `y`, facing `+y` when `up`.
    fn disc(&mut self, r: f32, y: f32, up: bool) {
        let n = if up { 1.0 } else { -1.0 };
        let centre = self.vertices.len() as u32;
        self.vertices.push(Vertex { position: [0.0, y, 0.0], normal: [0.0, n, 0.0], uv: [0.5, 0.5] });
        let rim = self.ring(r, y, 0.0, n, 0.0);
        for i in 0..AROUND as u32 {
            let (a, b) = (rim + i, rim + i + 1);
            self.indices.extend(if up { [centre, a, b] } else { [centre, b, a] });
        }
    }

    /// A convex polygon (corners counter-clockwise in the (x, z) plane)
    /// extruded between `-half_height` and `half_height`, with flat faces.
    fn prism(&mut self, corners: &[[f32; 2]], half_height: f32) {
        let k = corners.len();
        for i in 0..k {
            let ([x0, z0], [x1, z1]) = (corners[i], corners[(i + 1) % k]);
            let (nx, nz) = (z1 - z0, x0 - x1);
            let len = (nx * nx + nz * nz).sqrt().max(f32::MIN_POSITIVE);
            let normal = [nx / len, 0.0, nz / len];
            let first = self.vertices.len() as u32;
            for (x, y, z) in
                [(x0, -half_height, z0), (x1, -half_height, z1), (x1, half_height, z1), (x0, half_height, z0)]
            {
                self.vertices.push(Vertex { position: [x, y, z], normal, uv: [0.0, 0.0] });
            }
            self.indices.extend([first, first + 2, first + 1, first, first + 3, first + 2]);
        }
        for (y, n) in [(half_height, 1.0f32), (-half_height, -1.0)] {
            let first = self.vertices.len() as u32;
            for &[x, z] in corners {
                self.vertices.push(Vertex { position: [x, y, z], normal: [0.0, n, 0.0], uv: [0.0, 0.0] });
            }
            for i in 1..k as u32 - 1 {
                self.indices.extend(if n > 0.0 {
                    [first, first + i + 1, first + i]
                } else {
                    [first, first + i, first + i + 1]
                });
            }
        }
    }
}

/// The mesh of a bounded shape; `None` for the plane (drawn as the ground).
pub fn shape_mesh(shape: &Shape) -> Option<ShapeMesh> {
    let mut mesh = ShapeMesh::default();
    match *shape {
        Shape::Plane => return None,
        Shape::Sphere { radius } => {
            let r = radius as f32;
            let rings: Vec<u32> = (0..=SPHERE_RINGS)
                .map(|j| {
                    let polar = std::f32::consts::PI * j as f32 / SPHERE_RINGS as f32;
                    let (s, c) = polar.sin_cos();
                    mesh.ring(r * s, r * c, s, c, j as f32 / SPHERE_RINGS as f32)
                })
                .collect();
            for pair in rings.windows(2) {
                mesh.ring_strip(pair[0], pair[1]);
            }
        }
        Shape::Cylinder { radius, half_height } => {
            let (r, h) = (radius as f32, half_height as f32);
            let top = mesh.ring(r, h, 1.0, 0.0, 0.0);
            let bottom = mesh.ring(r, -h, 1.0, 0.0, 1.0);
            mesh.ring_strip(top, bottom);
            mesh.disc(r, h, true);
            mesh.disc(r, -h, false);
        }
        Shape::Cone { radius, half_height } => {
            let (r, h) = (radius as f32, half_height as f32);
            let slant = (r * r + 4.0 * h * h).sqrt();
            let (n_r, n_y) = (2.0 * h / slant, r / slant);
            let apex = mesh.ring(0.0, h, n_r, n_y, 0.0);
            let base = mesh.ring(r, -h, n_r, n_y, 1.0);
            mesh.ring_strip(apex, base);
            mesh.disc(r, -h, false);
        }
        Shape::Box { half_extents } => {
            let (x, z) = (half_extents.x as f32, half_extents.z as f32);
            mesh.prism(&[[-x, -z], [x, -z], [x, z], [-x, z]], half_extents.y as f32);
        }
        Shape::Prism { side, half_height } => {
            let circumradius = (side / 3f64.sqrt()) as f32;
            let corner = |deg: f32| [circumradius * deg.to_radians().sin(), circumradius * deg.to_radians().cos()];
            mesh.prism(&[corner(0.0), corner(240.0), corner(120.0)], half_height as f32);
        }
    }
    Some(mesh)
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector3;

    use super::*;

    fn shapes() -> Vec<Shape> {
        vec![
            Shape::Sphere { radius: 0.3 },
            Shape::Box { half_extents: Vector3::new(0.5, 0.1, 0.3) },
            Shape::Cylinder { radius: 0.2, half_height: 0.4 },
            Shape::Cone { radius: 0.3, half_height: 0.25 },
            Shape::Prism { side: 0.4, half_height: 0.3 },
        ]
    }

    #[test]
    fn vertices_lie_on_the_exact_surface() {
        for shape in shapes() {
            let mesh = shape_mesh(&shape).unwrap();
            for v in &mesh.vertices {
                let p = Vector3::new(v.position[0], v.position[1], v.position[2]).cast::<f64>();
                let d = shape.signed_distance(&p).distance;
                assert!(d.abs() < 1e-6, "{shape:?}: vertex {p:?} at distance {d}");
            }
        }
    }

    #[test]
    fn triangles_wind_outwards_and_agree_with_the_vertex_normals() {
        for shape in shapes() {
            let mesh = shape_mesh(&shape).unwrap();
            let mut enclosed = 0.0;
            for t in mesh.indices.chunks_exact(3) {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vector3::from(mesh.vertices[i as usize].position));
                let face = (b - a).cross(&(c - a));
                enclosed += a.dot(&face) / 6.0;
                let normal = Vector3::from(mesh.vertices[t[0] as usize].normal);
                assert!(face.norm() < 1e-9 || face.dot(&normal) > 0.0, "{shape:?}");
            }
            // Divergence theorem: the signed volume is positive (close to the solid's).
            assert!(enclosed > 0.0, "{shape:?}: volume {enclosed}");
        }
        let sphere = shape_mesh(&Shape::Sphere { radius: 1.0 }).unwrap();
        let volume: f32 = sphere
            .indices
            .chunks_exact(3)
            .map(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vector3::from(sphere.vertices[i as usize].position));
                a.dot(&(b - a).cross(&(c - a))) / 6.0
            })
            .sum();
        assert!((volume / (4.0 / 3.0 * std::f32::consts::PI) - 1.0).abs() < 0.01, "{volume}");
    }
}
