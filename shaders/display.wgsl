// The editor's display pass: an evaluated picture as the viewer and the node thumbnails show it,
// drawn from the texture it was evaluated into (no read-back). Each output texel is the box
// average of `factor` × `factor` source texels (1: the picture itself; thumbnails shrink by an
// integer factor), then the chosen channel(s), `gain` = 2^stops of exposure, clamped to [0, 1]
// and sRGB-encoded into 8 bits (after a viewer transform, `colour_pass::view`, which applied
// the channel and exposure itself: quantized as they are); a non-finite value shows magenta. With `normalise`, one-channel
// values are divided by their largest finite box average when that is above 1 (depths in metres
// show their shape, not white): the `peak` entry finds it first.
// CPU reference: `src/editor/view.rs` (`to_srgb8`) and `src/editor/worker/evaluate.rs`
// (`shrink`, `thumbnail`).

struct DisplayParams {
    // Box filter side in source texels (≥ 1).
    factor: u32,
    // 1: a one-channel picture (shown grey from .r); 4: RGBA.
    channels: u32,
    // 0 RGB, 1 R, 2 G, 3 B, 4 A, 5 Rec. 709 luminance (`Channel` in view.rs).
    channel: u32,
    // 1: divide one-channel values by the peak above 1 (thumbnails).
    normalise: u32,
    // 2^stops.
    gain: f32,
    // Output size in texels.
    out_w: u32,
    out_h: u32,
    // 1: sRGB-encode; 0: display values already (a viewer transform ran first), quantized only.
    encode: u32,
}

@group(0) @binding(0) var<uniform> p: DisplayParams;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out: texture_storage_2d<rgba8unorm, write>;
// The largest finite one-channel box average (as f32 bits; non-negative floats order as their
// bits), starting at 0 like the CPU's fold.
@group(0) @binding(3) var<storage, read_write> peak: array<atomic<u32>, 1>;

fn finite(v: f32) -> bool {
    return (bitcast<u32>(v) & 0x7f800000u) != 0x7f800000u;
}

// The box average of output texel `o` (NaN stays NaN, as in the CPU's sum).
fn box_average(o: vec2<u32>) -> vec4<f32> {
    let size = textureDimensions(src);
    let start = o * p.factor;
    let end = min(start + vec2<u32>(p.factor), size);
    var acc = vec4<f32>(0.0);
    var n = 0.0;
    for (var y = start.y; y < end.y; y = y + 1u) {
        for (var x = start.x; x < end.x; x = x + 1u) {
            acc = acc + textureLoad(src, vec2<i32>(i32(x), i32(y)), 0);
            n = n + 1.0;
        }
    }
    return acc / max(n, 1.0);
}

@compute @workgroup_size(8, 8, 1)
fn find_peak(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.out_w || id.y >= p.out_h) {
        return;
    }
    let v = box_average(id.xy).x;
    if (finite(v) && v > 0.0) {
        atomicMax(&peak[0], bitcast<u32>(v));
    }
}

fn srgb8(x: f32) -> f32 {
    let v = clamp(x * p.gain, 0.0, 1.0);
    var e: f32;
    if (p.encode == 0u) {
        e = v;
    } else if (v <= 0.0031308) {
        e = v * 12.92;
    } else {
        e = 1.055 * pow(v, 1.0 / 2.4) - 0.055;
    }
    // Rounded to 8 bits here, as the CPU's `(… * 255).round()`; the store keeps it exactly.
    return round(e * 255.0) / 255.0;
}

@compute @workgroup_size(8, 8, 1)
fn show(@builtin(global_invocation_id) id: vec3<u32>) {
    if (id.x >= p.out_w || id.y >= p.out_h) {
        return;
    }
    var t = box_average(id.xy);
    var c: vec3<f32>;
    if (p.channels == 1u) {
        var v = t.x;
        if (p.normalise == 1u) {
            let top = bitcast<f32>(atomicLoad(&peak[0]));
            if (top > 1.0) {
                v = v / top;
            }
        }
        c = vec3<f32>(v);
    } else {
        switch p.channel {
            case 1u: { c = vec3<f32>(t.x); }
            case 2u: { c = vec3<f32>(t.y); }
            case 3u: { c = vec3<f32>(t.z); }
            case 4u: { c = vec3<f32>(t.w); }
            case 5u: { c = vec3<f32>(0.2126 * t.x + 0.7152 * t.y + 0.0722 * t.z); }
            default: { c = t.xyz; }
        }
    }
    var o = vec4<f32>(1.0, 0.0, 1.0, 1.0);
    if (finite(c.x) && finite(c.y) && finite(c.z)) {
        o = vec4<f32>(srgb8(c.x), srgb8(c.y), srgb8(c.z), 1.0);
    }
    textureStore(out, vec2<i32>(id.xy), o);
}
