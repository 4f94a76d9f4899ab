//! Mouse control of the viewport camera: orbit (left drag), pan (right or
//! middle drag), zoom (wheel), frame-all, turntable.

use glam::Vec3;

use crate::render::OrbitCamera;

/// Degrees of orbit per pixel dragged.
const ORBIT_DEG_PER_PIXEL: f32 = 0.3;
/// Zoom factor per wheel point (e^(-points · ZOOM)).
const ZOOM_PER_POINT: f32 = 0.002;
/// Steepest pitch, degrees (the camera never flips over the pole).
const MAX_PITCH_DEG: f32 = 89.0;
/// Closest and farthest distances, m.
const DISTANCE_RANGE_M: (f32, f32) = (0.05, 200.0);

/// The user's camera: framed automatically until they move it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraControl {
    /// The camera the user moved to; `None` follows the scene's own framing.
    pub manual: Option<OrbitCamera>,
    /// Turn the camera around the scene once in this many seconds.
    pub turntable_period_s: Option<f32>,
    /// Yaw added by the turntable so far, degrees.
    pub turntable_yaw_deg: f32,
}

impl CameraControl {
    /// The camera to draw with, given the scene's automatic framing.
    pub fn camera(&self, framed: OrbitCamera) -> OrbitCamera {
        let mut camera = self.manual.unwrap_or(framed);
        camera.yaw_deg += self.turntable_yaw_deg;
        camera
    }

    /// Orbits by a drag of (`dx`, `dy`) pixels.
    pub fn orbit(&mut self, framed: OrbitCamera, dx: f32, dy: f32) {
        let camera = self.manual.get_or_insert(framed);
        camera.yaw_deg -= dx * ORBIT_DEG_PER_PIXEL;
        camera.pitch_deg = (camera.pitch_deg + dy * ORBIT_DEG_PER_PIXEL).clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG);
    }

    /// Pans by a drag of (`dx`, `dy`) pixels in a viewport `height` pixels
    /// tall: the point under the cursor stays under it (at the target's depth).
    pub fn pan(&mut self, framed: OrbitCamera, dx: f32, dy: f32, height: f32) {
        let turned = self.camera(framed);
        let camera = self.manual.get_or_insert(framed);
        let towards_eye = (turned.eye() - turned.target).normalize_or_zero();
        let right = Vec3::Y.cross(towards_eye).try_normalize().unwrap_or(Vec3::X);
        let up = towards_eye.cross(right);
        let metres_per_pixel = 2.0 * camera.distance_m * (0.5 * camera.fov_y_deg.to_radians()).tan() / height.max(1.0);
        camera.target += (-dx * right + dy * up) * metres_per_pixel;
    }

    /// Zooms by `points` of wheel scroll (positive moves closer).
    pub fn zoom(&mut self, framed: OrbitCamera, points: f32) {
        let camera = self.manual.get_or_insert(framed);
        let (near, far) = DISTANCE_RANGE_M;
        camera.distance_m = (camera.distance_m * (-points * ZOOM_PER_POINT).exp()).clamp(near, far);
    }

    /// Back to the scene's framing.
    pub fn frame_all(&mut self) {
        self.manual = None;
        self.turntable_yaw_deg = 0.0;
    }

    /// Advances the turntable by `elapsed_s`.
    pub fn tick(&mut self, elapsed_s: f32) {
        if let Some(period) = self.turntable_period_s.filter(|p| *p > 0.0) {
            self.turntable_yaw_deg = (self.turntable_yaw_deg + 360.0 * elapsed_s / period) % 360.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn framed() -> OrbitCamera {
        OrbitCamera { target: Vec3::ZERO, yaw_deg: 30.0, pitch_deg: 20.0, distance_m: 3.0, fov_y_deg: 27.0 }
    }

    #[test]
    fn dragging_orbits_and_pitch_stops_short_of_the_pole() {
        let mut control = CameraControl::default();
        control.orbit(framed(), 100.0, 0.0);
        assert!(control.camera(framed()).yaw_deg.abs() < 1e-4, "100 px at 0.3°/px from 30°");
        control.orbit(framed(), 0.0, 10_000.0);
        assert_eq!(control.camera(framed()).pitch_deg, MAX_PITCH_DEG);
        control.frame_all();
        assert_eq!(control.camera(framed()), framed());
    }

    #[test]
    fn panning_keeps_the_target_at_its_depth_and_moves_it_by_the_drag() {
        let mut control = CameraControl::default();
        let height = 500.0;
        control.pan(framed(), -height, 0.0, height);
        let moved = control.camera(framed());
        let shift = moved.target - framed().target;
        let towards_eye = (framed().eye() - framed().target).normalize();
        assert!(shift.dot(towards_eye).abs() < 1e-5, "no motion in depth");
        let view_height = 2.0 * 3.0 * (13.5f32).to_radians().tan();
        assert!((shift.length() - view_height).abs() < 1e-4, "one viewport height of drag moves the view height");
    }

    #[test]
    fn zoom_is_multiplicative_and_bounded() {
        let mut control = CameraControl::default();
        control.zoom(framed(), 100.0);
        control.zoom(framed(), -100.0);
        assert!((control.camera(framed()).distance_m - 3.0).abs() < 1e-5);
        control.zoom(framed(), 1e6);
        assert_eq!(control.camera(framed()).distance_m, DISTANCE_RANGE_M.0);
    }

    #[test]
    fn turntable_turns_once_per_period() {
        let mut control = CameraControl { turntable_period_s: Some(4.0), ..Default::default() };
        control.tick(1.0);
        assert!((control.camera(framed()).yaw_deg - 120.0).abs() < 1e-4);
    }
}
