//! A stage rendered offscreen to images: the headless path of `drape render`
//! and of the render tests.

use std::path::Path;

use nalgebra::Vector3;

use super::Stage;
use crate::io::atomic::{WriteError, write_file};
use crate::render::{Gpu, LightRig, OffscreenTarget, OrbitCamera, RenderError, Renderer};
use crate::scene::Scene;

/// A scene's stage with a renderer and an image-sized target.
pub struct OffscreenStage {
    gpu: Gpu,
    renderer: Renderer,
    target: OffscreenTarget,
    stage: Stage,
    /// The lights used for the next image.
    pub rig: LightRig,
}

impl OffscreenStage {
    /// Prepares `scene` for `width` × `height` images under `rig`.
    pub fn new(gpu: &Gpu, scene: &Scene, width: u32, height: u32, rig: LightRig) -> Result<Self, RenderError> {
        let stage = Stage::new(scene)?;
        let mut renderer = Renderer::new(gpu)?;
        renderer.set_meshes(stage.meshes());
        let target = OffscreenTarget::new(gpu, width, height);
        Ok(OffscreenStage { gpu: gpu.clone(), renderer, target, stage, rig })
    }

    /// The image of the garments at `positions` (all garments, scene order, m)
    /// at time `t_s`.
    pub fn render(&mut self, positions: &[Vector3<f64>], t_s: f64) -> Result<image::RgbaImage, RenderError> {
        self.stage.pose(&mut self.renderer, positions, t_s);
        let view = self.stage.view(self.target.aspect(), &self.rig, t_s);
        self.target.render(&self.gpu, &self.renderer, &view)
    }

    /// The image of the garments at `positions` at time `t_s` through `camera`.
    pub fn render_through(
        &mut self,
        positions: &[Vector3<f64>],
        t_s: f64,
        camera: OrbitCamera,
    ) -> Result<image::RgbaImage, RenderError> {
        self.stage.pose(&mut self.renderer, positions, t_s);
        let view = self.stage.view_through(camera, self.target.aspect(), &self.rig, t_s);
        self.target.render(&self.gpu, &self.renderer, &view)
    }

    /// Colours the garments by a fit map from now on ([`Stage::use_fit_map`]).
    pub fn use_fit_map(&mut self) {
        self.stage.use_fit_map();
        self.renderer.set_meshes(self.stage.meshes());
    }

    /// The fit-map values of the next image ([`Stage::set_fit_map_values`]).
    pub fn set_fit_map_values(&mut self, values: Vec<f32>) {
        self.stage.set_fit_map_values(values);
    }

    /// The stage, e.g. to read its camera.
    pub fn stage(&self) -> &Stage {
        &self.stage
    }
}

/// Writes `image` as a PNG, atomically.
pub fn write_png(path: &Path, image: &image::RgbaImage) -> Result<(), WriteError> {
    let mut bytes = Vec::new();
    image
        .write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| WriteError { path: path.to_owned(), source: std::io::Error::other(e) })?;
    write_file(path, |out| std::io::Write::write_all(out, &bytes))
}
