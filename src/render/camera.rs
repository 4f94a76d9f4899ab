//! The camera: an orbit about a target point, framed automatically on the
//! scene's bounds or set from the scene file, and its wgpu matrices (right
//! handed, Y up, depth 0..1).

use glam::camera::rh::{proj::directx, view::look_at_mat4};
use glam::{Mat4, Vec3};

/// An axis-aligned box, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Bounds {
    /// The box around `points`, or `None` when there are none.
    pub fn around(points: impl IntoIterator<Item = Vec3>) -> Option<Bounds> {
        points.into_iter().fold(None, |b: Option<Bounds>, p| {
            Some(b.map_or(Bounds { min: p, max: p }, |b| Bounds { min: b.min.min(p), max: b.max.max(p) }))
        })
    }

    /// The box around both.
    pub fn union(self, other: Bounds) -> Bounds {
        Bounds { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    /// Centre, m.
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Radius of the sphere through the corners, m.
    pub fn radius(&self) -> f32 {
        0.5 * (self.max - self.min).length()
    }
}

/// A camera orbiting `target` at `distance_m`, looking at it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrbitCamera {
    /// Point looked at, world space, m.
    pub target: Vec3,
    /// Angle about +Y from +Z towards +X, degrees.
    pub yaw_deg: f32,
    /// Elevation above the horizontal, degrees (positive looks down).
    pub pitch_deg: f32,
    /// Distance from the target, m.
    pub distance_m: f32,
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
}

/// Default yaw of an automatically framed camera: a three-quarter view, degrees.
pub const DEFAULT_YAW_DEG: f32 = 30.0;
/// Default pitch of an automatically framed camera, degrees.
pub const DEFAULT_PITCH_DEG: f32 = 20.0;
/// Default vertical field of view (a 50 mm lens on 24 mm film height), degrees.
pub const DEFAULT_FOV_Y_DEG: f32 = 27.0;
/// Margin around the framed bounds, as a factor on the distance.
const FRAMING_MARGIN: f32 = 1.1;

impl OrbitCamera {
    /// The camera at `yaw_deg`, `pitch_deg` and `fov_y_deg`, looking at the
    /// centre of `bounds`, just far enough that every corner of the box is in
    /// an image of `aspect` (width / height), with a small margin.
    pub fn framing(bounds: &Bounds, aspect: f32, yaw_deg: f32, pitch_deg: f32, fov_y_deg: f32) -> OrbitCamera {
        let tan_y = (0.5 * fov_y_deg.to_radians()).tan();
        let tan_x = tan_y * aspect;
        let mut camera = OrbitCamera { target: bounds.centre(), yaw_deg, pitch_deg, distance_m: 1.0, fov_y_deg };
        let towards_eye = (camera.eye() - camera.target).normalize();
        let right = Vec3::Y.cross(towards_eye).try_normalize().unwrap_or(Vec3::X);
        let up = towards_eye.cross(right);
        // A corner at depth z (towards the eye) and offsets x, y is inside the
        // frustum when the eye is at least z + |x|/tan_x and z + |y|/tan_y away.
        let needed = (0..8)
            .map(|i| {
                let pick = |bit: usize, lo: f32, hi: f32| if i & bit == 0 { lo } else { hi };
                let corner = Vec3::new(
                    pick(1, bounds.min.x, bounds.max.x),
                    pick(2, bounds.min.y, bounds.max.y),
                    pick(4, bounds.min.z, bounds.max.z),
                ) - camera.target;
                let z = corner.dot(towards_eye);
                (z + corner.dot(right).abs() / tan_x).max(z + corner.dot(up).abs() / tan_y)
            })
            .fold(1e-3, f32::max);
        camera.distance_m = FRAMING_MARGIN * needed;
        camera
    }

    /// Where the camera is, world space, m.
    pub fn eye(&self) -> Vec3 {
        let (yaw, pitch) = (self.yaw_deg.to_radians(), self.pitch_deg.to_radians());
        let towards_eye = Vec3::new(pitch.cos() * yaw.sin(), pitch.sin(), pitch.cos() * yaw.cos());
        self.target + self.distance_m * towards_eye
    }

    /// `view_from_world`.
    pub fn view(&self) -> Mat4 {
        look_at_mat4(self.eye(), self.target, Vec3::Y)
    }

    /// `clip_from_view` for an image of `aspect`, with the far plane beyond a
    /// ground of half size `ground_extent_m` around the target.
    pub fn projection(&self, aspect: f32, ground_extent_m: f32) -> Mat4 {
        let near = (0.02 * self.distance_m).max(0.01);
        let far = self.distance_m + 2.0 * ground_extent_m;
        directx::perspective(self.fov_y_deg.to_radians(), aspect, near, far)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box() -> Bounds {
        Bounds { min: Vec3::splat(-0.5), max: Vec3::splat(0.5) }
    }

    #[test]
    fn framing_keeps_every_corner_inside_the_image() {
        for aspect in [0.5, 1.0, 16.0 / 9.0] {
            let camera = OrbitCamera::framing(&unit_box(), aspect, 30.0, 20.0, 27.0);
            let clip_from_world = camera.projection(aspect, 10.0) * camera.view();
            for i in 0..8 {
                let corner = Vec3::new([-0.5, 0.5][i & 1], [-0.5, 0.5][(i >> 1) & 1], [-0.5, 0.5][i >> 2]);
                let clip = clip_from_world * corner.extend(1.0);
                let ndc = clip.truncate() / clip.w;
                assert!(ndc.x.abs() < 1.0 && ndc.y.abs() < 1.0, "aspect {aspect}: {ndc}");
                assert!(ndc.z > 0.0 && ndc.z < 1.0);
            }
        }
    }

    #[test]
    fn eye_follows_yaw_and_pitch() {
        let camera =
            OrbitCamera { target: Vec3::ZERO, yaw_deg: 90.0, pitch_deg: 0.0, distance_m: 2.0, fov_y_deg: 30.0 };
        assert!((camera.eye() - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-5);
        let above = OrbitCamera { pitch_deg: 90.0, ..camera };
        assert!((above.eye() - Vec3::new(0.0, 2.0, 0.0)).length() < 1e-5);
    }
}
