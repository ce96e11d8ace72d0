// SingleScattering with a density volume (nodes/single_scattering/density.rs): σt(x) =
// sigma_t · density(x) inside the volume's box, the light reaching a point attenuated by the
// density between it and the light (a light-space transmittance volume built once per run),
// the view ray marched through the varying σt.
#import single_scattering/common
#import lib/box_volume

struct DensityView {
    // The density volume's world box (the light transmittance volume covers the same box).
    lo: vec3<f32>,
    // Samples per light ray of the transmittance volume (midpoints).
    light_steps: u32,
    hi: vec3<f32>,
    _pad0: u32,
}

@group(0) @binding(20) var density_volume: texture_3d<f32>;
@group(0) @binding(21) var light_tr: texture_3d<f32>;
@group(0) @binding(22) var<uniform> D: DensityView;
@group(0) @binding(23) var out_light_tr: texture_storage_3d<r32float, write>;
// Empty-space skipping: per brick of BRICK³ density texels, the largest density a trilinear
// read inside the brick can see (its texels and one more on every side); 0 = empty.
@group(0) @binding(24) var occupancy: texture_3d<f32>;
@group(0) @binding(25) var out_occupancy: texture_storage_3d<r32float, write>;

const BRICK: i32 = 4;

fn density_at(x: vec3<f32>) -> f32 {
    return max(box_trilinear(density_volume, D.lo, D.hi, x, 0.0), 0.0);
}

// Brick b's occupancy: the max of max(density, 0) over texels 4b − 1 … 4b + 4 (clamped), every
// texel a trilinear read at a point of the brick's box can weigh.
@compute @workgroup_size(4, 4, 4)
fn occupancy_build(@builtin(global_invocation_id) id: vec3<u32>) {
    let nb = textureDimensions(out_occupancy);
    if any(id >= nb) {
        return;
    }
    let n = vec3<i32>(textureDimensions(density_volume, 0));
    let a = max(vec3<i32>(id) * BRICK - 1, vec3<i32>(0));
    let b = min(vec3<i32>(id) * BRICK + BRICK, n - 1);
    var m = 0.0;
    for (var z = a.z; z <= b.z; z++) {
        for (var y = a.y; y <= b.y; y++) {
            for (var x = a.x; x <= b.x; x++) {
                m = max(m, textureLoad(density_volume, vec3<i32>(x, y, z), 0).r);
            }
        }
    }
    textureStore(out_occupancy, id, vec4<f32>(m, 0.0, 0.0, 1.0));
}

// The samples to step over from sample i at x (along unit d, `delta` apart): 0 when x's brick
// holds density, else enough to pass the brick's box (at least 1). Every sample skipped lies in
// an empty brick, where the density reads exactly 0 and adds nothing to any sum.
fn skip_empty(x: vec3<f32>, d: vec3<f32>, delta: f32) -> u32 {
    let n = vec3<f32>(textureDimensions(density_volume, 0));
    let u = (x - D.lo) / max(D.hi - D.lo, vec3<f32>(1e-12));
    if any(u < vec3<f32>(0.0)) || any(u > vec3<f32>(1.0)) || delta <= 0.0 {
        return 0u;
    }
    let nb = textureDimensions(occupancy, 0);
    let b = min(vec3<u32>(u * n / f32(BRICK)), nb - 1u);
    if textureLoad(occupancy, b, 0).r > 0.0 {
        return 0u;
    }
    let cell = (D.hi - D.lo) / n * f32(BRICK);
    let lo = D.lo + vec3<f32>(b) * cell;
    let hi = min(lo + cell, D.hi);
    var t = 1e30;
    for (var k = 0; k < 3; k++) {
        if d[k] > 0.0 {
            t = min(t, (hi[k] - x[k]) / d[k]);
        } else if d[k] < 0.0 {
            t = min(t, (lo[k] - x[k]) / d[k]);
        }
    }
    return max(1u, u32(min(ceil(max(t, 0.0) / delta), 1e9)));
}

// The unit direction from x towards the light, and how far the light is (the sun: unbounded).
fn to_light(x: vec3<f32>) -> vec4<f32> {
    if LOCAL && P.light.kind != 0u {
        let l = P.light.position - x;
        let r = length(l);
        return vec4<f32>(select(vec3<f32>(0.0, 1.0, 0.0), l / r, r > 0.0), r);
    }
    return vec4<f32>(towards_sun(P.light), 1e30);
}

// Distance from x along unit d to where it leaves D's box (0 when it starts outside going out).
fn box_exit(x: vec3<f32>, d: vec3<f32>) -> f32 {
    var t = 1e30;
    for (var k = 0; k < 3; k++) {
        if d[k] > 0.0 {
            t = min(t, (D.hi[k] - x[k]) / d[k]);
        } else if d[k] < 0.0 {
            t = min(t, (D.lo[k] - x[k]) / d[k]);
        }
    }
    return max(t, 0.0);
}

// The light's transmittance through the density from texel (i, j, k)'s centre to the box's
// boundary (or to a lamp inside it): e^{−σt Σ density(x_m) Δ}, midpoints of `light_steps`
// equal intervals.
@compute @workgroup_size(4, 4, 4)
fn light_transmittance(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = textureDimensions(out_light_tr);
    if any(id >= n) {
        return;
    }
    let x = D.lo + (vec3<f32>(id) + 0.5) / vec3<f32>(n) * (D.hi - D.lo);
    let l = to_light(x);
    let len = min(box_exit(x, l.xyz), l.w);
    let m = max(D.light_steps, 1u);
    let delta = len / f32(m);
    var tau = 0.0;
    // Empty bricks are stepped over; the occupancy is looked up only after a sample read 0, so
    // the smoke itself costs no more than without skipping.
    var empty = true;
    var i = 0u;
    loop {
        if i >= m {
            break;
        }
        let xi = x + l.xyz * ((f32(i) + 0.5) * delta);
        if empty {
            let skip = skip_empty(xi, l.xyz, delta);
            if skip > 0u {
                i += skip;
                continue;
            }
        }
        let dens = density_at(xi);
        tau += dens;
        empty = dens == 0.0;
        i++;
    }
    textureStore(out_light_tr, id, vec4<f32>(exp(-P.sigma_t * tau * delta), 0.0, 0.0, 1.0));
}

// BruteForce through the density: `steps` samples at the centres of equal intervals of the
// ray's part inside the medium and the box. Sample i stands for its interval Δ with σ_i =
// σt · density(x_i): it adds ρ f(θ) L_i T_i (1 − e^{−σ_i Δ}), T_i the view ray's transmittance
// up to the interval, L_i = V(x_i) · T_light(x_i) (· a lamp's falloff); T_{i+1} = T_i e^{−σ_i Δ}.
// `visibility` is the mean of V · T_light over the samples where the density is above 0 (the
// mean light reaching the smoke along the ray; 1 where the ray meets none). Samples in empty
// bricks are stepped over (they add nothing).
@compute @workgroup_size(8, 8)
fn brute_force_density(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
    let s = textureLoad(depth, id.xy, 0).r;
    // The medium's part of [0, s], clipped to the density's box.
    let seg = medium_segment(dir, s);
    var t0 = seg.x;
    var t1 = seg.y;
    for (var k = 0; k < 3; k++) {
        if dir[k] != 0.0 {
            let a = (D.lo[k] - P.eye[k]) / dir[k];
            let b = (D.hi[k] - P.eye[k]) / dir[k];
            t0 = max(t0, min(a, b));
            t1 = min(t1, max(a, b));
        } else if P.eye[k] < D.lo[k] || P.eye[k] > D.hi[k] {
            t1 = t0 - 1.0;
        }
    }
    let len = max(t1 - t0, 0.0);
    let offset = P.jitter * (fract(pixel_jitter(id.x, id.y) + P.jitter_phase) - 0.5);
    let delta = len / f32(P.steps);
    var tr = 1.0;
    var lit = 0.0;
    var in_smoke = 0u;
    var acc = vec3<f32>(0.0);
    var empty = true;
    var i = 0u;
    loop {
        if i >= P.steps {
            break;
        }
        let t = t0 + (f32(i) + 0.5 + offset) * delta;
        let x = P.eye + dir * t;
        if empty {
            let skip = skip_empty(x, dir, delta);
            if skip > 0u {
                i += skip;
                continue;
            }
        }
        i++;
        let dens = density_at(x);
        empty = dens == 0.0;
        if empty {
            continue;
        }
        let sigma = P.sigma_t * dens;
        let light = visible(x) * box_trilinear(light_tr, D.lo, D.hi, x, 1.0);
        lit += light;
        in_smoke++;
        let absorbed = 1.0 - exp(-sigma * delta);
        if light > 0.0 && absorbed > 0.0 {
            var f: vec3<f32>;
            if LOCAL && P.light.kind != 0u {
                f = phase(dot(dir, normalize(P.light.position - x))) * local_falloff(x);
            } else {
                f = phase(dot(dir, towards_sun(P.light)));
            }
            acc += f * (light * tr * absorbed);
        }
        tr *= exp(-sigma * delta);
    }
    let vbar = select(1.0, lit / f32(in_smoke), in_smoke > 0u);
    textureStore(out_vis, id.xy, vec4<f32>(vbar, 0.0, 0.0, 1.0));
    textureStore(out_inscatter, id.xy, vec4<f32>(P.light.radiance * P.albedo * acc, 1.0));
    textureStore(out_transmittance, id.xy, vec4<f32>(tr, 0.0, 0.0, 1.0));
}
