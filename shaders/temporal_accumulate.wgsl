// TemporalAccumulate (nodes/temporal_accumulate.rs): the mean of the current frame and earlier
// frames reprojected into it through the depth, with depth rejection. One pass per earlier
// frame adds its reprojected value and weight to running sums: `accumulate` (ping-pong textures)
// for all but the last, whose `resolve_*` pass divides.
#import lib/camera

struct Params {
    // World → clip of the earlier frame's camera.
    prev_view_proj: mat4x4<f32>,
    // Clip → world of the current camera.
    inv_view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    // Relative depth tolerance of the rejection.
    tolerance: f32,
    prev_eye: vec3<f32>,
    _pad0: u32,
    // Frames asked for (the resolve's `accepted` is the weight over this).
    frames: f32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
}

@group(0) @binding(0) var<uniform> P: Params;

// Pipeline constants, set per dispatch: the first pass (the sums start from the current frame),
// and the neighbourhood clamp. Constants rather than uniforms: lavapipe compiles a variant of a
// shader for the uniform values its branches read, at every dispatch whose values are new.
override FIRST: bool = true;
override CLAMP: bool = true;
@group(0) @binding(1) var sum_in: texture_2d<f32>;
@group(0) @binding(2) var weight_in: texture_2d<f32>;
@group(0) @binding(3) var prev: texture_2d<f32>;
@group(0) @binding(4) var prev_depth: texture_2d<f32>;
@group(0) @binding(5) var depth: texture_2d<f32>;
@group(0) @binding(6) var sum_out: texture_storage_2d<rgba32float, write>;
@group(0) @binding(7) var weight_out: texture_storage_2d<r32float, write>;
@group(0) @binding(8) var out_image: texture_storage_2d<rgba32float, write>;
@group(0) @binding(9) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(10) var out_accepted: texture_storage_2d<r32float, write>;
@group(0) @binding(11) var current: texture_2d<f32>;

// The range (per channel) of the current frame over the 3×3 pixels around p, clamped at the
// image's edges: what an earlier frame's value is clamped to (TAA's neighbourhood clamp — a
// value the current frame's neighbourhood does not span is a change the earlier frame lags).
fn neighbourhood(p: vec2<u32>) -> array<vec4<f32>, 2> {
    let size = vec2<i32>(textureDimensions(current));
    var lo = vec4<f32>(3.0e38);
    var hi = vec4<f32>(-3.0e38);
    for (var j = -1; j <= 1; j++) {
        for (var i = -1; i <= 1; i++) {
            let t = clamp(vec2<i32>(p) + vec2<i32>(i, j), vec2<i32>(0), size - 1);
            let v = textureLoad(current, t, 0);
            lo = min(lo, v);
            hi = max(hi, v);
        }
    }
    return array<vec4<f32>, 2>(lo, hi);
}

// A weighted sum of texels (every channel) and the sum of its weights.
struct Reprojected {
    sum: vec4<f32>,
    weight: f32,
}

// The current pixel's surface point seen from the earlier camera: the bilinear taps around its
// projection whose earlier depth agrees with the point's distance from the earlier eye (within
// `tolerance` of it), each with its bilinear weight; taps off the earlier image, or a point
// behind its camera, count nothing.
fn reproject(p: vec2<u32>) -> Reprojected {
    var r = Reprojected(vec4<f32>(0.0), 0.0);
    let size = textureDimensions(depth);
    let psize = vec2<i32>(textureDimensions(prev));
    let dir = pixel_ray(P.inv_view_proj, P.eye, p, size);
    let x = P.eye + dir * textureLoad(depth, p, 0).r;
    let c = P.prev_view_proj * vec4<f32>(x, 1.0);
    if !(c.w > 0.0) {
        return r;
    }
    let ndc = c.xy / c.w;
    let q = vec2<f32>((ndc.x + 1.0) * 0.5, (1.0 - ndc.y) * 0.5) * vec2<f32>(psize) - 0.5;
    let base = floor(q);
    let f = q - base;
    let dist = length(x - P.prev_eye);
    for (var k = 0; k < 4; k++) {
        let o = vec2<i32>(k & 1, k >> 1u);
        let t = vec2<i32>(base) + o;
        if any(t < vec2<i32>(0)) || any(t >= psize) {
            continue;
        }
        let wb = select(1.0 - f.x, f.x, o.x == 1) * select(1.0 - f.y, f.y, o.y == 1);
        let dq = textureLoad(prev_depth, t, 0).r;
        if abs(dq - dist) <= P.tolerance * dist && wb > 0.0 {
            r.sum += wb * textureLoad(prev, t, 0);
            r.weight += wb;
        }
    }
    return r;
}

// The running sums at p after this pass's earlier frame: the incoming sums (or the current
// frame with weight 1 on the first pass) plus the frame's reprojected value, clamped when asked.
fn accumulated(p: vec2<u32>) -> Reprojected {
    var acc = Reprojected(textureLoad(sum_in, p, 0), 1.0);
    if !FIRST {
        acc.weight = textureLoad(weight_in, p, 0).r;
    }
    let r = reproject(p);
    if CLAMP && r.weight > 0.0 {
        let range = neighbourhood(p);
        acc.sum += clamp(r.sum / r.weight, range[0], range[1]) * r.weight;
    } else {
        acc.sum += r.sum;
    }
    acc.weight += r.weight;
    return acc;
}

// Every earlier frame but the last: store the running sums.
@compute @workgroup_size(8, 8)
fn accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(sum_out);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let acc = accumulated(id.xy);
    textureStore(sum_out, vec2<i32>(id.xy), acc.sum);
    textureStore(weight_out, vec2<i32>(id.xy), vec4<f32>(acc.weight, 0.0, 0.0, 1.0));
}

// The last earlier frame: the mean, and the accepted share of the window.
fn resolved(p: vec2<u32>) -> vec4<f32> {
    let acc = accumulated(p);
    textureStore(out_accepted, vec2<i32>(p), vec4<f32>(acc.weight / P.frames, 0.0, 0.0, 1.0));
    return acc.sum / acc.weight;
}

@compute @workgroup_size(8, 8)
fn resolve_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_image, vec2<i32>(id.xy), resolved(id.xy));
}

@compute @workgroup_size(8, 8)
fn resolve_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_scalar, vec2<i32>(id.xy), vec4<f32>(resolved(id.xy).r, 0.0, 0.0, 1.0));
}
