// Phase-function tables (nodes/phase/): W×1 RGBA32F, texel i at θ = π (i + 0.5)/W, RGB the
// phase function per channel in 1/sr. Tabulation of the analytic models, the Legendre series of
// multiple scattering, and the two reductions (normalisation, forward fraction) that run in one
// workgroup of 64 invocations.

struct Params {
    width: u32,
    count: u32,
    g: f32,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var table_out: texture_storage_2d<rgba32float, write>;
@group(0) @binding(2) var coeffs: texture_2d<f32>;
@group(0) @binding(3) var table_in: texture_2d<f32>;
@group(0) @binding(4) var forward_out: texture_storage_2d<rgba32float, write>;

const PI: f32 = 3.14159265358979;

fn theta(i: u32) -> f32 {
    return PI * (f32(i) + 0.5) / f32(P.width);
}

fn store(i: u32, v: vec3<f32>) {
    textureStore(table_out, vec2<u32>(i, 0u), vec4<f32>(v, 1.0));
}

// Henyey–Greenstein, (1 − g²) / (4π (1 + g² − 2g cos θ)^{3/2}), the same in every channel.
@compute @workgroup_size(8, 8, 1)
fn henyey_greenstein(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if id.y > 0u || i >= P.width {
        return;
    }
    let g = P.g;
    let d = max(1.0 + g * g - 2.0 * g * cos(theta(i)), 1e-12);
    store(i, vec3<f32>((1.0 - g * g) / (4.0 * PI * d * sqrt(d))));
}

// Rayleigh, 3/(16π) (1 + cos²θ).
@compute @workgroup_size(8, 8, 1)
fn rayleigh(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if id.y > 0u || i >= P.width {
        return;
    }
    let c = cos(theta(i));
    store(i, vec3<f32>(3.0 / (16.0 * PI) * (1.0 + c * c)));
}

// Σ_{l < count} (2l + 1)/(4π) c_l P_l(cos θ) per channel (Legendre recurrence), negative
// values (truncation ringing) clamped to 0.
@compute @workgroup_size(8, 8, 1)
fn legendre_series(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if id.y > 0u || i >= P.width {
        return;
    }
    let mu = cos(theta(i));
    var p0 = 1.0;
    var p1 = mu;
    var acc = textureLoad(coeffs, vec2<u32>(0u, 0u), 0).rgb * p0;
    if P.count > 1u {
        acc += 3.0 * textureLoad(coeffs, vec2<u32>(1u, 0u), 0).rgb * p1;
    }
    for (var l = 2u; l < P.count; l++) {
        let fl = f32(l);
        let p2 = ((2.0 * fl - 1.0) * mu * p1 - (fl - 1.0) * p0) / fl;
        acc += (2.0 * fl + 1.0) * textureLoad(coeffs, vec2<u32>(l, 0u), 0).rgb * p2;
        p0 = p1;
        p1 = p2;
    }
    store(i, max(acc / (4.0 * PI), vec3<f32>(0.0)));
}

var<workgroup> partial: array<vec3<f32>, 64>;

// 2π Σ p(θ_i) sin θ_i Δθ over the texels i ≡ lane (mod 64) with θ_i below `limit`, reduced over
// the workgroup; every lane returns the total.
fn integrate(lane: u32, limit: f32) -> vec3<f32> {
    var s = vec3<f32>(0.0);
    for (var i = lane; i < P.width; i += 64u) {
        let t = theta(i);
        if t < limit {
            s += textureLoad(table_in, vec2<u32>(i, 0u), 0).rgb * sin(t);
        }
    }
    partial[lane] = s * (2.0 * PI * PI / f32(P.width));
    workgroupBarrier();
    for (var k = 32u; k > 0u; k >>= 1u) {
        if lane < k {
            partial[lane] += partial[lane + k];
        }
        workgroupBarrier();
    }
    return partial[0];
}

// table_out = table_in / ∫ table_in dΩ per channel (a table integrating to 0: isotropic 1/(4π)).
@compute @workgroup_size(8, 8, 1)
fn normalise(@builtin(local_invocation_index) lane: u32) {
    let total = integrate(lane, 4.0);
    for (var i = lane; i < P.width; i += 64u) {
        let v = textureLoad(table_in, vec2<u32>(i, 0u), 0).rgb;
        store(i, select(vec3<f32>(0.25 / PI), v / total, total > vec3<f32>(0.0)));
    }
}

// F = ∫ over the forward hemisphere (θ < π/2) of table_in dΩ, per channel, into texel (0, 0).
@compute @workgroup_size(8, 8, 1)
fn forward_fraction(@builtin(local_invocation_index) lane: u32) {
    let f = integrate(lane, 0.5 * PI);
    if lane == 0u {
        textureStore(forward_out, vec2<u32>(0u, 0u), vec4<f32>(f, 1.0));
    }
}
