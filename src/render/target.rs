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
}

fn attachment(
    gpu: &Gpu,
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    samples: u32,
    usage: wgpu::TextureUsages,
    view_formats: &[wgpu::TextureFormat],
) -> wgpu::Texture {
    gpu.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: samples,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats,
    })
}

/// A render attachment of a `size` image with `samples` per pixel.
fn sampled(gpu: &Gpu, label: &str, size: (u32, u32), format: wgpu::TextureFormat, samples: u32) -> wgpu::TextureView {
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT;
    attachment(gpu, label, size, format, samples, usage, &[]).create_view(&Default::default())
}

/// The multisampled colour and depth attachments of a `size` image.
fn multisampled(gpu: &Gpu, size: (u32, u32)) -> [wgpu::TextureView; 2] {
    [sampled(gpu, "colour", size, COLOR_FORMAT, SAMPLE_COUNT), sampled(gpu, "depth", size, DEPTH_FORMAT, SAMPLE_COUNT)]
}

impl OffscreenTarget {
    /// A `width` × `height` target, pixels.
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> OffscreenTarget {
        let size = (width, height);
        let [color, depth] = multisampled(gpu, size);
        let resolved = attachment(
            gpu,
            "resolved",
            size,
            COLOR_FORMAT,
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            &[],
        );
        OffscreenTarget {
            width,
            height,
            color,
            depth,
            resolved_view: resolved.create_view(&Default::default()),
            resolved,
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
        gpu.queue.submit([encoder.finish()]);
        read_texture(gpu, &self.resolved, (self.width, self.height))
    }
}

/// Reads a `size` texture of 4 bytes per pixel (RGBA or BGRA, which is
/// swapped to RGBA) back into an image.
pub fn read_texture(
    gpu: &Gpu,
    texture: &wgpu::Texture,
    (width, height): (u32, u32),
) -> Result<image::RgbaImage, RenderError> {
    let align = wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let padded_row_bytes = (width * BYTES_PER_PIXEL).div_ceil(align) * align;
    let readback = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(padded_row_bytes) * u64::from(height),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("read back") });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row_bytes),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
    gpu.queue.submit([encoder.finish()]);
    let slice = readback.slice(..);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    gpu.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| RenderError::Readback(e.to_string()))?;
    receiver
        .recv()
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let row_bytes = (width * BYTES_PER_PIXEL) as usize;
    let mut pixels = Vec::with_capacity(row_bytes * height as usize);
    {
        let mapped = slice.get_mapped_range().map_err(|e| RenderError::Readback(e.to_string()))?;
        for row in mapped.chunks(padded_row_bytes as usize) {
            pixels.extend_from_slice(&row[..row_bytes]);
        }
    }
    readback.unmap();
    if matches!(texture.format(), wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb) {
        for pixel in pixels.chunks_exact_mut(4) {
            pixel.swap(0, 2);
        }
    }
    image::RgbaImage::from_raw(width, height, pixels)
        .ok_or_else(|| RenderError::Readback("image size does not match the pixel data".into()))
}

/// A render target that stays on the GPU to be drawn by a UI (the editor's
/// viewport): the image is resolved into a texture that can be sampled, or
/// drawn into it at one sample per pixel where that is what a frame can
/// afford.
pub struct TextureTarget {
    /// Size, pixels.
    pub size: (u32, u32),
    /// The multisampled colour and depth of an anti-aliased image.
    color: wgpu::TextureView,
    depth: wgpu::TextureView,
    /// The depth of a one-sample image, drawn into the image directly.
    single_depth: wgpu::TextureView,
    image: wgpu::Texture,
    resolved: wgpu::TextureView,
    /// The resolved image viewed as plain `Rgba8Unorm`: sampling it gives the
    /// sRGB-encoded values, which is what UI toolkits (egui) composite.
    pub encoded: wgpu::TextureView,
}

impl TextureTarget {
    /// A `width` × `height` target, pixels.
    pub fn new(gpu: &Gpu, width: u32, height: u32) -> TextureTarget {
        let size = (width.max(1), height.max(1));
        let [color, depth] = multisampled(gpu, size);
        let single_depth = sampled(gpu, "depth", size, DEPTH_FORMAT, 1);
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST;
        let plain = wgpu::TextureFormat::Rgba8Unorm;
        let resolved = attachment(gpu, "viewport", size, COLOR_FORMAT, 1, usage, &[plain]);
        let encoded = resolved.create_view(&wgpu::TextureViewDescriptor { format: Some(plain), ..Default::default() });
        TextureTarget {
            size,
            color,
            depth,
            single_depth,
            resolved: resolved.create_view(&Default::default()),
            image: resolved,
            encoded,
        }
    }

    /// Width / height.
    pub fn aspect(&self) -> f32 {
        self.size.0 as f32 / self.size.1 as f32
    }

    /// Renders `view` with `renderer` into the texture (no read-back),
    /// anti-aliased ([`SAMPLE_COUNT`] samples per pixel) or at one sample.
    pub fn render(&self, gpu: &Gpu, renderer: &Renderer, view: &View, antialiased: bool) {
        let mut encoder =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("viewport") });
        if antialiased {
            renderer.encode(&mut encoder, view, &self.color, Some(&self.resolved), &self.depth);
        } else {
            renderer.encode(&mut encoder, view, &self.resolved, None, &self.single_depth);
        }
        gpu.queue.submit([encoder.finish()]);
    }

    /// Copies the last image into `into` with its left edge at column `x`
    /// (side-by-side views), clipped to `into`.
    pub fn copy_into(&self, gpu: &Gpu, into: &TextureTarget, x: u32) {
        let width = self.size.0.min(into.size.0.saturating_sub(x));
        let height = self.size.1.min(into.size.1);
        if width == 0 || height == 0 {
            return;
        }
        let mut encoder = gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("compose") });
        encoder.copy_texture_to_texture(
            self.image.as_image_copy(),
            wgpu::TexelCopyTextureInfo { origin: wgpu::Origin3d { x, y: 0, z: 0 }, ..into.image.as_image_copy() },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        gpu.queue.submit([encoder.finish()]);
    }

    /// Reads the last image back (sRGB-encoded RGBA), e.g. for tests.
    pub fn read(&self, gpu: &Gpu) -> Result<image::RgbaImage, RenderError> {
        read_texture(gpu, &self.image, self.size)
    }
}
