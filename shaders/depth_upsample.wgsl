// DepthUpsample (nodes/depth_upsample.rs): joint bilateral upsampling guided by depth, and the
// point-sampling Downsample it pairs with (nodes/downsample.rs shares nothing with it but the
// texel-centre convention: low-res texel q covers high-res texels [q·f, (q + 1)·f)).

struct Params {
    sigma_depth: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var low: texture_2d<f32>;
@group(0) @binding(2) var low_depth: texture_2d<f32>;
@group(0) @binding(3) var high_depth: texture_2d<f32>;
@group(0) @binding(4) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(5) var out_image: texture_storage_2d<rgba32float, write>;

// The four low-res texels around high-res pixel p (bilinear footprint, clamped), each weighted
// by its bilinear weight times exp(−((d_q − d_p)/(σ d_p))²/2); when every weight vanishes (a
// surface none of the four saw), the texel of nearest depth within two texels.
fn upsample(p: vec2<u32>) -> vec4<f32> {
    let hi = vec2<f32>(textureDimensions(high_depth));
    let lo = vec2<i32>(textureDimensions(low));
    let uv = (vec2<f32>(p) + 0.5) / hi;
    let q = uv * vec2<f32>(lo) - 0.5;
    let f = q - floor(q);
    let base = vec2<i32>(floor(q));
    let dp = textureLoad(high_depth, p, 0).r;
    var num = vec4<f32>(0.0);
    var den = 0.0;
    for (var k = 0; k < 4; k++) {
        let o = vec2<i32>(k & 1, k >> 1u);
        let t = clamp(base + o, vec2<i32>(0), lo - 1);
        let wb = select(1.0 - f.x, f.x, o.x == 1) * select(1.0 - f.y, f.y, o.y == 1);
        let dq = textureLoad(low_depth, t, 0).r;
        let scale = max(P.sigma_depth * abs(dp), 1e-6);
        let r = (dq - dp) / scale;
        var w = wb * exp(-0.5 * r * r);
        if !(w == w) {
            w = 0.0;
        }
        num += w * textureLoad(low, t, 0);
        den += w;
    }
    if den > 1e-8 {
        return num / den;
    }
    var best = vec2<i32>(clamp(base, vec2<i32>(0), lo - 1));
    var best_gap = 3.0e38;
    for (var j = -2; j <= 3; j++) {
        for (var i = -2; i <= 3; i++) {
            let t = clamp(base + vec2<i32>(i, j), vec2<i32>(0), lo - 1);
            let gap = abs(textureLoad(low_depth, t, 0).r - dp);
            if gap < best_gap {
                best_gap = gap;
                best = t;
            }
        }
    }
    return textureLoad(low, best, 0);
}

@compute @workgroup_size(8, 8)
fn upsample_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_scalar, vec2<i32>(id.xy), vec4<f32>(upsample(id.xy).r, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn upsample_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_image, vec2<i32>(id.xy), upsample(id.xy));
}
