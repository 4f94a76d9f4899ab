//! The editor's 3D view: the scene's [`Stage`] drawn by the PBR renderer into
//! a texture that egui's render pass copies into the window ([`super::blit`]).
//! It re-renders only when what it shows changed (frame, camera, lights,
//! size, scene), so a software rasteriser keeps the UI responsive. On a software rasteriser it also draws half the window's
//! resolution, and while the image changes (the cloth simulating or playing,
//! the camera moving) one sample per pixel: 4× MSAA there costs half of each
//! render. Once the view is still it is drawn again, anti-aliased.

use std::sync::Arc;

use super::blit::BlitPipeline;
use super::editor::Editor;
use crate::render::{Gpu, OrbitCamera, RenderError, Renderer, TextureTarget};
use crate::stage::Stage;
use crate::stage::fit_map::{FitMap, map_values};

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
    map: Option<FitMap>,
}

/// The viewport's GPU side.
pub struct Viewport {
    gpu: Gpu,
    renderer: Renderer,
    /// The stage drawn, for the editor's scene generation and whether a fit
    /// map colours it.
    stage: Option<((u64, bool), Stage)>,
    target: Option<TextureTarget>,
    blit: BlitPipeline,
    /// What the last image shows, and whether it was anti-aliased.
    shown: Option<(Shown, bool)>,
    /// Whether images of a changing view are anti-aliased too (on a GPU).
    antialias_moving: bool,
    /// Fraction of the window's pixels rendered (below 1 on a software rasteriser).
    pub resolution_scale: f32,
}

impl Viewport {
    /// A viewport on `gpu` for a window of `surface_format` (anti-aliased at
    /// full resolution on a GPU, see the module's doc on a software
    /// rasteriser), or why the adapter cannot render it.
    pub fn new(gpu: &Gpu, surface_format: wgpu::TextureFormat) -> Result<Viewport, RenderError> {
        let software = gpu.software;
        Ok(Viewport {
            gpu: gpu.clone(),
            renderer: Renderer::new(gpu)?,
            stage: None,
            target: None,
            blit: BlitPipeline::new(&gpu.device, surface_format),
            shown: None,
            antialias_moving: !software,
            resolution_scale: if software { 0.5 } else { 1.0 },
        })
    }

    /// The last image rendered, read back (sRGB-encoded RGBA), if any.
    pub fn image(&self) -> Option<Result<image::RgbaImage, crate::render::RenderError>> {
        self.target.as_ref().map(|t| t.read(&self.gpu))
    }

    /// Whether the last image was drawn without anti-aliasing, to be drawn
    /// again with it on the next redraw if the view stays still.
    pub fn needs_refinement(&self) -> bool {
        self.shown.as_ref().is_some_and(|(_, antialiased)| !antialiased)
    }

    /// Whether there is an image for [`super::blit::viewport_image`] to draw.
    pub fn has_image(&self) -> bool {
        self.shown.is_some()
    }

    /// Renders the editor's current view at `size` physical pixels (scaled by
    /// [`Self::resolution_scale`]) into the image `ui_renderer` draws,
    /// when anything shown changed, or anti-aliased when it did not and the
    /// editor is still. Sets the editor's automatic framing.
    pub fn render(&mut self, editor: &mut Editor, size: [u32; 2], ui_renderer: &mut egui_wgpu::Renderer) {
        let key = (editor.generation, editor.fit_map.is_some());
        if self.stage.as_ref().is_none_or(|(k, _)| *k != key) {
            match Stage::new(&editor.scene) {
                Ok(mut stage) => {
                    if key.1 {
                        stage.use_fit_map();
                    }
                    self.renderer.set_meshes(stage.meshes());
                    self.stage = Some((key, stage));
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
            ui_renderer.callback_resources.insert(self.blit.image(&self.gpu.device, &target.encoded));
            self.target = Some(target);
        }
        let Some(target) = &self.target else { return };
        let framed = stage.camera(target.aspect(), 0.0);
        editor.framed = Some(framed);
        let camera = editor.shown_camera();
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
            map: editor.fit_map,
        };
        let (same, refined) = match &self.shown {
            Some((last, antialiased)) => (*last == shown, *antialiased),
            None => (false, false),
        };
        let antialiased = self.antialias_moving || (same && !editor.is_animating());
        if same && (refined || !antialiased) {
            return;
        }
        if let Some(map) = editor.fit_map {
            stage.set_fit_map_values(map_values(map, &editor.scene, &frame.positions, &frame.contact_force_n));
        }
        stage.pose(&mut self.renderer, &frame.positions, time_s);
        stage.show_garments(&mut self.renderer, !shown.body_only);
        let view = stage.view_through(camera, target.aspect(), editor.light_rig(), time_s);
        target.render(&self.gpu, &self.renderer, &view, antialiased);
        self.shown = Some((shown, antialiased));
    }
}
