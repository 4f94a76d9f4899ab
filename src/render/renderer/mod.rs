//! The wgpu renderer: a shadow pass for the key light, then one PBR pass
//! (4× MSAA) that exposes and tone-maps into an sRGB target.

mod pipelines;
mod uniforms;

use glam::camera::rh::{proj::directx, view::look_at_mat4};
use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use self::pipelines::{sampler_entry, texture_entry, texture_with_data, uniform_entry};
use self::uniforms::{FrameUniforms, ObjectUniforms, ShadowProjection, frame_uniforms};
use super::camera::{Bounds, OrbitCamera};
use super::draw::{DrawMesh, Material, Vertex};
use super::gpu::{Gpu, RenderError};
use super::lights::{LightRig, MAX_LIGHTS, PlacedLight};
use super::sheen::{MIN_SHEEN_ROUGHNESS, SHEEN_TABLE_SIZE, sheen_albedo_table};

/// Colour format of the render target (the hardware does the sRGB encoding).
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// Depth format of the main pass and the shadow map.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Samples per pixel (MSAA) of every image drape writes, and of the editor's
/// viewport once it is still.
pub const SAMPLE_COUNT: u32 = 4;
/// Side of the square shadow map, texels.
const SHADOW_MAP_SIZE: u32 = 2048;
/// Widest shadow filter (penumbra radius), texels.
const MAX_PCF_RADIUS_TEXELS: f32 = 24.0;

/// Everything about one image except the meshes: camera, lights, exposure.
#[derive(Clone, Debug)]
pub struct View {
    /// The camera.
    pub camera: OrbitCamera,
    /// Image width / height.
    pub aspect: f32,
    /// The lights, placed in the world.
    pub lights: Vec<PlacedLight>,
    /// Sky irradiance (colour × lux) on an upward-facing surface.
    pub sky_irradiance: Vec3,
    /// Ground-bounce irradiance (colour × lux) on a downward-facing surface.
    pub ground_irradiance: Vec3,
    /// Scene luminance to tone-mapper input, 1/(cd/m²).
    pub exposure: f32,
    /// Clear colour, display-linear RGB.
    pub background: [f32; 3],
    /// What the shadow map must cover (the objects that cast and catch shadows).
    pub shadow_bounds: Bounds,
    /// Half size of the ground, m (sets the far plane).
    pub ground_extent_m: f32,
}

impl View {
    /// The view of `rig` at time `t_s` through `camera`.
    pub fn new(camera: OrbitCamera, aspect: f32, rig: &LightRig, t_s: f32, shadow_bounds: Bounds) -> View {
        let a = &rig.ambient;
        View {
            camera,
            aspect,
            lights: rig.placed(camera.yaw_deg, t_s),
            sky_irradiance: Vec3::from(a.sky_color) * a.sky_illuminance_lux,
            ground_irradiance: Vec3::from(a.ground_color) * a.ground_illuminance_lux,
            exposure: rig.exposure(),
            background: rig.background,
            shadow_bounds,
            ground_extent_m: 20.0,
        }
    }
}

/// A mesh on the GPU.
struct GpuMesh {
    vertices: wgpu::Buffer,
    vertex_count: usize,
    indices: wgpu::Buffer,
    index_count: u32,
    uniforms: wgpu::Buffer,
    material: Material,
    bind_group: wgpu::BindGroup,
    casts_shadow: bool,
    visible: bool,
}

/// Which PBR pipeline: the full one, or the quick one of a moving view on a
/// software rasteriser.
#[derive(Clone, Copy)]
enum PbrPass {
    /// [`SAMPLE_COUNT`] samples per pixel, soft (PCSS) shadows.
    Full,
    /// One sample, hard-edged shadows (one bilinear comparison tap).
    Quick,
}

/// Pipelines, the shadow map and the uploaded meshes.
pub struct Renderer {
    gpu: Gpu,
    /// The PBR pass into [`SAMPLE_COUNT`]-sample targets.
    pbr: wgpu::RenderPipeline,
    /// The quick PBR pass into one-sample targets, with hard-edged shadows
    /// (a software rasteriser's viewport while it moves).
    pbr_quick: wgpu::RenderPipeline,
    shadow: wgpu::RenderPipeline,
    object_layout: wgpu::BindGroupLayout,
    frame_uniforms: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    shadow_uniforms: wgpu::Buffer,
    shadow_bind_group: wgpu::BindGroup,
    shadow_map: wgpu::TextureView,
    base_sampler: wgpu::Sampler,
    white: wgpu::TextureView,
    meshes: Vec<GpuMesh>,
}

impl Renderer {
    /// Builds the pipelines and the shadow map on `gpu`, or says why its
    /// adapter cannot ([`RenderError::Unsupported`]).
    pub fn new(gpu: &Gpu) -> Result<Renderer, RenderError> {
        let device = &gpu.device;
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
                texture_entry(1, wgpu::TextureSampleType::Depth),
                sampler_entry(2, wgpu::SamplerBindingType::Comparison),
                texture_entry(3, wgpu::TextureSampleType::Float { filterable: true }),
                sampler_entry(4, wgpu::SamplerBindingType::Filtering),
            ],
        });
        let object_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("object"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
                texture_entry(1, wgpu::TextureSampleType::Float { filterable: true }),
                sampler_entry(2, wgpu::SamplerBindingType::Filtering),
            ],
        });
        let shadow_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow frame"),
            entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX)],
        });

        let (pbr, pbr_quick, shadow) = gpu.validated(|device| {
            let pbr = Self::pbr_pipeline(device, &frame_layout, &object_layout, PbrPass::Full);
            let pbr_quick = Self::pbr_pipeline(device, &frame_layout, &object_layout, PbrPass::Quick);
            (pbr, pbr_quick, Self::shadow_pipeline(device, &shadow_layout, &object_layout))
        })?;

        let shadow_map = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("shadow map"),
                size: wgpu::Extent3d { width: SHADOW_MAP_SIZE, height: SHADOW_MAP_SIZE, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            })
            .create_view(&wgpu::TextureViewDescriptor::default());
        let compare_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow compare"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let linear_clamp = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("linear clamp"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let base_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("base colour"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::Repeat,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let n = SHEEN_TABLE_SIZE as u32;
        let sheen_table =
            texture_with_data(gpu, "sheen albedo", (n, n), wgpu::TextureFormat::R8Unorm, &sheen_albedo_table());
        let white = texture_with_data(gpu, "white", (1, 1), wgpu::TextureFormat::Rgba8UnormSrgb, &[255; 4]);

        let frame_uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let frame_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &frame_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: frame_uniforms.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&shadow_map) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&compare_sampler) },
                wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::TextureView(&sheen_table) },
                wgpu::BindGroupEntry { binding: 4, resource: wgpu::BindingResource::Sampler(&linear_clamp) },
            ],
        });
        let shadow_uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("shadow frame"),
            size: std::mem::size_of::<[[f32; 4]; 4]>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shadow_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow frame"),
            layout: &shadow_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: shadow_uniforms.as_entire_binding() }],
        });
        Ok(Renderer {
            gpu: gpu.clone(),
            pbr,
            pbr_quick,
            shadow,
            object_layout,
            frame_uniforms,
            frame_bind_group,
            shadow_uniforms,
            shadow_bind_group,
            shadow_map,
            base_sampler,
            white,
            meshes: Vec::new(),
        })
    }

    /// Replaces the meshes to draw (uploads geometry, materials and textures).
    pub fn set_meshes(&mut self, meshes: &[DrawMesh]) {
        self.meshes = meshes.iter().map(|m| self.upload(m)).collect();
    }

    fn upload(&self, mesh: &DrawMesh) -> GpuMesh {
        let device = &self.gpu.device;
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(&mesh.name),
            contents: bytemuck::cast_slice(&mesh.vertices),
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
        });
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(&mesh.name),
            contents: bytemuck::cast_slice(&mesh.indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        let uniforms = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(&mesh.name),
            contents: bytemuck::bytes_of(&ObjectUniforms::new(mesh.world_from_model, &mesh.material)),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let texture = mesh.material.texture.as_ref().map(|image| {
            texture_with_data(
                &self.gpu,
                &mesh.name,
                image.dimensions(),
                wgpu::TextureFormat::Rgba8UnormSrgb,
                image.as_raw(),
            )
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&mesh.name),
            layout: &self.object_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(texture.as_ref().unwrap_or(&self.white)),
                },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&self.base_sampler) },
            ],
        });
        GpuMesh {
            vertices,
            vertex_count: mesh.vertices.len(),
            indices,
            index_count: mesh.indices.len() as u32,
            uniforms,
            material: mesh.material.clone(),
            bind_group,
            casts_shadow: mesh.casts_shadow,
            visible: true,
        }
    }

    /// Shows or hides mesh `index` (hidden meshes cast no shadow either).
    pub fn set_visible(&mut self, index: usize, visible: bool) {
        if let Some(mesh) = self.meshes.get_mut(index) {
            mesh.visible = visible;
        }
    }

    /// New vertex positions and normals for mesh `index` (same count as uploaded).
    pub fn update_vertices(&mut self, index: usize, vertices: &[Vertex]) {
        if let Some(mesh) = self.meshes.get(index) {
            debug_assert_eq!(mesh.vertex_count, vertices.len());
            let n = mesh.vertex_count.min(vertices.len());
            self.gpu.queue.write_buffer(&mesh.vertices, 0, bytemuck::cast_slice(&vertices[..n]));
        }
    }

    /// New placement and material of mesh `index` (the texture stays).
    pub fn update_placement(&mut self, index: usize, world_from_model: Mat4, material: Option<&Material>) {
        if let Some(mesh) = self.meshes.get_mut(index) {
            if let Some(m) = material {
                mesh.material = Material { texture: mesh.material.texture.clone(), ..m.clone() };
            }
            let uniforms = ObjectUniforms::new(world_from_model, &mesh.material);
            self.gpu.queue.write_buffer(&mesh.uniforms, 0, bytemuck::bytes_of(&uniforms));
        }
    }

    /// Records the shadow pass and the main pass of `view` into `encoder`:
    /// colour into `color` and depth into `depth`, both of [`SAMPLE_COUNT`]
    /// samples resolved into `resolve`, or of one sample without it.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &View,
        color: &wgpu::TextureView,
        resolve: Option<&wgpu::TextureView>,
        depth: &wgpu::TextureView,
    ) {
        let key = view.lights.iter().find(|l| l.shadow);
        let shadow = match key {
            Some(l) => ShadowProjection::around(l.towards_light, &view.shadow_bounds),
            None => ShadowProjection::none(),
        };
        let light_clip_from_world = shadow.clip_from_world.to_cols_array_2d();
        self.gpu.queue.write_buffer(&self.shadow_uniforms, 0, bytemuck::bytes_of(&light_clip_from_world));
        self.gpu.queue.write_buffer(&self.frame_uniforms, 0, bytemuck::bytes_of(&frame_uniforms(view, &shadow)));
        self.shadow_pass(encoder);
        let clear = view.background.map(f64::from);
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("pbr"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color,
                depth_slice: None,
                resolve_target: resolve,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r: clear[0], g: clear[1], b: clear[2], a: 1.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(if resolve.is_some() { &self.pbr } else { &self.pbr_quick });
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        for mesh in self.meshes.iter().filter(|m| m.visible) {
            draw(&mut pass, mesh);
        }
    }

    fn shadow_pass(&self, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("shadow"),
            color_attachments: &[],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.shadow_map,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.shadow);
        pass.set_bind_group(0, &self.shadow_bind_group, &[]);
        for mesh in self.meshes.iter().filter(|m| m.casts_shadow && m.visible) {
            draw(&mut pass, mesh);
        }
    }
}

fn draw(pass: &mut wgpu::RenderPass<'_>, mesh: &GpuMesh) {
    pass.set_bind_group(1, &mesh.bind_group, &[]);
    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
    pass.draw_indexed(0..mesh.index_count, 0, 0..1);
}
