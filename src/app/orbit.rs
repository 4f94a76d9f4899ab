//! The viewport camera: orbit (left drag), pan (right or middle drag), zoom
//! towards the cursor (wheel), views from the figure's sides, following the
//! figure as it walks, turntable.

use glam::{Vec2, Vec3};

use crate::render::OrbitCamera;
use crate::render::camera::{DEFAULT_PITCH_DEG, DEFAULT_YAW_DEG};
use crate::stage::figure::FigurePath;

/// Degrees of orbit per pixel dragged.
const ORBIT_DEG_PER_PIXEL: f32 = 0.3;
/// Zoom factor per wheel point (e^(-points · ZOOM)).
const ZOOM_PER_POINT: f32 = 0.002;
/// Steepest pitch, degrees (the camera never flips over the pole).
const MAX_PITCH_DEG: f32 = 89.0;
/// Closest and farthest distances, m.
const DISTANCE_RANGE_M: (f32, f32) = (0.05, 200.0);

/// A side to look at the figure from (its own front, whichever way it walks).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewSide {
    /// Facing the figure.
    Front,
    /// Behind it.
    Back,
    /// At its left side.
    Left,
    /// At its right side.
    Right,
    /// In front, turned towards its left, from a little above.
    ThreeQuarter,
    /// From above.
    Top,
}

impl ViewSide {
    /// Every side, in the order the View menu lists them.
    pub const ALL: [ViewSide; 6] =
        [ViewSide::Front, ViewSide::ThreeQuarter, ViewSide::Left, ViewSide::Right, ViewSide::Back, ViewSide::Top];

    /// Name in the UI.
    pub fn label(self) -> &'static str {
        match self {
            ViewSide::Front => "Front",
            ViewSide::Back => "Back",
            ViewSide::Left => "Left",
            ViewSide::Right => "Right",
            ViewSide::ThreeQuarter => "Three-quarter",
            ViewSide::Top => "Top",
        }
    }

    /// Yaw from the figure's front and pitch of the view, degrees (a figure
    /// facing +Z has its left hand towards +X).
    pub fn angles_deg(self) -> (f32, f32) {
        match self {
            ViewSide::Front => (0.0, 0.0),
            ViewSide::Back => (180.0, 0.0),
            ViewSide::Left => (90.0, 0.0),
            ViewSide::Right => (-90.0, 0.0),
            ViewSide::ThreeQuarter => (DEFAULT_YAW_DEG, DEFAULT_PITCH_DEG),
            ViewSide::Top => (0.0, MAX_PITCH_DEG),
        }
    }
}

/// The user's camera: the scene's framing until they move it, optionally
/// following the figure as it walks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraControl {
    /// The camera the user placed; `None` uses the scene's own framing.
    pub manual: Option<OrbitCamera>,
    /// The time the camera was placed at, s (the scene's framing: 0): a
    /// following camera moves with the figure from there.
    pub placed_at_s: f64,
    /// Keep the figure framed while it walks.
    pub follow: bool,
    /// Turn the camera around the scene once in this many seconds.
    pub turntable_period_s: Option<f32>,
    /// Yaw added by the turntable so far, degrees.
    pub turntable_yaw_deg: f32,
}

impl Default for CameraControl {
    fn default() -> Self {
        CameraControl { manual: None, placed_at_s: 0.0, follow: true, turntable_period_s: None, turntable_yaw_deg: 0.0 }
    }
}

impl CameraControl {
    /// The camera to draw with at `t_s`, given the scene's framing (of the
    /// first frame) and the figure's path.
    pub fn camera(&self, framed: OrbitCamera, path: &FigurePath, t_s: f64) -> OrbitCamera {
        let mut camera = self.manual.unwrap_or(framed);
        let from = if self.manual.is_some() { self.placed_at_s } else { 0.0 };
        if self.follow {
            camera.target += path.shift(from, t_s);
        }
        camera.yaw_deg += self.turntable_yaw_deg;
        camera
    }

    /// Places the camera at `camera` (shown at `t_s`), the turntable at its start.
    pub fn place(&mut self, camera: OrbitCamera, t_s: f64) {
        (self.manual, self.placed_at_s, self.turntable_yaw_deg) = (Some(camera), t_s, 0.0);
    }

    /// Makes the camera `shown` at `t_s` the user's, to move it from there.
    fn take(&mut self, shown: OrbitCamera, t_s: f64) -> &mut OrbitCamera {
        let mut camera = shown;
        camera.yaw_deg -= self.turntable_yaw_deg;
        self.placed_at_s = t_s;
        self.manual.insert(camera)
    }

    /// Orbits the camera `shown` at `t_s` by a drag of (`dx`, `dy`) pixels.
    pub fn orbit(&mut self, shown: OrbitCamera, t_s: f64, dx: f32, dy: f32) {
        let camera = self.take(shown, t_s);
        camera.yaw_deg -= dx * ORBIT_DEG_PER_PIXEL;
        camera.pitch_deg = (camera.pitch_deg + dy * ORBIT_DEG_PER_PIXEL).clamp(-MAX_PITCH_DEG, MAX_PITCH_DEG);
    }

    /// Pans the camera `shown` at `t_s` by a drag of (`dx`, `dy`) pixels in
    /// a viewport `height` pixels tall: the point under the cursor stays
    /// under it (at the target's depth).
    pub fn pan(&mut self, shown: OrbitCamera, t_s: f64, dx: f32, dy: f32, height: f32) {
        let (right, up) = screen_axes(&shown);
        let camera = self.take(shown, t_s);
        let metres_per_pixel = 2.0 * camera.distance_m * (0.5 * camera.fov_y_deg.to_radians()).tan() / height.max(1.0);
        camera.target += (-dx * right + dy * up) * metres_per_pixel;
    }

    /// Zooms the camera `shown` at `t_s` by `points` of wheel scroll
    /// (positive moves closer) towards the point under the cursor at the
    /// target's depth; `cursor` is its place in the image (-1..1 each way,
    /// +y up) of `aspect`.
    pub fn zoom(&mut self, shown: OrbitCamera, t_s: f64, points: f32, cursor: Vec2, aspect: f32) {
        let (right, up) = screen_axes(&shown);
        let half_height = shown.distance_m * (0.5 * shown.fov_y_deg.to_radians()).tan();
        let under_cursor = shown.target + (cursor.x * aspect * right + cursor.y * up) * half_height;
        let camera = self.take(shown, t_s);
        let (near, far) = DISTANCE_RANGE_M;
        let distance = (camera.distance_m * (-points * ZOOM_PER_POINT).exp()).clamp(near, far);
        let kept = distance / camera.distance_m;
        camera.target = under_cursor + (camera.target - under_cursor) * kept;
        camera.distance_m = distance;
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

/// The directions of the image's right and up in the world, for `camera`.
fn screen_axes(camera: &OrbitCamera) -> (Vec3, Vec3) {
    let towards_eye = (camera.eye() - camera.target).normalize_or_zero();
    let right = Vec3::Y.cross(towards_eye).try_normalize().unwrap_or(Vec3::X);
    (right, towards_eye.cross(right))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn framed() -> OrbitCamera {
        OrbitCamera { target: Vec3::ZERO, yaw_deg: 30.0, pitch_deg: 20.0, distance_m: 3.0, fov_y_deg: 27.0 }
    }

    fn still() -> FigurePath {
        FigurePath::through(30.0, vec![nalgebra::Vector3::zeros()])
    }

    fn shown(control: &CameraControl) -> OrbitCamera {
        control.camera(framed(), &still(), 0.0)
    }

    #[test]
    fn dragging_orbits_and_pitch_stops_short_of_the_pole() {
        let mut control = CameraControl::default();
        control.orbit(shown(&control), 0.0, 100.0, 0.0);
        assert!(shown(&control).yaw_deg.abs() < 1e-4, "100 px at 0.3°/px from 30°");
        control.orbit(shown(&control), 0.0, 0.0, 10_000.0);
        assert_eq!(shown(&control).pitch_deg, MAX_PITCH_DEG);
        control.frame_all();
        assert_eq!(shown(&control), framed());
    }

    #[test]
    fn panning_keeps_the_target_at_its_depth_and_moves_it_by_the_drag() {
        let mut control = CameraControl::default();
        let height = 500.0;
        control.pan(shown(&control), 0.0, -height, 0.0, height);
        let shift = shown(&control).target - framed().target;
        let towards_eye = (framed().eye() - framed().target).normalize();
        assert!(shift.dot(towards_eye).abs() < 1e-5, "no motion in depth");
        let view_height = 2.0 * 3.0 * (13.5f32).to_radians().tan();
        assert!((shift.length() - view_height).abs() < 1e-4, "one viewport height of drag moves the view height");
    }

    #[test]
    fn zoom_is_multiplicative_and_bounded() {
        let mut control = CameraControl::default();
        control.zoom(shown(&control), 0.0, 100.0, Vec2::ZERO, 1.5);
        control.zoom(shown(&control), 0.0, -100.0, Vec2::ZERO, 1.5);
        assert!((shown(&control).distance_m - 3.0).abs() < 1e-5);
        assert!(shown(&control).target.length() < 1e-5, "zooming at the centre keeps the target");
        control.zoom(shown(&control), 0.0, 1e6, Vec2::ZERO, 1.5);
        assert_eq!(shown(&control).distance_m, DISTANCE_RANGE_M.0);
    }

    #[test]
    fn zooming_keeps_the_point_under_the_cursor_under_it() {
        let mut control = CameraControl::default();
        let before = shown(&control);
        let (cursor, aspect) = (Vec2::new(0.6, -0.4), 1.5);
        let (right, up) = screen_axes(&before);
        let half_height = 3.0 * (13.5f32).to_radians().tan();
        let point = before.target + (cursor.x * aspect * right + cursor.y * up) * half_height;
        control.zoom(before, 0.0, 300.0, cursor, aspect);
        let after = shown(&control);
        let clip = after.projection(aspect, 10.0) * after.view() * point.extend(1.0);
        let ndc = Vec2::new(clip.x, clip.y) / clip.w;
        assert!((ndc - cursor).length() < 1e-4, "{ndc} should stay at {cursor}");
        assert!(after.distance_m < 3.0);
    }

    #[test]
    fn a_following_camera_moves_with_the_figure_from_where_it_was_placed() {
        let walk = FigurePath::through(1.0, vec![nalgebra::Vector3::zeros(), nalgebra::Vector3::new(2.0, 0.0, 0.0)]);
        let mut control = CameraControl::default();
        control.place(framed(), 0.5);
        let later = control.camera(framed(), &walk, 1.0);
        assert!((later.target - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-5, "half the walk after placing");
        control.follow = false;
        assert_eq!(control.camera(framed(), &walk, 1.0).target, Vec3::ZERO);
    }

    #[test]
    fn turntable_turns_once_per_period() {
        let mut control = CameraControl { turntable_period_s: Some(4.0), ..Default::default() };
        control.tick(1.0);
        assert!((shown(&control).yaw_deg - 120.0).abs() < 1e-4);
    }
}
