//! An offscreen render target (multisampled colour and depth, a resolved
//! image) and its read-back into an RGBA image.

use super::gpu::{Gpu, RenderError};
use super::renderer::{COLOR_FORMAT, DEPTH_FORMAT, Renderer, SAMPLE_COUNT, View};

/// Bytes per pixel of [`COLOR_FORMAT`].
const BYTES_PER_PIXEL: u32 = 4;

/// Textures of one image size, reused frame after frame.
pub struct OffscreenTarget {
    width: u32,
    height: u32,
    color: wgpu::TextureView,
    depth: wgpu::TextureView,
    resolved: wgpu::Texture,
    resolved_view: wgpu::TextureView,
    readback: wgpu::Buffer,
    padded_row_bytes: u32,
}

fn attachment(
    gpu: &Gpu,
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    samples: u32,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

impl OffscreenTarget {
    /// A `width` × `height` target, pixels.
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> OffscreenTarget {
        let size = (width, height);
        let color = attachment(gpu, "colour", size, COLOR_FORMAT, SAMPLE_COUNT, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let depth = attachment(gpu, "depth", size, DEPTH_FORMAT, SAMPLE_COUNT, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let resolved = attachment(
            gpu,
            "resolved",
            size,
            COLOR_FORMAT,
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let padded_row_bytes = (width * BYTES_PER_PIXEL).div_ceil(align) * align;
        let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: u64::from(padded_row_bytes) * u64::from(height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        OffscreenTarget {
            width,
            height,
            color: color.create_view(&Default::default()),
            depth: depth.create_view(&Default::default()),
            resolved_view: resolved.create_view(&Default::default()),
            resolved,
            readback,
            padded_row_bytes,
        }
    }

    /// Width / height.
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// Renders `view` with `renderer` and reads the image back (sRGB-encoded RGBA).
    pub fn render(&self, gpu: &Gpu, renderer: &Renderer, view: &View) -> Result<image::RgbaImage, RenderError> {
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        renderer.encode(&mut encoder, view, &self.color, Some(&self.resolved_view), &self.depth);
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.resolved,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row_bytes),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 },
        );
        gpu.queue.submit([encoder.finish()]);
        self.read(gpu)
    }

    fn read(&self, gpu: &Gpu) -> Result<image::RgbaImage, RenderError> {
        let slice = self.readback.slice(..);
        let (sender, receiver) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |result| {
            let _ = sender.send(result);
        });
        gpu.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| RenderError::Readback(e.to_string()))?;
        receiver
            .recv()
            .map_err(|e| RenderError::Readback(e.to_string()))?
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let row_bytes = (self.width * BYTES_PER_PIXEL) as usize;
        let mut pixels = Vec::with_capacity(row_bytes * self.height as usize);
        {
            let mapped = slice.get_mapped_range().map_err(|e| RenderError::Readback(e.to_string()))?;
            for row in mapped.chunks(self.padded_row_bytes as usize) {
                pixels.extend_from_slice(&row[..row_bytes]);
            }
        }
        self.readback.unmap();
        image::RgbaImage::from_raw(self.width, self.height, pixels)
            .ok_or_else(|| RenderError::Readback("image size does not match the pixel data".into()))
    }
}
