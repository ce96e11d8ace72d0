// Plate mode: PlateDepth bounds the view rays by a plate's depth; PlateOver puts the shafts
// over the plate (nodes/plate.rs).
#import lib/camera
#import lib/sampling

struct DepthParams {
    inv_view_proj: mat4x4<f32>,
    view: mat4x4<f32>,
    eye: vec3<f32>,
    planar: u32,
    scale: f32,
    tolerance: f32,
    _pad1: u32,
    _pad2: u32,
}

struct OverParams {
    has_inscatter: u32,
    has_transmittance: u32,
    _pad0: u32,
    _pad1: u32,
}

// Plate depth values at or beyond this bound nothing (Blender's background Z is 1e10).
const NO_DEPTH: f32 = 1e9;

@group(0) @binding(0) var<uniform> D: DepthParams;
@group(0) @binding(1) var scene_depth: texture_2d<f32>;
@group(0) @binding(2) var plate_depth_in: texture_2d<f32>;
@group(0) @binding(3) var out_depth: texture_storage_2d<r32float, write>;
@group(0) @binding(4) var out_mask: texture_storage_2d<r32float, write>;

@group(0) @binding(5) var<uniform> O: OverParams;
@group(0) @binding(6) var plate: texture_2d<f32>;
@group(0) @binding(7) var inscatter: texture_2d<f32>;
@group(0) @binding(8) var transmittance: texture_2d<f32>;
@group(0) @binding(9) var out_image: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(8, 8)
fn plate_depth(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let s = textureLoad(scene_depth, vec2<i32>(id.xy), 0).r;
    // The plate's texel nearest to this pixel's centre.
    let psize = textureDimensions(plate_depth_in);
    let pc = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(size) * vec2<f32>(psize);
    let pt = min(vec2<u32>(pc), psize - 1u);
    let value = textureLoad(plate_depth_in, vec2<i32>(pt), 0).r;
    var d = s;
    var m = 0.0;
    // value == value is false for NaN; > 0 and < NO_DEPTH leave out Inf and the background.
    if value == value && value > 0.0 && value < NO_DEPTH {
        var dist = value * D.scale;
        var ok = true;
        if D.planar == 1u {
            let ray = pixel_ray(D.inv_view_proj, D.eye, id.xy, size);
            let cv = normalize((D.view * vec4<f32>(ray, 0.0)).xyz);
            let cos_axis = -cv.z;
            ok = cos_axis > 1e-6;
            dist = dist / max(cos_axis, 1e-6);
        }
        if ok && dist < s * (1.0 - D.tolerance) {
            d = dist;
            m = 1.0;
        }
    }
    textureStore(out_depth, vec2<i32>(id.xy), vec4<f32>(d, 0.0, 0.0, 0.0));
    textureStore(out_mask, vec2<i32>(id.xy), vec4<f32>(m, 0.0, 0.0, 0.0));
}

// `t` at the position of pixel `id` of a `size` image: its own texel when the sizes agree (so
// T = 1 and L = 0 give the plate exactly), else bilinear.
fn at_pixel(t: texture_2d<f32>, id: vec2<u32>, size: vec2<u32>) -> vec4<f32> {
    let tsize = textureDimensions(t);
    if all(tsize == size) {
        return textureLoad(t, vec2<i32>(id), 0);
    }
    let uv = (vec2<f32>(id) + 0.5) / vec2<f32>(size);
    return bilinear_texels(t, uv * vec2<f32>(tsize));
}

@compute @workgroup_size(8, 8)
fn plate_over(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let c = textureLoad(plate, vec2<i32>(id.xy), 0);
    var t = 1.0;
    if O.has_transmittance == 1u {
        t = at_pixel(transmittance, id.xy, size).r;
    }
    var l = vec3<f32>(0.0);
    if O.has_inscatter == 1u {
        l = at_pixel(inscatter, id.xy, size).rgb;
    }
    textureStore(out_image, vec2<i32>(id.xy), vec4<f32>(c.rgb * t + l, c.a));
}
