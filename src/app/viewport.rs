//! The editor's 3D view: the scene's [`Stage`] drawn by the PBR renderer into
//! a texture that egui's render pass copies into the window ([`super::blit`]).
//! It re-renders only when what it shows changed (frame, camera, lights,
//! size, scene), so a software rasteriser keeps the UI responsive. On a software rasteriser it also draws half the window's
//! resolution, and while the image changes (the cloth simulating or playing,
//! the camera moving) one sample per pixel: 4× MSAA there costs half of each
//! render. Once the view is still it is drawn again, anti-aliased. With a
//! result pinned as A it draws A, or A and the current result B side by
//! side (each into half the image, then copied into place).

use std::sync::Arc;

use super::blit::BlitPipeline;
use super::editor::{Compare, Editor};
use super::worker::Frame;
use crate::render::{Gpu, OrbitCamera, RenderError, Renderer, TextureTarget};
use crate::scene::Scene;
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
    /// The pin drawn, its frame's positions, and how.
    compare: Option<(u64, usize, Compare)>,
}

/// One scene drawn: its stage, and a renderer holding its meshes.
struct Drawn {
    /// The scene generation (or pin) and whether a fit map colours it.
    key: (u64, bool),
    stage: Stage,
    renderer: Renderer,
}

impl Drawn {
    /// Makes `drawn` show `scene` for `key` unless it does, reusing its
    /// renderer (or `spare`) for the new meshes.
    fn ensure(
        drawn: &mut Option<Drawn>,
        spare: &mut Option<Renderer>,
        gpu: &Gpu,
        scene: &Scene,
        key: (u64, bool),
    ) -> Result<(), RenderError> {
        if drawn.as_ref().is_some_and(|d| d.key == key) {
            return Ok(());
        }
        let mut renderer = match drawn.take().map(|d| d.renderer).or_else(|| spare.take()) {
            Some(renderer) => renderer,
            None => Renderer::new(gpu)?,
        };
        let mut stage = Stage::new(scene)?;
        if key.1 {
            stage.use_fit_map();
        }
        renderer.set_meshes(stage.meshes());
        *drawn = Some(Drawn { key, stage, renderer });
        Ok(())
    }
}

/// What one pane shows.
struct Pane<'a> {
    scene: &'a Scene,
    frame: &'a Frame,
}

/// The viewport's GPU side.
pub struct Viewport {
    gpu: Gpu,
    /// The current scene (B).
    current: Option<Drawn>,
    /// The pinned result (A), while shown.
    pinned: Option<Drawn>,
    /// A renderer made and not yet used (the first scene takes it).
    spare: Option<Renderer>,
    target: Option<TextureTarget>,
    /// The left and right halves of a side-by-side image.
    halves: Option<(TextureTarget, TextureTarget)>,
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
            current: None,
            pinned: None,
            spare: Some(Renderer::new(gpu)?),
            target: None,
            halves: None,
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
        let map = editor.fit_map.is_some();
        let key = (editor.generation, map);
        if let Err(e) = Drawn::ensure(&mut self.current, &mut self.spare, &self.gpu, &editor.scene, key) {
            return editor.tell(format!("cannot draw the scene: {e}"), true);
        }
        let compare = editor.pinned.as_ref().filter(|_| editor.compare != Compare::B);
        match compare {
            Some(pin) => {
                if let Err(e) = Drawn::ensure(&mut self.pinned, &mut None, &self.gpu, &pin.scene, (pin.id, map)) {
                    return editor.tell(format!("cannot draw A: {e}"), true);
                }
            }
            None => self.pinned = None,
        }
        let scaled = size.map(|s| ((s as f32 * self.resolution_scale).round() as u32).clamp(2, 4096));
        self.fit_targets(scaled, editor.compare == Compare::SideBySide && compare.is_some(), ui_renderer);
        let Some(shown) = self.shown_now(editor) else { return };
        let (same, refined) = match &self.shown {
            Some((last, antialiased)) => (*last == shown, *antialiased),
            None => (false, false),
        };
        let antialiased = self.antialias_moving || (same && !editor.is_animating());
        if same && (refined || !antialiased) {
            return;
        }
        self.draw(editor, &shown, antialiased);
        self.shown = Some((shown, antialiased));
    }

    /// Makes the image `size` pixels, and its halves when `split`.
    fn fit_targets(&mut self, size: [u32; 2], split: bool, ui_renderer: &mut egui_wgpu::Renderer) {
        if self.target.as_ref().is_none_or(|t| t.size != (size[0], size[1])) {
            let target = TextureTarget::new(&self.gpu, size[0], size[1]);
            ui_renderer.callback_resources.insert(self.blit.image(&self.gpu.device, &target.encoded));
            self.target = Some(target);
        }
        let half = (size[0] / 2, size[1]);
        if !split {
            self.halves = None;
        } else if self.halves.as_ref().is_none_or(|(left, _)| left.size != half) {
            let right = (size[0] - half.0, size[1]);
            self.halves =
                Some((TextureTarget::new(&self.gpu, half.0, half.1), TextureTarget::new(&self.gpu, right.0, right.1)));
        }
    }

    /// What would be drawn now; sets the editor's framing for the pane's shape.
    fn shown_now(&self, editor: &mut Editor) -> Option<Shown> {
        let current = self.current.as_ref()?;
        let target = self.target.as_ref()?;
        let aspect = self.halves.as_ref().map_or(target.aspect(), |(left, _)| left.aspect());
        editor.framed = Some(current.stage.camera(aspect, 0.0));
        let frame = editor.timeline.shown()?;
        let k = editor.timeline.current();
        let compare = editor.pinned.as_ref().filter(|_| editor.compare != Compare::B).and_then(|pin| {
            let a = pin.frame(k)?;
            Some((pin.id, Arc::as_ptr(&a.positions) as usize, editor.compare))
        });
        Some(Shown {
            generation: editor.generation,
            positions: Arc::as_ptr(&frame.positions) as usize,
            time_s: editor.timeline.time_of(k),
            camera: editor.shown_camera(),
            rig: editor.rig,
            size: [target.size.0, target.size.1],
            body_only: editor.timeline.body_only,
            map: editor.fit_map,
            compare,
        })
    }

    fn draw(&mut self, editor: &Editor, shown: &Shown, antialiased: bool) {
        let k = editor.timeline.current();
        let (Some(frame), Some(target)) = (editor.timeline.shown(), &self.target) else { return };
        let b = Pane { scene: &editor.scene, frame };
        let a = editor.pinned.as_ref().and_then(|pin| Some(Pane { scene: &pin.scene, frame: pin.frame(k)? }));
        let draw = |drawn: &mut Option<Drawn>, pane: &Pane, into: &TextureTarget| {
            if let Some(d) = drawn {
                draw_pane(&self.gpu, d, pane, into, editor, shown, antialiased);
            }
        };
        match (shown.compare, a) {
            (Some((_, _, Compare::SideBySide)), Some(a)) => {
                let Some((left, right)) = &self.halves else { return };
                draw(&mut self.pinned, &a, left);
                draw(&mut self.current, &b, right);
                left.copy_into(&self.gpu, target, 0);
                right.copy_into(&self.gpu, target, left.size.0);
            }
            (Some((_, _, Compare::A)), Some(a)) => draw(&mut self.pinned, &a, target),
            _ => draw(&mut self.current, &b, target),
        }
    }
}

/// Draws `pane` with `drawn` into `into` as `shown` says.
fn draw_pane(
    gpu: &Gpu,
    drawn: &mut Drawn,
    pane: &Pane,
    into: &TextureTarget,
    editor: &Editor,
    shown: &Shown,
    antialiased: bool,
) {
    let Drawn { stage, renderer, .. } = drawn;
    if let Some(map) = shown.map {
        stage.set_fit_map_values(map_values(map, pane.scene, &pane.frame.positions, &pane.frame.contact_force_n));
    }
    stage.pose(renderer, &pane.frame.positions, shown.time_s);
    stage.show_garments(renderer, !shown.body_only);
    let view = stage.view_through(shown.camera, into.aspect(), editor.light_rig(), shown.time_s);
    into.render(gpu, renderer, &view, antialiased);
}
