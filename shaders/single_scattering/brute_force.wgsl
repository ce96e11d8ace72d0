// SingleScattering, method BruteForce: `steps` samples along each view ray, optionally
// through a light map (nodes/single_scattering/brute_force.rs).
#import single_scattering/common

// ---- Light map (BruteForce only): the sun is multiplied by a light-space RGB texture --------
//
// The factored form no longer holds: L_scat = σt ρ f E ∫ V(t) M(x_t) E(t) dt, with E(t) the
// weight of `weight` (e^{−σt (t − t0)}, times the light's extinction when on). Sample i stands for
// its interval: Σ_i V_i M(x_i) ∫_{interval i} E dt.

struct LightMapView {
    view_proj: mat4x4<f32>,
    enabled: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(11) var light_map: texture_2d<f32>;
@group(0) @binding(12) var<uniform> LM: LightMapView;

// Bilinear lookup of the light map at a world point: texel centres at (i + 0.5)/size, clamp to
// edge (a point outside the map takes the nearest edge texel).
fn light_map_at(x: vec3<f32>) -> vec3<f32> {
    let c = LM.view_proj * vec4<f32>(x, 1.0);
    // w is 1 in an orthographic map; a spot's perspective one divides.
    let uv = vec2<f32>(c.x / c.w * 0.5 + 0.5, 0.5 - c.y / c.w * 0.5);
    let size = vec2<i32>(textureDimensions(light_map));
    let q = uv * vec2<f32>(size) - 0.5;
    let f = q - floor(q);
    let i0 = clamp(vec2<i32>(floor(q)), vec2<i32>(0), size - 1);
    let i1 = clamp(vec2<i32>(floor(q)) + 1, vec2<i32>(0), size - 1);
    let top = mix(textureLoad(light_map, vec2<i32>(i0.x, i0.y), 0), textureLoad(light_map, vec2<i32>(i1.x, i0.y), 0), f.x);
    let bottom = mix(textureLoad(light_map, vec2<i32>(i0.x, i1.y), 0), textureLoad(light_map, vec2<i32>(i1.x, i1.y), 0), f.x);
    return mix(top, bottom, f.y).rgb;
}

// BruteForce: `steps` samples at the centres of equal intervals of the medium's part of the
// ray (moved by the per-pixel jitter, rotated by the frame's phase). With a light map (LM.enabled) each lit sample adds its
// interval's weight times the map's colour; otherwise the factored form (or, with light
// extinction, the weighted integral) goes to `store`.
@compute @workgroup_size(8, 8)
fn brute_force(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
    let s = textureLoad(depth, id.xy, 0).r;
    let seg = medium_segment(dir, s);
    let t0 = seg.x;
    let len = max(seg.y - seg.x, 0.0);
    let offset = P.jitter * (fract(pixel_jitter(id.x, id.y) + P.jitter_phase) - 0.5);
    let map = LIGHT_MAP && LM.enabled != 0u;
    if LOCAL && P.light.kind != 0u {
        brute_force_local(id.xy, dir, t0, len, offset, map);
        return;
    }
    var lit = 0.0;
    var weighted = 0.0;
    var acc = vec3<f32>(0.0);
    for (var i = 0u; i < P.steps; i++) {
        let t = t0 + (f32(i) + 0.5 + offset) / f32(P.steps) * len;
        let x = P.eye + dir * t;
        let v = visible(x);
        lit += v;
        // Without a light map and light extinction (pipeline constants off) this compiles away.
        if map || extinction() {
            if v > 0.0 {
                // Sample i stands for its interval of the segment, weighted by its visibility
                // (1 with the hard test; a soft volume's fraction otherwise).
                let a = t0 + f32(i) / f32(P.steps) * len;
                let b = t0 + f32(i + 1u) / f32(P.steps) * len;
                let w = weight(dir, t0, a, b) * v;
                weighted += w;
                if map {
                    acc += w * light_map_at(x);
                }
            }
        }
    }
    let vbar = select(1.0, lit / f32(P.steps), len > 0.0 || P.bounded == 0u);
    if map {
        let base = P.sigma_t * P.albedo * phase(dot(dir, towards_sun(P.light)));
        textureStore(out_vis, id.xy, vec4<f32>(vbar, 0.0, 0.0, 1.0));
        textureStore(out_inscatter, id.xy, vec4<f32>(P.light.radiance * base * acc, 1.0));
        textureStore(out_transmittance, id.xy, vec4<f32>(exp(-len * P.sigma_t), 0.0, 0.0, 1.0));
    } else {
        store(id.xy, dir, vbar, len, weighted);
    }
}

// A spot or point light: each sample at distance t adds, over its interval Δ = len/steps (the
// midpoint rule), V · a(x) · f(θ_x) · e^{−σt (t − t0)} (· e^{−σt ℓ(x)} with light extinction,
// · M(x) with a light map) · Δ, where a is the light's falloff (inverse square, cone, range) and
// θ_x the angle between the view ray and the direction to the light from x. The factored form
// of the sun does not hold: phase and falloff change along the ray.
fn brute_force_local(p: vec2<u32>, dir: vec3<f32>, t0: f32, len: f32, offset: f32, map: bool) {
    var lit = 0.0;
    var acc = vec3<f32>(0.0);
    let delta = len / f32(P.steps);
    for (var i = 0u; i < P.steps; i++) {
        let t = t0 + (f32(i) + 0.5 + offset) / f32(P.steps) * len;
        let x = P.eye + dir * t;
        let v = visible(x);
        lit += v;
        if v > 0.0 {
            let to_light = normalize(P.light.position - x);
            var e = exp(-P.sigma_t * (t - t0));
            if extinction() {
                e *= exp(-P.sigma_t * local_light_path(x));
            }
            // v: 1 with the hard test, a soft volume's fraction otherwise.
            var c = phase(dot(dir, to_light)) * (local_falloff(x) * e * delta * v);
            if map {
                c *= light_map_at(x);
            }
            acc += c;
        }
    }
    let vbar = select(1.0, lit / f32(P.steps), len > 0.0 || P.bounded == 0u);
    textureStore(out_vis, p, vec4<f32>(vbar, 0.0, 0.0, 1.0));
    textureStore(out_inscatter, p, vec4<f32>(P.light.radiance * (P.sigma_t * P.albedo) * acc, 1.0));
    textureStore(out_transmittance, p, vec4<f32>(exp(-len * P.sigma_t), 0.0, 0.0, 1.0));
}
