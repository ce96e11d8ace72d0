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
    min_level: u32,
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

// Unit direction of the view ray through the centre of pixel `p` of a `size` image.
fn view_ray(p: vec2<u32>, size: vec2<u32>) -> vec3<f32> {
    let ndc = vec4<f32>(
        (f32(p.x) + 0.5) / f32(size.x) * 2.0 - 1.0,
        1.0 - (f32(p.y) + 0.5) / f32(size.y) * 2.0,
        1.0,
        1.0,
    );
    let far = P.inv_view_proj * ndc;
    let dir = far.xyz / far.w - P.eye;
    return select(vec3<f32>(0.0, 0.0, -1.0), normalize(dir), dot(dir, dir) > 0.0);
}

@compute @workgroup_size(8, 8)
fn brute_force(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
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

// ---- Method MinMax: a min-max pyramid of the shadow map, traversed hierarchically ----------
//
// Level 0 is the map itself; levels 1.. live in one RG32F atlas (min, max of the 2^k × 2^k
// texels below), level k at rect[k] = (x offset, y offset, width, height). Along a view ray the
// light-space position is affine in t, so over any stretch of the ray inside one pyramid cell
// the ray's depth is bounded by its values at the ends: a cell whose max depth bound the ray
// stays under is lit throughout, one whose min the ray stays above is shadowed throughout, and
// only mixed cells are refined, down to single texels where the lit part is solved exactly.
// The result is the exact average of the brute-force visibility (nearest texel, same bias) as
// its number of steps goes to infinity.

struct Levels {
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    rect: array<vec4<u32>, 16>,
}

struct Build {
    level: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    src: vec4<u32>,
    dst: vec4<u32>,
}

@group(0) @binding(6) var atlas: texture_2d<f32>;
@group(0) @binding(7) var<uniform> B: Build;
@group(0) @binding(8) var build_src: texture_2d<f32>;
@group(0) @binding(9) var build_dst: texture_storage_2d<rg32float, write>;
@group(0) @binding(10) var<uniform> L: Levels;

// One level of the pyramid: level 1 reads the map (min = max = depth), later levels the atlas.
@compute @workgroup_size(8, 8)
fn build_level(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= B.dst.z || id.y >= B.dst.w {
        return;
    }
    var mn = 3.0e38;
    var mx = -3.0e38;
    for (var b = 0u; b < 2u; b++) {
        for (var a = 0u; a < 2u; a++) {
            let c = min(id.xy * 2u + vec2<u32>(a, b), B.src.zw - 1u);
            let v = textureLoad(build_src, B.src.xy + c, 0);
            if B.level == 1u {
                mn = min(mn, v.r);
                mx = max(mx, v.r);
            } else {
                mn = min(mn, v.r);
                mx = max(mx, v.g);
            }
        }
    }
    textureStore(build_dst, B.dst.xy + id.xy, vec4<f32>(mn, mx, 0.0, 1.0));
}

// Length of [t0, t1] where the depth, linear from z0 to z1, is at most c.
fn lit_part(t0: f32, t1: f32, z0: f32, z1: f32, c: f32) -> f32 {
    if z0 <= c && z1 <= c {
        return t1 - t0;
    }
    if z0 > c && z1 > c {
        return 0.0;
    }
    let u = clamp((c - z0) / (z1 - z0), 0.0, 1.0);
    if z0 <= c {
        return (t1 - t0) * u;
    }
    return (t1 - t0) * (1.0 - u);
}

const MAX_ITER: u32 = 16384u;

@compute @workgroup_size(8, 8)
fn min_max(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
    let s = textureLoad(depth, id.xy, 0).r;
    let msize = vec2<f32>(textureDimensions(shadow));
    // The ray in level-0 texel units and light depth: p(t) = a + d t.
    let c0 = P.light_view_proj * vec4<f32>(P.eye, 1.0);
    let c1 = P.light_view_proj * vec4<f32>(P.eye + dir, 1.0);
    let a = vec3<f32>((c0.x * 0.5 + 0.5) * msize.x, (0.5 - c0.y * 0.5) * msize.y, c0.z);
    let d = vec3<f32>((c1.x - c0.x) * 0.5 * msize.x, -(c1.y - c0.y) * 0.5 * msize.y, c1.z - c0.z);
    // Clip [0, s] to the map and the light box; the rest of the ray is lit.
    var tin = 0.0;
    var tout = s;
    let lo = vec3<f32>(0.0);
    let hi = vec3<f32>(msize, 1.0);
    for (var k = 0; k < 3; k++) {
        if abs(d[k]) < 1e-12 {
            if a[k] < lo[k] || a[k] > hi[k] {
                tout = -1.0;
            }
        } else {
            let ta = (lo[k] - a[k]) / d[k];
            let tb = (hi[k] - a[k]) / d[k];
            tin = max(tin, min(ta, tb));
            tout = min(tout, max(ta, tb));
        }
    }
    var lit = s;
    if tout > tin {
        lit = s - (tout - tin);
        let top = L.count;
        var level = top;
        var t = tin;
        var iter = 0u;
        let nudge = sign(d.xy) * 1e-3;
        let msz = vec2<u32>(msize);
        while t < tout && iter < MAX_ITER {
            iter++;
            let scale = f32(1u << level);
            let p = a + d * t;
            var dims = msz;
            if level > 0u {
                dims = L.rect[level].zw;
            }
            let cell = min(vec2<u32>(max(floor((p.xy + nudge) / scale), vec2<f32>(0.0))), dims - 1u);
            let cell_lo = vec2<f32>(cell) * scale;
            let cell_hi = cell_lo + scale;
            var t_exit = tout;
            for (var k = 0; k < 2; k++) {
                if d[k] > 1e-12 {
                    t_exit = min(t_exit, (cell_hi[k] - a[k]) / d[k]);
                } else if d[k] < -1e-12 {
                    t_exit = min(t_exit, (cell_lo[k] - a[k]) / d[k]);
                }
            }
            t_exit = max(t_exit, t);
            let z0 = a.z + d.z * t;
            let z1 = a.z + d.z * t_exit;
            var mm: vec2<f32>;
            if level == 0u {
                mm = vec2<f32>(textureLoad(shadow, cell, 0).r);
            } else {
                mm = textureLoad(atlas, L.rect[level].xy + cell, 0).rg;
            }
            // After a block is settled, go up a level only when the ray leaves the parent
            // block too: the parent of the next block, if it is the same, was found mixed.
            let next = a.xy + d.xy * t_exit + nudge;
            let parent_changes = any(vec2<u32>(max(floor(next / (2.0 * scale)), vec2<f32>(0.0))) != (cell >> vec2<u32>(1u)));
            let up = select(level, min(level + 1u, top), parent_changes);
            if max(z0, z1) <= mm.x + P.bias {
                lit += t_exit - t;
                t = t_exit;
                level = up;
            } else if min(z0, z1) > mm.y + P.bias {
                t = t_exit;
                level = up;
            } else if level == 0u {
                lit += lit_part(t, t_exit, z0, z1, mm.x + P.bias);
                t = t_exit;
            } else if level <= P.min_level {
                // Quality knob: estimate a mixed block instead of refining it, taking its
                // occluder depth as spread evenly over [min, max].
                let zm = 0.5 * (z0 + z1);
                lit += (t_exit - t) * clamp((mm.y + P.bias - zm) / max(mm.y - mm.x, 1e-6), 0.0, 1.0);
                t = t_exit;
                level = up;
            } else {
                level -= 1u;
            }
        }
        // Safety net for pathological rays: sample what is left.
        if t < tout {
            let n = 64u;
            for (var i = 0u; i < n; i++) {
                let ti = t + (f32(i) + 0.5) / f32(n) * (tout - t);
                lit += visible(P.eye + dir * ti) * (tout - t) / f32(n);
            }
        }
    }
    let vbar = select(1.0, clamp(lit / s, 0.0, 1.0), s > 0.0);
    let k = P.sigma_t * P.albedo * henyey_greenstein(P.g, dot(dir, P.to_sun)) * transmittance_integral(s, P.sigma_t) * vbar;
    textureStore(out_vis, id.xy, vec4<f32>(vbar, 0.0, 0.0, 1.0));
    textureStore(out_inscatter, id.xy, vec4<f32>(P.radiance * k, 1.0));
    textureStore(out_transmittance, id.xy, vec4<f32>(exp(-s * P.sigma_t), 0.0, 0.0, 1.0));
}
