//! The camera built around the figure: the view shown, framing the garment
//! and body at the frame shown, views from the figure's sides.

use super::Editor;
use crate::app::orbit::ViewSide;
use crate::render::camera::DEFAULT_FOV_Y_DEG;
use crate::render::{Bounds, OrbitCamera};
use crate::stage::figure::figure_bounds;

/// The camera used before the viewport has framed the scene (UI tests
/// without a GPU): a three-quarter view of the origin from 3 m.
const UNFRAMED: OrbitCamera = OrbitCamera {
    target: glam::Vec3::ZERO,
    yaw_deg: 30.0,
    pitch_deg: 20.0,
    distance_m: 3.0,
    fov_y_deg: DEFAULT_FOV_Y_DEG,
};

impl Editor {
    /// The time of the frame shown, s.
    pub fn shown_time_s(&self) -> f64 {
        self.timeline.time_of(self.timeline.current())
    }

    /// The camera the viewport draws with now.
    pub fn shown_camera(&self) -> OrbitCamera {
        self.camera.camera(self.framed.unwrap_or(UNFRAMED), &self.figure, self.shown_time_s())
    }

    /// The box around the garments and bodies at the frame shown (the
    /// bodies alone while previewing the motion without cloth).
    pub fn shown_figure_bounds(&self) -> Option<Bounds> {
        let shown = self.timeline.shown().filter(|_| !self.timeline.body_only);
        let positions = shown.map(|f| f.positions.as_slice()).unwrap_or_default();
        figure_bounds(&self.scene, positions, self.shown_time_s())
    }

    /// Fits the garment and body at the frame shown in the view, seen from
    /// where the camera looks now.
    pub fn frame_figure(&mut self) {
        let shown = self.shown_camera();
        self.frame_from(shown.yaw_deg, shown.pitch_deg);
    }

    /// Looks at the figure from `side`, framing it at the frame shown.
    pub fn view_from(&mut self, side: ViewSide) {
        let (yaw, pitch) = side.angles_deg();
        self.frame_from(self.figure.front_yaw_deg() + yaw, pitch);
    }

    fn frame_from(&mut self, yaw_deg: f32, pitch_deg: f32) {
        let Some(bounds) = self.shown_figure_bounds() else { return };
        let fov = self.shown_camera().fov_y_deg;
        let camera = OrbitCamera::framing(&bounds, self.viewport_aspect, yaw_deg, pitch_deg, fov);
        self.camera.place(camera, self.shown_time_s());
    }
}
