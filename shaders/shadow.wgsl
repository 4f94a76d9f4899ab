// Depth-only pass of the key light's shadow map.

struct ShadowFrame {
    light_clip_from_world: mat4x4<f32>,
}

struct Object {
    world_from_model: mat4x4<f32>,
    base: vec4<f32>,
    back: vec4<f32>,
    sheen: vec4<f32>,
    params: vec4<f32>,
}

@group(0) @binding(0) var<uniform> shadow_frame: ShadowFrame;
@group(1) @binding(0) var<uniform> object: Object;

@vertex
fn vs_shadow(@location(0) position: vec3<f32>) -> @builtin(position) vec4<f32> {
    return shadow_frame.light_clip_from_world * object.world_from_model * vec4<f32>(position, 1.0);
}
