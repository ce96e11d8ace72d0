// SingleScattering: average visibility, in-scatter and transmittance along view rays
// (nodes/single_scattering.rs; SPEC §3, seed 000 eq. 1–2).

struct Params {
    inv_view_proj: mat4x4<f32>,
    light_view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    steps: u32,
    to_sun: vec3<f32>,
    sigma_t: f32,
    radiance: vec3<f32>,
    albedo: f32,
    g: f32,
    jitter: f32,
    bias: f32,
    method: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var shadow: texture_2d<f32>;
@group(0) @binding(2) var depth: texture_2d<f32>;
@group(0) @binding(3) var out_vis: texture_storage_2d<r32float, write>;
@group(0) @binding(4) var out_inscatter: texture_storage_2d<rgba32float, write>;
@group(0) @binding(5) var out_transmittance: texture_storage_2d<r32float, write>;

const PI: f32 = 3.14159265358979;

fn hash(x: u32, y: u32) -> f32 {
    var v = (x * 1973u + y * 9277u + 26699u) | 1u;
    v = v * 747796405u + 2891336453u;
    let w = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
    return f32((w >> 22u) ^ w) / 4294967296.0;
}

fn transmittance_integral(s: f32, sigma_t: f32) -> f32 {
    let x = s * sigma_t;
    if x < 1e-3 {
        return s * (1.0 - x * 0.5 + x * x / 6.0);
    }
    return (1.0 - exp(-x)) / sigma_t;
}

fn henyey_greenstein(g: f32, cos_theta: f32) -> f32 {
    let d = max(1.0 + g * g - 2.0 * g * cos_theta, 1e-12);
    return (1.0 - g * g) / (4.0 * PI * d * sqrt(d));
}

fn visible(x: vec3<f32>) -> f32 {
    let c = P.light_view_proj * vec4<f32>(x, 1.0);
    let uvz = vec3<f32>(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z);
    if uvz.x < 0.0 || uvz.x >= 1.0 || uvz.y < 0.0 || uvz.y >= 1.0 || uvz.z < 0.0 || uvz.z > 1.0 {
        return 1.0;
    }
    let size = vec2<f32>(textureDimensions(shadow));
    let texel = min(vec2<u32>(uvz.xy * size), vec2<u32>(size) - 1u);
    return select(0.0, 1.0, uvz.z <= textureLoad(shadow, texel, 0).r + P.bias);
}

@compute @workgroup_size(8, 8)
fn brute_force(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let ndc = vec4<f32>(
        (f32(id.x) + 0.5) / f32(size.x) * 2.0 - 1.0,
        1.0 - (f32(id.y) + 0.5) / f32(size.y) * 2.0,
        1.0,
        1.0,
    );
    let far = P.inv_view_proj * ndc;
    var dir = far.xyz / far.w - P.eye;
    dir = select(vec3<f32>(0.0, 0.0, -1.0), normalize(dir), dot(dir, dir) > 0.0);
    let s = textureLoad(depth, id.xy, 0).r;
    let offset = P.jitter * (hash(id.x, id.y) - 0.5);
    var lit = 0.0;
    for (var i = 0u; i < P.steps; i++) {
        let t = (f32(i) + 0.5 + offset) / f32(P.steps) * s;
        lit += visible(P.eye + dir * t);
    }
    let vbar = lit / f32(P.steps);
    let k = P.sigma_t * P.albedo * henyey_greenstein(P.g, dot(dir, P.to_sun)) * transmittance_integral(s, P.sigma_t) * vbar;
    textureStore(out_vis, id.xy, vec4<f32>(vbar, 0.0, 0.0, 1.0));
    textureStore(out_inscatter, id.xy, vec4<f32>(P.radiance * k, 1.0));
    textureStore(out_transmittance, id.xy, vec4<f32>(exp(-s * P.sigma_t), 0.0, 0.0, 1.0));
}
