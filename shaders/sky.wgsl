// Sky: analytic single-scattering sky and aerial perspective over a flat earth with an
// exponential atmosphere (nodes/sky.rs; seed 002 eq. 8–15).
#import lib/camera

struct Params {
    inv_view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    far: f32,
    to_sun: vec3<f32>,
    gamma: f32,
    sun: vec3<f32>,
    altitude: f32,
    beta_air: vec3<f32>,
    aerosol: f32,
    distance_scale: f32,
    aerosol_g: f32,
    phase_width: u32,
    sun_disk: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var depth: texture_2d<f32>;
@group(0) @binding(2) var phase_table: texture_2d<f32>;
@group(0) @binding(3) var out_inscatter: texture_storage_2d<rgba32float, write>;
@group(0) @binding(4) var out_transmittance: texture_storage_2d<rgba32float, write>;
@group(0) @binding(5) var out_sky: texture_storage_2d<rgba32float, write>;

const PI: f32 = 3.14159265358979;
// The longest path considered (m): the sky's rays end there.
const K_MAX: f32 = 1e7;
// cos(0.25°) and the solid angle of a 0.5° sun disk, 2π (1 − cos 0.25°).
const SUN_COS: f32 = 0.99999048;
const SUN_SR: f32 = 5.9811e-5;

// (1 − e^{−x})/x, 1 at x = 0.
fn e1(x: f32) -> f32 {
    if abs(x) < 1e-4 {
        return 1.0 - 0.5 * x;
    }
    return -(exp(-x) - 1.0) / x;
}

// x, or 1e30 where it is larger, infinite or NaN (no NaN comparison is true).
fn finite(x: vec3<f32>) -> vec3<f32> {
    return select(vec3<f32>(1e30), x, x < vec3<f32>(1e30));
}

// Optical depth from height h along a ray of vertical component dy to distance k (eq. 11's
// exponent): β e^{−γh} k e1(γ dy k), or β (e^{−γh} − e^{−γ(h + dy k)})/(γ dy) where γ dy k is
// large (no 0 · ∞ when the density underflows); capped at 1e30.
fn optical_depth(beta: vec3<f32>, h: f32, dy: f32, k: f32) -> vec3<f32> {
    let x = P.gamma * dy * k;
    if abs(x) < 1.0 {
        return finite(beta * exp(-P.gamma * h) * k * e1(x));
    }
    return finite(beta * (exp(-P.gamma * h) - exp(-P.gamma * (h + dy * k))) / (P.gamma * dy));
}

fn aerosol_phase(c: f32) -> vec3<f32> {
    if P.phase_width == 0u {
        let g = P.aerosol_g;
        let d = max(1.0 + g * g - 2.0 * g * c, 1e-12);
        return vec3<f32>((1.0 - g * g) / (4.0 * PI * d * sqrt(d)));
    }
    let w = f32(P.phase_width);
    let x = clamp(acos(clamp(c, -1.0, 1.0)) / PI * w - 0.5, 0.0, w - 1.0);
    let i0 = u32(floor(x));
    let i1 = min(i0 + 1u, P.phase_width - 1u);
    let a = textureLoad(phase_table, vec2<u32>(i0, 0u), 0).rgb;
    let b = textureLoad(phase_table, vec2<u32>(i1, 0u), 0).rgb;
    return mix(a, b, x - f32(i0));
}

@compute @workgroup_size(8, 8)
fn sky(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = pixel_ray(P.inv_view_proj, P.eye, id.xy, size);
    let d = textureLoad(depth, id.xy, 0).r;
    let background = d >= P.far * 0.999;
    let h = P.altitude + P.eye.y * P.distance_scale;
    let dy = dir.y;
    var k = d * P.distance_scale;
    if background {
        k = K_MAX;
        if dy < 0.0 && h > 0.0 {
            k = min(K_MAX, h / -dy);
        }
    }
    let beta = P.beta_air + vec3<f32>(P.aerosol);
    let tau_e = optical_depth(beta, h, dy, k);
    let c = dot(dir, P.to_sun);
    let ray = 3.0 / (16.0 * PI) * (1.0 + c * c);
    let p_eff = (P.beta_air * ray + P.aerosol * aerosol_phase(c)) / max(beta, vec3<f32>(1e-30));
    var l = vec3<f32>(0.0);
    let ly = P.to_sun.y;
    if ly > 1e-4 {
        // τ_s at the eye and at distance k; L = I P τ_e e^{−min(τ_s0, τ_e + τ_sk)} e1(|z|).
        let tau_s0 = finite(beta * exp(-P.gamma * h) / (P.gamma * ly));
        let tau_sk = finite(beta * exp(-P.gamma * (h + dy * k)) / (P.gamma * ly));
        let z = tau_e - tau_s0 + tau_sk;
        let e = vec3<f32>(e1(abs(z.x)), e1(abs(z.y)), e1(abs(z.z)));
        l = P.sun * p_eff * tau_e * exp(-min(tau_s0, tau_e + tau_sk)) * e;
    }
    let t = exp(-tau_e);
    if background {
        var s = l;
        if P.sun_disk != 0u && c >= SUN_COS {
            s += P.sun * t / SUN_SR;
        }
        textureStore(out_inscatter, id.xy, vec4<f32>(s, 1.0));
        textureStore(out_transmittance, id.xy, vec4<f32>(0.0, 0.0, 0.0, 1.0));
        textureStore(out_sky, id.xy, vec4<f32>(s, 1.0));
    } else {
        textureStore(out_inscatter, id.xy, vec4<f32>(l, 1.0));
        textureStore(out_transmittance, id.xy, vec4<f32>(t, 1.0));
        textureStore(out_sky, id.xy, vec4<f32>(0.0, 0.0, 0.0, 1.0));
    }
}
