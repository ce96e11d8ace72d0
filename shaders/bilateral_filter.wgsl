// BilateralFilter (nodes/bilateral_filter.rs): one pass of the separable bilateral filter along
// x or y. w(j) = exp(−j²/(2σs²)) · exp(−(g(p + j) − g(p))²/(2σr²)), taps outside the image
// skipped, normalised by Σw. The guide g is the `guide` texture, or the luminance of the pass's
// own source (Rec. 709 weights; a Scalar's value) when there is none. σ = 0 keeps only exact
// matches (j = 0, or equal guide values), the limit of the Gaussian.

struct Params {
    radius: i32,
    axis: u32,
    sigma_spatial: f32,
    sigma_range: f32,
    use_guide: u32,
    scalar: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var guide: texture_2d<f32>;
@group(0) @binding(3) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(4) var out_image: texture_storage_2d<rgba32float, write>;

fn g(q: vec2<i32>) -> f32 {
    if P.use_guide == 1u {
        return textureLoad(guide, q, 0).r;
    }
    let c = textureLoad(src, q, 0);
    if P.scalar == 1u {
        return c.r;
    }
    return dot(c.rgb, vec3<f32>(0.2126, 0.7152, 0.0722));
}

// exp(−d²/(2σ²)), with the σ → 0 limit (1 where d = 0, else 0).
fn gauss(d: f32, sigma: f32) -> f32 {
    if sigma <= 0.0 {
        return select(0.0, 1.0, d == 0.0);
    }
    return exp(-(d * d) / (2.0 * sigma * sigma));
}

fn filtered(p: vec2<i32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(src));
    let step = select(vec2<i32>(1, 0), vec2<i32>(0, 1), P.axis == 1u);
    let gp = g(p);
    var num = vec4<f32>(0.0);
    var den = 0.0;
    for (var j = -P.radius; j <= P.radius; j++) {
        let q = p + step * j;
        if any(q < vec2<i32>(0)) || any(q >= size) {
            continue;
        }
        let w = gauss(f32(j), P.sigma_spatial) * gauss(g(q) - gp, P.sigma_range);
        num += w * textureLoad(src, q, 0);
        den += w;
    }
    // The centre tap always has weight 1 (unless the guide is not finite there).
    if den > 0.0 {
        return num / den;
    }
    return textureLoad(src, p, 0);
}

@compute @workgroup_size(8, 8)
fn bilateral_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_scalar, vec2<i32>(id.xy), vec4<f32>(filtered(vec2<i32>(id.xy)).r, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn bilateral_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_image, vec2<i32>(id.xy), filtered(vec2<i32>(id.xy)));
}
