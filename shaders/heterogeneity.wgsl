// Heterogeneity (nodes/heterogeneity.rs): h = s⁻¹ ∫₀ˢ I(x_t) (α(x_t) N(x_t, f(x_t)) + 1 − α(x_t)) dt
// marched at `steps` interval midpoints along each view ray to its surface; out = L_scat · h.
// Volumes are read trilinearly between texel centres (clamped to the edge of their box); the
// noise N at a fractional level f is the mix of levels ⌊f⌋ and ⌊f⌋ + 1.
#import lib/camera

struct Params {
    inv_view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    steps: u32,
    noise_min: vec3<f32>,
    alpha: f32,
    noise_max: vec3<f32>,
    frequency: f32,
    alpha_min: vec3<f32>,
    intensity: f32,
    alpha_max: vec3<f32>,
    use_alpha: u32,
    freq_min: vec3<f32>,
    use_freq: u32,
    freq_max: vec3<f32>,
    use_intensity: u32,
    int_min: vec3<f32>,
    _pad0: u32,
    int_max: vec3<f32>,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var inscatter: texture_2d<f32>;
@group(0) @binding(2) var depth: texture_2d<f32>;
@group(0) @binding(3) var noise: texture_3d<f32>;
@group(0) @binding(4) var alpha_vol: texture_3d<f32>;
@group(0) @binding(5) var freq_vol: texture_3d<f32>;
@group(0) @binding(6) var int_vol: texture_3d<f32>;
@group(0) @binding(7) var out_image: texture_storage_2d<rgba32float, write>;
@group(0) @binding(8) var out_h: texture_storage_2d<r32float, write>;

fn trilinear(v: texture_3d<f32>, level: i32, uvw: vec3<f32>) -> f32 {
    let size = vec3<i32>(textureDimensions(v, level));
    let q = uvw * vec3<f32>(size) - 0.5;
    let f = q - floor(q);
    let b = vec3<i32>(floor(q));
    var c: array<f32, 8>;
    for (var k = 0; k < 8; k++) {
        let o = vec3<i32>(k & 1, (k >> 1u) & 1, (k >> 2u) & 1);
        c[k] = textureLoad(v, clamp(b + o, vec3<i32>(0), size - 1), level).r;
    }
    let x00 = mix(c[0], c[1], f.x);
    let x10 = mix(c[2], c[3], f.x);
    let x01 = mix(c[4], c[5], f.x);
    let x11 = mix(c[6], c[7], f.x);
    return mix(mix(x00, x10, f.y), mix(x01, x11, f.y), f.z);
}

fn uvw(x: vec3<f32>, lo: vec3<f32>, hi: vec3<f32>) -> vec3<f32> {
    return clamp((x - lo) / max(hi - lo, vec3<f32>(1e-12)), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn noise_at(x: vec3<f32>, f: f32) -> f32 {
    let top = f32(textureNumLevels(noise) - 1u);
    let l = clamp(f, 0.0, top);
    let l0 = i32(floor(l));
    let l1 = min(l0 + 1, i32(top));
    let p = uvw(x, P.noise_min, P.noise_max);
    return mix(trilinear(noise, l0, p), trilinear(noise, l1, p), l - floor(l));
}

@compute @workgroup_size(8, 8)
fn heterogeneity(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = pixel_ray(P.inv_view_proj, P.eye, id.xy, size);
    let s = textureLoad(depth, id.xy, 0).r;
    var sum = 0.0;
    for (var i = 0u; i < P.steps; i++) {
        let x = P.eye + dir * ((f32(i) + 0.5) / f32(P.steps) * s);
        var a = P.alpha;
        if P.use_alpha == 1u {
            a = trilinear(alpha_vol, 0, uvw(x, P.alpha_min, P.alpha_max));
        }
        var f = P.frequency;
        if P.use_freq == 1u {
            f = trilinear(freq_vol, 0, uvw(x, P.freq_min, P.freq_max));
        }
        var I = P.intensity;
        if P.use_intensity == 1u {
            I = trilinear(int_vol, 0, uvw(x, P.int_min, P.int_max));
        }
        sum += I * (a * noise_at(x, f) + 1.0 - a);
    }
    let h = sum / f32(P.steps);
    let c = textureLoad(inscatter, id.xy, 0);
    textureStore(out_image, id.xy, vec4<f32>(c.rgb * h, c.a));
    textureStore(out_h, id.xy, vec4<f32>(h, 0.0, 0.0, 1.0));
}
