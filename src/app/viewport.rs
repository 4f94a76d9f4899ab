//! The editor's 3D view: the scene's [`Stage`] drawn by the PBR renderer into
//! a texture that egui shows. It re-renders only when what it shows changed
//! (frame, camera, lights, size, scene), so a software rasteriser keeps the
//! UI responsive.

use std::sync::Arc;

use super::editor::Editor;
use crate::render::{Gpu, OrbitCamera, RenderError, Renderer, TextureTarget};
use crate::stage::Stage;

/// Everything the image depends on, to skip renders that would be the same.
#[derive(Clone, Debug, PartialEq)]
struct Shown {
    generation: u64,
    positions: usize,
    time_s: f64,
    camera: OrbitCamera,
    rig: usize,
    size: [u32; 2],
    body_only: bool,
}

/// The viewport's GPU side.
pub struct Viewport {
    gpu: Gpu,
    renderer: Renderer,
    stage: Option<(u64, Stage)>,
    target: Option<TextureTarget>,
    texture: Option<egui::TextureId>,
    shown: Option<Shown>,
    /// Fraction of the window's pixels rendered (below 1 on a software rasteriser).
    pub resolution_scale: f32,
}

impl Viewport {
    /// A viewport on `gpu`, or why the adapter cannot render it.
    pub fn new(gpu: &Gpu) -> Result<Viewport, RenderError> {
        let software = gpu.adapter_name.contains("llvmpipe") || gpu.adapter_name.contains("lavapipe");
        Ok(Viewport {
            gpu: gpu.clone(),
            renderer: Renderer::new(gpu)?,
            stage: None,
            target: None,
            texture: None,
            shown: None,
            resolution_scale: if software { 0.5 } else { 1.0 },
        })
    }

    /// The last image rendered, read back (sRGB-encoded RGBA), if any.
    pub fn image(&self) -> Option<Result<image::RgbaImage, crate::render::RenderError>> {
        self.target.as_ref().map(|t| t.read(&self.gpu))
    }

    /// The texture of the last render, if any.
    pub fn texture(&self) -> Option<egui::TextureId> {
        self.texture
    }

    /// Renders the editor's current view at `size` physical pixels (scaled by
    /// [`Self::resolution_scale`]) into the texture registered with `ui_renderer`,
    /// when anything shown changed. Sets the editor's automatic framing.
    pub fn render(&mut self, editor: &mut Editor, size: [u32; 2], ui_renderer: &mut egui_wgpu::Renderer) {
        if self.stage.as_ref().is_none_or(|(g, _)| *g != editor.generation) {
            match Stage::new(&editor.scene) {
                Ok(stage) => {
                    self.renderer.set_meshes(stage.meshes());
                    self.stage = Some((editor.generation, stage));
                }
                Err(e) => {
                    editor.tell(format!("cannot draw the scene: {e}"), true);
                    self.stage = None;
                    return;
                }
            }
        }
        let Some((_, stage)) = &mut self.stage else { return };
        let scaled = size.map(|s| ((s as f32 * self.resolution_scale).round() as u32).clamp(1, 4096));
        if self.target.as_ref().is_none_or(|t| t.size != (scaled[0], scaled[1])) {
            let target = TextureTarget::new(&self.gpu, scaled[0], scaled[1]);
            let filter = wgpu::FilterMode::Linear;
            match self.texture {
                Some(id) => {
                    ui_renderer.update_egui_texture_from_wgpu_texture(&self.gpu.device, &target.encoded, filter, id)
                }
                None => {
                    self.texture = Some(ui_renderer.register_native_texture(&self.gpu.device, &target.encoded, filter))
                }
            }
            self.target = Some(target);
        }
        let Some(target) = &self.target else { return };
        let framed = stage.camera(target.aspect(), 0.0);
        editor.framed = Some(framed);
        let camera = editor.camera.camera(framed);
        let current = editor.timeline.current();
        let Some(frame) = editor.timeline.shown() else { return };
        let time_s = editor.timeline.time_of(current);
        let shown = Shown {
            generation: editor.generation,
            positions: Arc::as_ptr(&frame.positions) as usize,
            time_s,
            camera,
            rig: editor.rig,
            size: scaled,
            body_only: editor.timeline.body_only,
        };
        if self.shown.as_ref() == Some(&shown) {
            return;
        }
        stage.pose(&mut self.renderer, &frame.positions, time_s);
        stage.show_garments(&mut self.renderer, !shown.body_only);
        let view = stage.view_through(camera, target.aspect(), editor.light_rig(), time_s);
        target.render(&self.gpu, &self.renderer, &view);
        self.shown = Some(shown);
    }
}
