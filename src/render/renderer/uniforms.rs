//! What the shaders read per frame and per object, and the key light's
//! shadow projection around the scene.

use super::*;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct LightUniform {
    towards_light: [f32; 4],
    illuminance: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct FrameUniforms {
    clip_from_world: [[f32; 4]; 4],
    light_clip_from_world: [[f32; 4]; 4],
    camera_position: [f32; 4],
    sky_irradiance: [f32; 4],
    ground_irradiance: [f32; 4],
    params: [f32; 4],
    shadow: [f32; 4],
    lights: [LightUniform; MAX_LIGHTS],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct ObjectUniforms {
    world_from_model: [[f32; 4]; 4],
    base: [f32; 4],
    back: [f32; 4],
    sheen: [f32; 4],
    params: [f32; 4],
}

impl ObjectUniforms {
    pub(super) fn new(world_from_model: Mat4, m: &Material) -> Self {
        let [r, g, b] = m.base_color;
        let [br, bg, bb] = m.back_color;
        let [sr, sg, sb] = m.sheen_color;
        ObjectUniforms {
            world_from_model: world_from_model.to_cols_array_2d(),
            base: [r, g, b, m.metallic],
            back: [br, bg, bb, m.roughness],
            sheen: [sr, sg, sb, m.sheen_roughness.max(MIN_SHEEN_ROUGHNESS as f32)],
            params: [m.grid_spacing_m, m.unlit.clamp(0.0, 1.0), 0.0, 0.0],
        }
    }
}

/// The key light's orthographic projection.
pub(super) struct ShadowProjection {
    /// Shadow-map clip space from world space.
    pub(super) clip_from_world: Mat4,
    /// World size of one shadow texel, m.
    texel_m: f32,
    /// Depth covered by the projection (NDC depth 0..1), m.
    depth_range_m: f32,
}

impl ShadowProjection {
    /// The projection of a light towards `towards_light` around `bounds`.
    pub(super) fn around(towards_light: Vec3, bounds: &Bounds) -> ShadowProjection {
        let centre = bounds.centre();
        let radius = bounds.radius().max(1e-3);
        // A low light throws long shadows: widen the map as the light sinks.
        let half = (radius / towards_light.y.abs().max(0.35)).min(3.0 * radius);
        let up = if towards_light.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y };
        let view = look_at_mat4(centre + towards_light * 4.0 * half, centre, up);
        let depth_range_m = 8.0 * half;
        let projection = directx::orthographic(-half, half, -half, half, 0.0, depth_range_m);
        ShadowProjection {
            clip_from_world: projection * view,
            texel_m: 2.0 * half / SHADOW_MAP_SIZE as f32,
            depth_range_m,
        }
    }

    /// No shadow-casting light.
    pub(super) fn none() -> ShadowProjection {
        ShadowProjection { clip_from_world: Mat4::IDENTITY, texel_m: 0.0, depth_range_m: 0.0 }
    }
}

pub(super) fn frame_uniforms(view: &View, shadow: &ShadowProjection) -> FrameUniforms {
    let (light_clip_from_world, texel_m, depth_range_m) =
        (shadow.clip_from_world, shadow.texel_m, shadow.depth_range_m);
    let camera = &view.camera;
    let clip_from_world = camera.projection(view.aspect, view.ground_extent_m) * camera.view();
    let mut lights = [LightUniform { towards_light: [0.0; 4], illuminance: [0.0; 4] }; MAX_LIGHTS];
    for (slot, l) in lights.iter_mut().zip(&view.lights) {
        slot.towards_light = l.towards_light.extend(if l.shadow { 1.0 } else { 0.0 }).to_array();
        slot.illuminance = l.illuminance.extend(0.0).to_array();
    }
    // The shader sizes each penumbra from the occluder gap (PCSS): a gap of
    // `d` m behind an occluder lit by a source of angular radius θ blurs
    // `d tan θ` m. The depth range of the light's projection converts depth
    // differences to metres; the search covers the gap across the scene.
    let softness = view.lights.iter().find(|l| l.shadow).map_or(0.0, |l| l.softness_rad);
    let (texels_per_depth, widest_texels) = match texel_m > 0.0 {
        true => {
            let texels_per_m = softness.tan() / texel_m;
            (
                depth_range_m * texels_per_m,
                (view.shadow_bounds.radius() * texels_per_m).clamp(1.0, MAX_PCF_RADIUS_TEXELS),
            )
        }
        false => (0.0, 1.0),
    };
    FrameUniforms {
        clip_from_world: clip_from_world.to_cols_array_2d(),
        light_clip_from_world: light_clip_from_world.to_cols_array_2d(),
        camera_position: camera.eye().extend(1.0).to_array(),
        sky_irradiance: view.sky_irradiance.extend(0.0).to_array(),
        ground_irradiance: view.ground_irradiance.extend(0.0).to_array(),
        params: [view.exposure, 1.0 / SHADOW_MAP_SIZE as f32, widest_texels, view.lights.len().min(MAX_LIGHTS) as f32],
        shadow: [1.5 * texel_m, 1e-4, texels_per_depth, 0.0],
        lights,
    }
}
