// drape's surface shader: metallic-roughness Cook-Torrance (GGX distribution,
// height-correlated Smith visibility, Schlick Fresnel) plus the fabric sheen lobe
// of KHR_materials_sheen (Charlie distribution, Neubelt visibility, base layer
// scaled by the sheen's directional albedo so the sum conserves energy).
// Double-sided: back faces use the flipped normal and the back colour.
// Lights: up to four directional lights (illuminance in lux), one with a soft
// (PCSS) shadow map, and a sky/ground hemisphere. Output: exposed (EV100), ACES
// filmic tone map, written to an sRGB target (the hardware encodes).

const PI: f32 = 3.14159265359;
const MAX_LIGHTS: u32 = 4u;
// Radiance of an unlit surface's base colour before exposure: ACES maps it
// back to about the colour itself.
const UNLIT_RADIANCE: f32 = 1.0;
const SHADOW_TAPS: i32 = 32;
// False in the quick pipeline (a moving view on a software rasteriser): one
// bilinear comparison tap, hard-edged shadows at a tenth of the cost.
override SOFT_SHADOWS: bool = true;
const BLOCKER_TAPS: i32 = 8;

struct Light {
    towards_light: vec4<f32>, // xyz unit vector, w = 1 when it uses the shadow map
    illuminance: vec4<f32>,   // rgb, lux
}

struct Frame {
    clip_from_world: mat4x4<f32>,
    light_clip_from_world: mat4x4<f32>,
    camera_position: vec4<f32>,
    sky_irradiance: vec4<f32>,    // rgb lux on an upward-facing surface
    ground_irradiance: vec4<f32>, // rgb lux on a downward-facing surface
    params: vec4<f32>,            // exposure, shadow texel (uv), widest penumbra (texels), light count
    shadow: vec4<f32>,            // normal offset (m), depth bias (NDC), penumbra texels per unit of depth gap, unused
    lights: array<Light, 4>,
}

struct Object {
    world_from_model: mat4x4<f32>,
    base: vec4<f32>,   // rgb base colour (linear), a metallic
    back: vec4<f32>,   // rgb back-face colour, a roughness
    sheen: vec4<f32>,  // rgb sheen colour, a sheen roughness
    params: vec4<f32>, // grid spacing (m, 0 none), unlit share (0..1), unused x2
}

@group(0) @binding(0) var<uniform> frame: Frame;
@group(0) @binding(1) var shadow_map: texture_depth_2d;
@group(0) @binding(2) var shadow_sampler: sampler_comparison;
@group(0) @binding(3) var sheen_albedo_table: texture_2d<f32>;
@group(0) @binding(4) var table_sampler: sampler;
@group(1) @binding(0) var<uniform> object: Object;
@group(1) @binding(1) var base_texture: texture_2d<f32>;
@group(1) @binding(2) var base_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
}

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
}

@vertex
fn vs_main(v: VertexIn) -> VertexOut {
    let world = object.world_from_model * vec4<f32>(v.position, 1.0);
    var out: VertexOut;
    out.clip = frame.clip_from_world * world;
    out.world = world.xyz;
    out.normal = (object.world_from_model * vec4<f32>(v.normal, 0.0)).xyz;
    out.uv = v.uv;
    return out;
}

fn ggx_distribution(n_h: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let d = n_h * n_h * (a2 - 1.0) + 1.0;
    return a2 / (PI * d * d);
}

fn smith_visibility(n_v: f32, n_l: f32, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let g_v = n_l * sqrt(n_v * n_v * (1.0 - a2) + a2);
    let g_l = n_v * sqrt(n_l * n_l * (1.0 - a2) + a2);
    return 0.5 / max(g_v + g_l, 1e-6);
}

fn schlick_fresnel(f0: vec3<f32>, v_h: f32) -> vec3<f32> {
    return f0 + (vec3<f32>(1.0) - f0) * pow(1.0 - v_h, 5.0);
}

// Same formulas as src/render/sheen.rs.
fn charlie_distribution(n_h: f32, roughness: f32) -> f32 {
    let alpha = roughness * roughness;
    let inv_alpha = 1.0 / alpha;
    let sin2 = max(1.0 - n_h * n_h, 0.0);
    return (2.0 + inv_alpha) * pow(sin2, 0.5 * inv_alpha) / (2.0 * PI);
}

fn sheen_visibility(n_v: f32, n_l: f32) -> f32 {
    return clamp(1.0 / (4.0 * (n_l + n_v - n_l * n_v)), 0.0, 1.0);
}

fn sheen_albedo(cos_theta: f32, roughness: f32) -> f32 {
    return textureSampleLevel(sheen_albedo_table, table_sampler, vec2<f32>(cos_theta, roughness), 0.0).r;
}

// Karis' analytic fit of the split-sum environment BRDF.
fn environment_brdf(f0: vec3<f32>, roughness: f32, n_v: f32) -> vec3<f32> {
    let c0 = vec4<f32>(-1.0, -0.0275, -0.572, 0.022);
    let c1 = vec4<f32>(1.0, 0.0425, 1.04, -0.04);
    let r = roughness * c0 + c1;
    let a004 = min(r.x * r.x, exp2(-9.28 * n_v)) * r.x + r.y;
    let ab = vec2<f32>(-1.04, 1.04) * a004 + r.zw;
    return f0 * ab.x + ab.y;
}

// Where a world point falls in the shadow map: (u, v, depth).
fn shadow_coordinates(world: vec3<f32>, normal: vec3<f32>) -> vec3<f32> {
    let shifted = world + normal * frame.shadow.x;
    let clip = frame.light_clip_from_world * vec4<f32>(shifted, 1.0);
    let ndc = clip.xyz / clip.w;
    return vec3<f32>(0.5 + 0.5 * ndc.x, 0.5 - 0.5 * ndc.y, ndc.z);
}

// How the receiver's depth changes across the shadow map (receiver-plane depth
// bias, Isidoro 2006), from the screen-space derivatives of its coordinates, so
// that wide filters do not shadow a curved surface with itself.
fn receiver_depth_slope(coordinates: vec3<f32>) -> vec2<f32> {
    let dx = dpdx(coordinates);
    let dy = dpdy(coordinates);
    let det = dx.x * dy.y - dx.y * dy.x;
    let slope = vec2<f32>(dy.y * dx.z - dx.y * dy.z, dx.x * dy.z - dy.x * dx.z) / select(det, 1.0, abs(det) < 1e-12);
    let limit = 50.0 * frame.shadow.y / max(frame.params.y, 1e-6);
    return select(clamp(slope, vec2<f32>(-limit), vec2<f32>(limit)), vec2<f32>(0.0), abs(det) < 1e-12);
}

// Mean depth of the occluders between the light and a receiver, searched over
// the widest penumbra; -1 when nothing occludes (percentage-closer soft
// shadows, Fernando 2005: penumbrae widen with the distance to the occluder,
// so contact shadows stay sharp).
fn mean_occluder_depth(uv: vec2<f32>, depth: f32, slope: vec2<f32>) -> f32 {
    let radius = frame.params.z * frame.params.y;
    let size = 1.0 / frame.params.y;
    var sum = 0.0;
    var count = 0.0;
    // The centre first (an occluder right above is never missed), then a spiral.
    for (var i = -1; i < BLOCKER_TAPS; i++) {
        let r = select(sqrt((f32(i) + 0.5) / f32(BLOCKER_TAPS)), 0.0, i < 0);
        let angle = f32(i) * 2.39996323;
        let offset = radius * r * vec2<f32>(cos(angle), sin(angle));
        let texel = clamp(vec2<i32>((uv + offset) * size), vec2<i32>(0), vec2<i32>(i32(size) - 1));
        let occluder = textureLoad(shadow_map, texel, 0);
        if occluder < depth + dot(slope, offset) {
            sum += occluder;
            count += 1.0;
        }
    }
    return select(-1.0, sum / max(count, 1.0), count > 0.0);
}

// Fraction of the key light reaching a point at `coordinates` of the shadow map:
// percentage-closer filtering over a disc as wide as the penumbra there
// (comparison taps on a Vogel spiral), each compared at the receiver plane's depth.
fn shadow_visibility(coordinates: vec3<f32>, slope: vec2<f32>) -> f32 {
    let uv = coordinates.xy;
    if any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0)) || coordinates.z > 1.0 {
        return 1.0;
    }
    let depth = coordinates.z - frame.shadow.y;
    if !SOFT_SHADOWS {
        return textureSampleCompareLevel(shadow_map, shadow_sampler, uv, depth);
    }
    let occluder = mean_occluder_depth(uv, depth, slope);
    if occluder < 0.0 {
        return 1.0;
    }
    let penumbra_texels = clamp((depth - occluder) * frame.shadow.z, 1.0, frame.params.z);
    let radius = penumbra_texels * frame.params.y;
    // Eight taps on the rim first: umbrae stop here; only penumbrae pay for the disc.
    var rim = 0.0;
    for (var i = 0; i < 8; i++) {
        let angle = f32(i) * 0.78539816;
        let offset = radius * vec2<f32>(cos(angle), sin(angle));
        rim += textureSampleCompareLevel(shadow_map, shadow_sampler, uv + offset, depth + dot(slope, offset));
    }
    if rim == 0.0 || rim == 8.0 {
        return rim / 8.0;
    }
    var lit = rim;
    for (var i = 0; i < SHADOW_TAPS; i++) {
        let r = sqrt((f32(i) + 0.5) / f32(SHADOW_TAPS));
        let angle = f32(i) * 2.39996323;
        let offset = radius * r * vec2<f32>(cos(angle), sin(angle));
        lit += textureSampleCompareLevel(shadow_map, shadow_sampler, uv + offset, depth + dot(slope, offset));
    }
    return lit / f32(SHADOW_TAPS + 8);
}

// Stephen Hill's fit of the ACES reference rendering and output transforms.
fn aces_filmic(color: vec3<f32>) -> vec3<f32> {
    let input = mat3x3<f32>(
        vec3<f32>(0.59719, 0.07600, 0.02840),
        vec3<f32>(0.35458, 0.90834, 0.13383),
        vec3<f32>(0.04823, 0.01566, 0.83777),
    );
    let output = mat3x3<f32>(
        vec3<f32>(1.60475, -0.10208, -0.00327),
        vec3<f32>(-0.53108, 1.10813, -0.07276),
        vec3<f32>(-0.07367, -0.00605, 1.07602),
    );
    let v = input * color;
    let a = v * (v + 0.0245786) - 0.000090537;
    let b = v * (0.983729 * v + 0.4329510) + 0.238081;
    return clamp(output * (a / b), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn max3(v: vec3<f32>) -> f32 {
    return max(v.x, max(v.y, v.z));
}

// Ground grid lines (0..1), antialiased by the screen-space derivative and
// faded out where the cells become smaller than a few pixels.
fn grid_line(world: vec3<f32>, spacing: f32) -> f32 {
    let cell = world.xz / max(spacing, 1e-3);
    let width = fwidth(cell);
    let distance = abs(fract(cell - 0.5) - 0.5) / max(width, vec2<f32>(1e-4));
    let line = 1.0 - min(min(distance.x, distance.y), 1.0);
    let fade = 1.0 - smoothstep(0.05, 0.25, max(width.x, width.y));
    return select(0.0, line * fade, spacing > 0.0);
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    // Everything that needs derivatives first, in uniform control flow.
    let texel = textureSample(base_texture, base_sampler, in.uv).rgb;
    let line = grid_line(in.world, object.params.x);
    let geometric = normalize(in.normal);
    let shadow_at = shadow_coordinates(in.world, select(-geometric, geometric, front));
    let shadow_slope = receiver_depth_slope(shadow_at);
    var n = geometric;
    var base = object.base.rgb;
    if !front {
        n = -n;
        base = object.back.rgb;
    }
    base = base * texel * (1.0 - 0.2 * line);
    let v = normalize(frame.camera_position.xyz - in.world);
    let n_v = clamp(dot(n, v), 1e-4, 1.0);
    let metallic = object.base.a;
    let roughness = clamp(object.back.a, 0.045, 1.0);
    let alpha = roughness * roughness;
    let f0 = mix(vec3<f32>(0.04), base, metallic);
    let diffuse_color = base * (1.0 - metallic);
    let sheen_color = object.sheen.rgb;
    let sheen_roughness = clamp(object.sheen.a, 0.07, 1.0);
    let sheen_strength = max3(sheen_color);
    let base_scale_v = 1.0 - sheen_strength * sheen_albedo(n_v, sheen_roughness);

    var color = vec3<f32>(0.0);
    let count = min(u32(frame.params.w), MAX_LIGHTS);
    for (var i = 0u; i < count; i++) {
        let light = frame.lights[i];
        let l = light.towards_light.xyz;
        let n_l = dot(n, l);
        if n_l <= 0.0 {
            continue;
        }
        let h = normalize(l + v);
        let n_h = clamp(dot(n, h), 0.0, 1.0);
        let v_h = clamp(dot(v, h), 0.0, 1.0);
        let fresnel = schlick_fresnel(f0, v_h);
        let specular = fresnel * ggx_distribution(n_h, alpha) * smith_visibility(n_v, n_l, alpha);
        let diffuse = (vec3<f32>(1.0) - fresnel) * diffuse_color / PI;
        let sheen = sheen_color * charlie_distribution(n_h, sheen_roughness) * sheen_visibility(n_v, n_l);
        let base_scale = min(base_scale_v, 1.0 - sheen_strength * sheen_albedo(n_l, sheen_roughness));
        var visible = 1.0;
        if light.towards_light.w > 0.5 {
            visible = shadow_visibility(shadow_at, shadow_slope);
        }
        color += (sheen + base_scale * (diffuse + specular)) * light.illuminance.rgb * n_l * visible;
    }

    let irradiance = mix(frame.ground_irradiance.rgb, frame.sky_irradiance.rgb, 0.5 + 0.5 * n.y);
    let r = reflect(-v, n);
    let reflected = mix(frame.ground_irradiance.rgb, frame.sky_irradiance.rgb, 0.5 + 0.5 * r.y) / PI;
    let ambient_base = diffuse_color * irradiance / PI + reflected * environment_brdf(f0, roughness, n_v);
    let ambient_sheen = sheen_color * sheen_albedo(n_v, sheen_roughness) * irradiance / PI;
    color += base_scale_v * ambient_base + ambient_sheen;
    // The unlit share shows the base colour as a surface lit to mid-grey
    // would, whatever the lights.
    let unlit = object.params.y;
    color = mix(color, base * UNLIT_RADIANCE / frame.params.x, unlit);

    return vec4<f32>(aces_filmic(color * frame.params.x), 1.0);
}
