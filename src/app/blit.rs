//! The viewport's image drawn into egui's render pass by a paint callback:
//! an opaque copy, magnified by the sampler. Through egui's own textured
//! quad (blended, with its colour conversions) it took ~60 % of a window's
//! paint under lavapipe.

use egui_wgpu::{CallbackResources, CallbackTrait};

/// The pipeline that draws an image over a callback's rectangle, made once
/// for the window's surface format.
pub struct BlitPipeline {
    pipeline: wgpu::RenderPipeline,
    sampler: wgpu::Sampler,
}

/// What egui's render pass needs to draw the viewport's current image; kept
/// in the UI renderer's [`CallbackResources`].
pub struct ViewportImage {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
}

impl BlitPipeline {
    /// The pipeline writing `format` (the surface's, or a screenshot's of
    /// the same format).
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> BlitPipeline {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("viewport blit"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../../shaders/blit.wgsl").into()),
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("viewport blit"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("viewport blit"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        BlitPipeline { pipeline, sampler }
    }

    /// The resources that draw `image` (a view egui would sample: values
    /// already encoded for the surface).
    pub fn image(&self, device: &wgpu::Device, image: &wgpu::TextureView) -> ViewportImage {
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewport blit"),
            layout: &self.pipeline.get_bind_group_layout(0),
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(image) },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        });
        ViewportImage { pipeline: self.pipeline.clone(), bind_group }
    }
}

impl ViewportImage {
    /// Draws the image over the pass's viewport.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// A shape that draws the [`ViewportImage`] in the UI renderer's resources
/// over `rect` (nothing until one is there).
pub fn viewport_image(rect: egui::Rect) -> egui::Shape {
    egui::Shape::Callback(egui_wgpu::Callback::new_paint_callback(rect, PaintViewport))
}

struct PaintViewport;

impl CallbackTrait for PaintViewport {
    fn paint(&self, _: egui::PaintCallbackInfo, pass: &mut wgpu::RenderPass<'static>, resources: &CallbackResources) {
        if let Some(image) = resources.get::<ViewportImage>() {
            image.draw(pass);
        }
    }
}
