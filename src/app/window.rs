//! The editor's window: winit events into egui, the wgpu surface, and each
//! frame: take in the worker's news, lay out the UI, render the viewport,
//! paint the UI. Dropped files open or replace what they are.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use winit::application::ApplicationHandler;
use winit::event::{StartCause, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop, OwnedDisplayHandle};
use winit::window::{Window, WindowId};

use super::AppError;
use super::browse::dropped;
use super::editor::{Editor, Quality, RunState};
use super::panels::editor_ui;
use super::rasteriser::RasteriserPriority;
use super::viewport::Viewport;
use crate::render::Gpu;
use crate::render::gpu::supported_backends;
use crate::render::target::read_texture;
use crate::scene::Scene;
use crate::stage::offscreen::write_png;

/// Redraws per second while the simulation runs or the timeline plays.
const ANIMATION_HZ: f64 = 30.0;

/// Window frames that compile shaders and upload the scene first.
const WARM_UP_FRAMES: u32 = 3;

/// A window image to take, then close (smoke tests, documentation).
#[derive(Clone, Debug)]
pub struct Screenshot {
    /// The PNG to write.
    pub path: PathBuf,
    /// Simulate this many frames live first (0: the initial state); at most
    /// the scene's range, where the simulation stops.
    pub after_frames: usize,
    /// The quality to simulate at (default: the scene's own, Balanced).
    pub quality: Option<Quality>,
}

impl Screenshot {
    /// The frames to simulate before the image on a scene of `range` frames.
    fn frames_wanted(&self, range: usize) -> usize {
        self.after_frames.min(range)
    }
}

/// Opens the editor's window on `scene` and runs until it is closed (or,
/// with `screenshot`, until that image is written).
pub fn run(scene: Scene, screenshot: Option<Screenshot>) -> Result<(), AppError> {
    let event_loop = EventLoop::new().map_err(|e| AppError::Window(e.to_string()))?;
    event_loop.set_control_flow(ControlFlow::Wait);
    let display = event_loop.owned_display_handle();
    let mut editor = Editor::new(scene);
    if let Some(quality) = screenshot.as_ref().and_then(|shot| shot.quality) {
        editor.set_quality(quality);
    }
    let mut app = App { editor: Some(editor), display, open: None, failure: None, screenshot, live: LiveRate::Waiting };
    event_loop.run_app(&mut app).map_err(|e| AppError::Window(e.to_string()))?;
    match app.failure {
        Some(failure) => Err(failure),
        None => Ok(()),
    }
}

struct App {
    editor: Option<Editor>,
    display: OwnedDisplayHandle,
    open: Option<Open>,
    failure: Option<AppError>,
    screenshot: Option<Screenshot>,
    /// For a screenshot after live frames: how fast they came.
    live: LiveRate,
}

/// The window and everything drawn into it.
struct Open {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    gpu: Gpu,
    egui: egui_winit::State,
    painter: egui_wgpu::Renderer,
    viewport: Viewport,
    viewport_size: [u32; 2],
    editor: Editor,
    last_frame: Instant,
    frames_drawn: u32,
    /// The window's title as last set.
    title: String,
    /// When egui wants its next repaint (none: only on input).
    egui_repaint_at: Option<Instant>,
    /// The software rasteriser's priority (see [`RasteriserPriority`]).
    rasteriser: RasteriserPriority,
    /// The last frame's UI, kept for a screenshot.
    last_paint: Option<(Vec<egui::ClippedPrimitive>, egui_wgpu::ScreenDescriptor)>,
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.open.is_some() {
            return;
        }
        let Some(editor) = self.editor.take() else { return };
        match Open::new(event_loop, &self.display, editor) {
            Ok(open) => self.open = Some(open),
            Err(e) => {
                self.failure = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(open) = &mut self.open else { return };
        let response = open.egui.on_window_event(&open.window, &event);
        // egui asks for a repaint after every redraw; what it really needs
        // next comes with its output (`Open::egui_repaint_at`).
        let repaint = response.repaint && event != WindowEvent::RedrawRequested;
        match event {
            WindowEvent::CloseRequested if open.editor.request_quit() => event_loop.exit(),
            // Unsaved changes: the question shows on the next frame.
            WindowEvent::CloseRequested => open.window.request_redraw(),
            WindowEvent::Resized(size) => open.resize(size.width, size.height),
            WindowEvent::DroppedFile(path) => dropped(&mut open.editor, path),
            WindowEvent::RedrawRequested => {
                if let Err(e) = open.frame() {
                    self.failure = Some(e);
                    event_loop.exit();
                    return;
                }
                if let Some(shot) = &self.screenshot {
                    self.live.observe(&open.editor, open.frames_drawn, shot.frames_wanted(open.editor.timeline.range));
                }
                if let Some(shot) = self.screenshot.take_if(|shot| open.ready_for(shot)) {
                    if let Err(e) = open.screenshot(&shot.path) {
                        self.failure = Some(e);
                    }
                    event_loop.exit();
                }
                if open.editor.quit {
                    event_loop.exit();
                }
            }
            _ => {}
        }
        if repaint {
            open.window.request_redraw();
        }
    }

    /// While something moves by itself, or the viewport has a still image to
    /// draw anti-aliased, wake up at most [`ANIMATION_HZ`] times a second to
    /// redraw: a busy redraw loop would take a core from the simulation (and
    /// lavapipe draws on the CPU). Otherwise sleep until an event, or until
    /// egui's next timed repaint (a tooltip's delay, a fold's animation).
    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let redraw = |o: &Open| o.editor.is_animating() || o.viewport.needs_refinement();
        let animating = self.open.as_ref().is_some_and(redraw) || self.screenshot.is_some();
        let animation = animating.then(|| Instant::now() + Duration::from_secs_f64(1.0 / ANIMATION_HZ));
        let egui = self.open.as_ref().and_then(|o| o.egui_repaint_at);
        let wake = match (animation, egui) {
            (Some(a), Some(e)) => Some(a.min(e)),
            (a, e) => a.or(e),
        };
        event_loop.set_control_flow(wake.map_or(ControlFlow::Wait, ControlFlow::WaitUntil));
    }

    fn new_events(&mut self, _: &ActiveEventLoop, cause: StartCause) {
        if let (StartCause::ResumeTimeReached { .. }, Some(open)) = (cause, &self.open) {
            open.window.request_redraw();
        }
    }
}

/// How fast frames come while the window draws, measured once for a
/// screenshot after live frames (the live benchmark, `tools/bench-live`).
enum LiveRate {
    /// No simulated frame yet.
    Waiting,
    /// Since the first frame seen: when, which frame, window frames drawn then.
    Measuring { since: Instant, frame: usize, drawn: u32 },
    /// Reported.
    Done,
}

impl LiveRate {
    /// Starts at the first simulated frame and prints the rate once the
    /// `wanted` frame has come: frames of animation per second of wall time,
    /// and window redraws per second.
    fn observe(&mut self, editor: &Editor, drawn_now: u32, wanted: usize) {
        let last = editor.timeline.last();
        match *self {
            LiveRate::Waiting if last > 0 => {
                *self = LiveRate::Measuring { since: Instant::now(), frame: last, drawn: drawn_now };
            }
            LiveRate::Measuring { since, frame, drawn } if last >= wanted && last > frame => {
                let seconds = since.elapsed().as_secs_f64();
                let rate = (last - frame) as f64 / seconds;
                let redraws = f64::from(drawn_now - drawn) / seconds;
                let (frames, quality) = (last - frame, editor.quality.label());
                println!(
                    "live: {frames} frames in {seconds:.2} s, {rate:.1} frames/s, window drawn {redraws:.1} times/s ({quality})"
                );
                *self = LiveRate::Done;
            }
            _ => {}
        }
    }
}

impl Open {
    fn new(event_loop: &ActiveEventLoop, display: &OwnedDisplayHandle, editor: Editor) -> Result<Open, AppError> {
        let attributes = Window::default_attributes()
            .with_title(editor.title())
            .with_inner_size(winit::dpi::LogicalSize::new(1440.0, 860.0));
        let window = Arc::new(event_loop.create_window(attributes).map_err(|e| AppError::Window(e.to_string()))?);
        let descriptor = wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(display.clone()));
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor { backends: supported_backends(), ..descriptor });
        let surface = instance.create_surface(window.clone()).map_err(|e| AppError::Graphics(e.to_string()))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .map_err(|e| AppError::Graphics(e.to_string()))?;
        let gpu = Gpu::open(&adapter).map_err(|e| AppError::Graphics(e.to_string()))?;
        let mut rasteriser = RasteriserPriority::default();
        if gpu.software {
            rasteriser.yield_to_the_simulation();
        }
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .ok_or_else(|| AppError::Graphics("the window's surface is not supported by the adapter".into()))?;
        // egui composites in gamma space: prefer a plain (non-sRGB) format.
        let formats = surface.get_capabilities(&adapter).formats;
        if let Some(plain) = formats.iter().find(|f| !f.is_srgb()) {
            config.format = *plain;
        }
        surface.configure(&gpu.device, &config);
        let context = egui::Context::default();
        let egui = egui_winit::State::new(context, egui::ViewportId::ROOT, &window, None, None, None);
        let painter = egui_wgpu::Renderer::new(&gpu.device, config.format, egui_wgpu::RendererOptions::default());
        let viewport = Viewport::new(&gpu, config.format).map_err(|e| AppError::Graphics(e.to_string()))?;
        Ok(Open {
            window,
            surface,
            config,
            gpu,
            egui,
            painter,
            viewport,
            viewport_size: [640, 480],
            editor,
            last_frame: Instant::now(),
            frames_drawn: 0,
            title: String::new(),
            egui_repaint_at: None,
            rasteriser,
            last_paint: None,
        })
    }

    /// Whether the screenshot can be taken: the scene shown and, when asked,
    /// the frames simulated (the simulation is started on the first call).
    fn ready_for(&mut self, shot: &Screenshot) -> bool {
        if self.frames_drawn < WARM_UP_FRAMES || self.editor.is_loading() || self.editor.timeline.is_empty() {
            return false;
        }
        let idle = self.editor.run == RunState::Idle;
        if self.editor.timeline.last() < shot.frames_wanted(self.editor.timeline.range) {
            if idle {
                self.editor.simulate();
            }
            return false;
        }
        // Then the still view a designer sees after pausing: the newest
        // frame, anti-aliased.
        if !idle {
            self.editor.pause();
            return false;
        }
        let newest = self.editor.timeline.current() == self.editor.timeline.last();
        newest && !self.editor.is_animating() && !self.viewport.needs_refinement()
    }

    fn resize(&mut self, width: u32, height: u32) {
        if width > 0 && height > 0 {
            (self.config.width, self.config.height) = (width, height);
            self.surface.configure(&self.gpu.device, &self.config);
            self.window.request_redraw();
        }
    }

    /// One frame of the editor.
    fn frame(&mut self) -> Result<(), AppError> {
        let started = Instant::now();
        let elapsed = self.last_frame.elapsed().as_secs_f64();
        self.last_frame = started;
        self.editor.update(elapsed);
        self.viewport.render(&mut self.editor, self.viewport_size, &mut self.painter);
        let input = self.egui.take_egui_input(&self.window);
        let context = self.egui.egui_ctx().clone();
        let drawn = self.viewport.has_image();
        let editor = &mut self.editor;
        let mut viewport_size = self.viewport_size;
        let output = context.run_ui(input, |ui| viewport_size = editor_ui(ui, editor, drawn));
        self.viewport_size = viewport_size;
        let title = self.editor.title();
        if title != self.title {
            self.window.set_title(&title);
            self.title = title;
        }
        self.egui.handle_platform_output(&self.window, output.platform_output);
        let delay = output.viewport_output.get(&egui::ViewportId::ROOT).map(|v| v.repaint_delay);
        self.egui_repaint_at = delay.and_then(|d| Instant::now().checked_add(d));
        let jobs = context.tessellate(output.shapes, output.pixels_per_point);
        let frame = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(frame) | wgpu::CurrentSurfaceTexture::Suboptimal(frame) => frame,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.gpu.device, &self.config);
                self.window.request_redraw();
                return Ok(());
            }
            _ => {
                self.window.request_redraw();
                return Ok(());
            }
        };
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.config.width, self.config.height],
            pixels_per_point: output.pixels_per_point,
        };
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                self.painter.update_texture(&self.gpu.device, &self.gpu.queue, *id, delta);
            }
        }
        let target = frame.texture.create_view(&Default::default());
        self.paint(&jobs, &screen, &target);
        self.gpu.queue.present(frame);
        self.last_paint = Some((jobs, screen));
        for id in &output.textures_delta.free {
            self.painter.free_texture(id);
        }
        self.frames_drawn += 1;
        // The first frames compile the shaders: not a sign of starvation.
        if self.frames_drawn > WARM_UP_FRAMES {
            self.rasteriser.frame_took(started.elapsed());
        }
        Ok(())
    }

    fn paint(
        &mut self,
        jobs: &[egui::ClippedPrimitive],
        screen: &egui_wgpu::ScreenDescriptor,
        target: &wgpu::TextureView,
    ) {
        let (device, queue) = (&self.gpu.device, &self.gpu.queue);
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("ui") });
        let mut commands = self.painter.update_buffers(device, queue, &mut encoder, jobs, screen);
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("ui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: target,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color { r: 0.1, g: 0.1, b: 0.1, a: 1.0 }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            let mut pass = pass.forget_lifetime();
            self.painter.render(&mut pass, jobs, screen);
        }
        commands.push(encoder.finish());
        queue.submit(commands);
    }

    /// Draws the UI of the last frame once more into an offscreen texture of
    /// the window's size and format, and writes it as a PNG (the surface
    /// itself cannot be read back portably).
    fn screenshot(&mut self, path: &Path) -> Result<(), AppError> {
        let (width, height) = (self.config.width, self.config.height);
        let texture = self.gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("screenshot"),
            size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: self.config.format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let Some((jobs, screen)) = self.last_paint.take() else {
            return Err(AppError::Graphics("no frame was drawn to take a screenshot of".into()));
        };
        self.paint(&jobs, &screen, &texture.create_view(&Default::default()));
        let image =
            read_texture(&self.gpu, &texture, (width, height)).map_err(|e| AppError::Graphics(e.to_string()))?;
        write_png(path, &image).map_err(|e| AppError::Graphics(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_screenshot_after_more_frames_than_the_scene_has_waits_for_its_last() {
        let shot = Screenshot { path: PathBuf::from("shot.png"), after_frames: 120, quality: None };
        assert_eq!(shot.frames_wanted(114), 114);
        assert_eq!(shot.frames_wanted(300), 120);
    }
}
