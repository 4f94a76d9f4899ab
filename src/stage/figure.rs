//! Where the figure is: the garments with every collider that has bounds
//! (bodies, props; not the ground), at one moment and along the motion. The
//! camera frames the figure's box at the frame shown and follows the
//! figure's path while it walks.

use glam::Vec3;
use nalgebra::{Point3, Vector3};

use crate::render::Bounds;
use crate::scene::Scene;

/// Points read per mesh collider when only the figure's place is wanted
/// (a body of 50,000 vertices is as well placed by 2,000 of them).
const PATH_SAMPLES_PER_MESH: usize = 2000;
/// The path is averaged over this window, s, so a swinging arm or a flying
/// hem does not shake a following camera.
const PATH_SMOOTHING_S: f64 = 1.0;
/// A figure whose path is shorter than this faces +Z (it stands), m.
const WALKING_DISTANCE_M: f64 = 0.3;

fn to_vec3(p: &Vector3<f64>) -> Vec3 {
    Vec3::new(p.x as f32, p.y as f32, p.z as f32)
}

/// The box around the garments' `positions` (every garment's vertices in
/// turn, m) and every bounded collider at `t_s`; `None` for an empty scene.
pub fn figure_bounds(scene: &Scene, positions: &[Vector3<f64>], t_s: f64) -> Option<Bounds> {
    let garments = positions.iter().map(to_vec3);
    let meshes = scene.mesh_colliders.iter().flat_map(|c| c.world_vertices(t_s)).map(|p| to_vec3(&p));
    let shapes = scene.colliders.iter().filter(|c| c.shape.bounding_radius().is_finite()).flat_map(|c| {
        let centre = to_vec3(&c.world_from_local(t_s).translation.vector);
        let r = Vec3::splat(c.shape.bounding_radius() as f32);
        [centre - r, centre + r]
    });
    Bounds::around(garments.chain(meshes).chain(shapes))
}

/// The centre of the colliders that have bounds at `t_s` (a sparse sample
/// of each mesh), m; `None` when there are none.
fn colliders_centre(scene: &Scene, t_s: f64) -> Option<Vector3<f64>> {
    let meshes = scene.mesh_colliders.iter().flat_map(|c| {
        let stride = c.vertices.len().div_ceil(PATH_SAMPLES_PER_MESH).max(1);
        let pose = c.placement.world_from_local(t_s);
        (0..c.vertices.len()).step_by(stride).map(move |v| (pose * Point3::from(c.local_vertex(v, t_s))).coords)
    });
    let shapes = scene
        .colliders
        .iter()
        .filter(|c| c.shape.bounding_radius().is_finite())
        .map(|c| c.world_from_local(t_s).translation.vector);
    let (min, max) = meshes.chain(shapes).fold(None, |b: Option<(Vector3<f64>, Vector3<f64>)>, p| {
        Some(b.map_or((p, p), |(lo, hi)| (lo.inf(&p), hi.sup(&p))))
    })?;
    Some(0.5 * (min + max))
}

/// The figure's place over the scene's range, smoothed: what a following
/// camera tracks.
#[derive(Clone, Debug, PartialEq)]
pub struct FigurePath {
    /// Frames per second of the samples.
    fps: f64,
    /// The smoothed centre at each frame, m.
    centres: Vec<Vector3<f64>>,
}

impl FigurePath {
    /// The path of `scene`'s colliders, one sample per frame (none moving: a
    /// path that stays put).
    pub fn new(scene: &Scene) -> FigurePath {
        let raw: Vec<Vector3<f64>> = (0..=scene.frame_count)
            .map(|f| colliders_centre(scene, f as f64 / scene.fps).unwrap_or_else(Vector3::zeros))
            .collect();
        let half = (0.5 * PATH_SMOOTHING_S * scene.fps).round() as usize;
        let centres = (0..raw.len())
            .map(|f| {
                let window = &raw[f.saturating_sub(half)..(f + half + 1).min(raw.len())];
                window.iter().sum::<Vector3<f64>>() / window.len() as f64
            })
            .collect();
        FigurePath::through(scene.fps, centres)
    }

    /// The path through `centres` (m), one per frame at `fps`.
    pub fn through(fps: f64, centres: Vec<Vector3<f64>>) -> FigurePath {
        FigurePath { fps, centres }
    }

    /// The smoothed centre at `t_s` (held before the start and after the end), m.
    pub fn centre(&self, t_s: f64) -> Vector3<f64> {
        let last = self.centres.len().saturating_sub(1);
        let f = (t_s * self.fps).clamp(0.0, last as f64);
        let (i, s) = (f.floor() as usize, f.fract());
        let at = |k: usize| self.centres.get(k.min(last)).copied().unwrap_or_else(Vector3::zeros);
        at(i) * (1.0 - s) + at(i + 1) * s
    }

    /// How far the figure moved from `from_s` to `to_s`, m.
    pub fn shift(&self, from_s: f64, to_s: f64) -> Vec3 {
        to_vec3(&(self.centre(to_s) - self.centre(from_s)))
    }

    /// The yaw of a camera in front of the figure, degrees: facing where it
    /// walks, or +Z (the convention of Maya, Max and Mixamo characters) when
    /// it stands.
    pub fn front_yaw_deg(&self) -> f32 {
        let (Some(first), Some(last)) = (self.centres.first(), self.centres.last()) else { return 0.0 };
        let walk = last - first;
        match walk.x.hypot(walk.z) > WALKING_DISTANCE_M {
            true => walk.x.atan2(walk.z).to_degrees() as f32,
            false => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path(centres: Vec<Vector3<f64>>) -> FigurePath {
        FigurePath::through(10.0, centres)
    }

    #[test]
    fn the_path_is_read_between_frames_and_held_past_its_ends() {
        let p = path(vec![Vector3::zeros(), Vector3::new(1.0, 0.0, 0.0)]);
        assert_eq!(p.centre(0.05), Vector3::new(0.5, 0.0, 0.0));
        assert_eq!(p.centre(-1.0), Vector3::zeros());
        assert_eq!(p.centre(9.0), Vector3::new(1.0, 0.0, 0.0));
        assert_eq!(p.shift(0.0, 0.1), Vec3::X);
    }

    #[test]
    fn the_front_faces_where_the_figure_walks_or_plus_z() {
        let walking_x = path(vec![Vector3::zeros(), Vector3::new(2.0, 0.0, 0.0)]);
        assert!((walking_x.front_yaw_deg() - 90.0).abs() < 1e-4, "eye on +X for a walk along +X");
        let standing = path(vec![Vector3::zeros(), Vector3::new(0.1, 0.0, 0.0)]);
        assert_eq!(standing.front_yaw_deg(), 0.0);
    }
}
