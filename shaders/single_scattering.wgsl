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
    box_min: vec3<f32>,
    bounded: u32,
    box_max: vec3<f32>,
    light_extinction: u32,
    phase_width: u32,
    soft_slices: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var shadow: texture_2d<f32>;
@group(0) @binding(2) var depth: texture_2d<f32>;
@group(0) @binding(3) var out_vis: texture_storage_2d<r32float, write>;
@group(0) @binding(4) var out_inscatter: texture_storage_2d<rgba32float, write>;
@group(0) @binding(5) var out_transmittance: texture_storage_2d<r32float, write>;
@group(0) @binding(13) var phase_table: texture_2d<f32>;

struct SoftView {
    view_proj: mat4x4<f32>,
}

@group(0) @binding(14) var soft_volume: texture_3d<f32>;
@group(0) @binding(15) var<uniform> SV: SoftView;

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

// The phase function per channel: the connected table (linear between texel centres θ_i =
// π (i + 0.5)/W, clamped at the ends) or Henyey–Greenstein g.
fn phase(cos_theta: f32) -> vec3<f32> {
    if P.phase_width == 0u {
        return vec3<f32>(henyey_greenstein(P.g, cos_theta));
    }
    let w = f32(P.phase_width);
    let x = clamp(acos(clamp(cos_theta, -1.0, 1.0)) / PI * w - 0.5, 0.0, w - 1.0);
    let i0 = u32(floor(x));
    let i1 = min(i0 + 1u, P.phase_width - 1u);
    let f = x - f32(i0);
    let a = textureLoad(phase_table, vec2<u32>(i0, 0u), 0).rgb;
    let b = textureLoad(phase_table, vec2<u32>(i1, 0u), 0).rgb;
    return mix(a, b, f);
}

// Visibility from a SoftVisibility volume: 1 − A at the nearest light texel, A linear between
// the slices' far ends (0 at light depth 0).
fn soft_visible(x: vec3<f32>) -> f32 {
    let c = SV.view_proj * vec4<f32>(x, 1.0);
    let uvz = vec3<f32>(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z);
    if uvz.x < 0.0 || uvz.x >= 1.0 || uvz.y < 0.0 || uvz.y >= 1.0 || uvz.z < 0.0 || uvz.z > 1.0 {
        return 1.0;
    }
    let dims = textureDimensions(soft_volume);
    let t = min(vec2<u32>(uvz.xy * vec2<f32>(dims.xy)), dims.xy - 1u);
    let p = uvz.z * f32(P.soft_slices) - 1.0;
    let k0 = floor(p);
    let f = p - k0;
    var a0 = 0.0;
    if k0 >= 0.0 {
        a0 = textureLoad(soft_volume, vec3<u32>(t, u32(k0)), 0).r;
    }
    let k1 = min(u32(max(k0 + 1.0, 0.0)), P.soft_slices - 1u);
    let a1 = textureLoad(soft_volume, vec3<u32>(t, k1), 0).r;
    return 1.0 - mix(a0, a1, f);
}

fn visible(x: vec3<f32>) -> f32 {
    if P.soft_slices != 0u {
        return soft_visible(x);
    }
    let c = P.light_view_proj * vec4<f32>(x, 1.0);
    let uvz = vec3<f32>(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z);
    if uvz.x < 0.0 || uvz.x >= 1.0 || uvz.y < 0.0 || uvz.y >= 1.0 || uvz.z < 0.0 || uvz.z > 1.0 {
        return 1.0;
    }
    let size = vec2<f32>(textureDimensions(shadow));
    let texel = min(vec2<u32>(uvz.xy * size), vec2<u32>(size) - 1u);
    return select(0.0, 1.0, uvz.z <= textureLoad(shadow, texel, 0).r + P.bias);
}

// ---- The medium's extent along a view ray, and the weight of each stretch of it -----------
//
// Unbounded (`bounded` = 0), the medium fills [0, s]. Bounded, it is the box [box_min, box_max]
// and the view ray scatters on [t0, t1] = [0, s] ∩ the box. A point at distance t contributes
// with weight E(t) = e^{−σt (t − t0)} · e^{−σt ℓ(t)}: the view ray's transmittance from where it
// entered the medium, and (light extinction on) the sun's transmittance over ℓ(t), the distance
// from the point to the box's boundary towards the sun. In the box ℓ(t) is the smallest of three
// linear functions of t (one per face the sun shines through), so E is the exponential of a
// piecewise-linear function and its integral over any stretch is exact, piece by piece.

// [t0, t1]: the part of [0, s] inside the medium (t1 ≤ t0 when the ray misses it).
fn medium_segment(dir: vec3<f32>, s: f32) -> vec2<f32> {
    if P.bounded == 0u {
        return vec2<f32>(0.0, s);
    }
    var t0 = 0.0;
    var t1 = s;
    for (var k = 0; k < 3; k++) {
        if dir[k] == 0.0 {
            if P.eye[k] < P.box_min[k] || P.eye[k] > P.box_max[k] {
                return vec2<f32>(0.0, -1.0);
            }
        } else {
            let ta = (P.box_min[k] - P.eye[k]) / dir[k];
            let tb = (P.box_max[k] - P.eye[k]) / dir[k];
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    return vec2<f32>(t0, t1);
}

// ℓ along the ray through face k (the face the sun shines through on axis k): ℓ_k(t) = α + β t.
// An axis the sun is parallel to never limits ℓ (a huge α).
fn light_line(dir: vec3<f32>, k: i32) -> vec2<f32> {
    let sk = P.to_sun[k];
    if abs(sk) < 1e-12 {
        return vec2<f32>(3.0e38, 0.0);
    }
    let face = select(P.box_min[k], P.box_max[k], sk > 0.0);
    return vec2<f32>((face - P.eye[k]) / sk, -dir[k] / sk);
}

// (1 − e^{−len·m})/m for m ≥ 0, accurate for the short stretches the weights integrate: the
// series below x = len·m = 0.5 (truncation < 2e-7 relative), so 1 − e^{−x} never cancels
// against the driver's exp.
fn decay_integral(len: f32, m: f32) -> f32 {
    let x = len * m;
    if x < 0.5 {
        return len * (1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0 * (1.0 - x / 7.0))))));
    }
    return (1.0 - exp(-x)) / m;
}

// ℓ at distance t along the view ray, from the point itself (the lines above carry terms of
// order 1/|sun_k|, which cancel badly in f32 when the sun is nearly parallel to a face).
fn light_exit(dir: vec3<f32>, t: f32) -> f32 {
    let q = P.eye + dir * t;
    var ell = 3.0e38;
    for (var k = 0; k < 3; k++) {
        let sk = P.to_sun[k];
        if abs(sk) >= 1e-12 {
            let face = select(P.box_min[k], P.box_max[k], sk > 0.0);
            ell = min(ell, (face - q[k]) / sk);
        }
    }
    return max(ell, 0.0);
}

// ∫_a^b e^{−m (t − a)} dt for m of either sign, from the end where the exponent is largest, so
// nothing overflows: returns (integral relative to E at that end, which end: 0 = a, 1 = b).
fn exp_segment(len: f32, m: f32) -> vec2<f32> {
    if m >= 0.0 {
        return vec2<f32>(decay_integral(len, m), 0.0);
    }
    return vec2<f32>(decay_integral(len, -m), 1.0);
}

// ∫_a^b E(t) dt over a stretch [a, b] of [t0, t1] (see above).
fn weight(dir: vec3<f32>, t0: f32, a: f32, b: f32) -> f32 {
    if b <= a {
        return 0.0;
    }
    let sig = P.sigma_t;
    if P.light_extinction == 0u {
        return exp(-sig * (a - t0)) * decay_integral(b - a, sig);
    }
    let l0 = light_line(dir, 0);
    let l1 = light_line(dir, 1);
    let l2 = light_line(dir, 2);
    // Where two of the lines cross inside (a, b), ℓ may switch lines: split there.
    // cuts[0] = a, the crossings at cuts[1 … n], then b.
    var cuts = array<f32, 5>(a, b, b, b, b);
    var n = 0;
    let lines = array<vec2<f32>, 3>(l0, l1, l2);
    for (var i = 0; i < 3; i++) {
        for (var j = i + 1; j < 3; j++) {
            let db = lines[i].y - lines[j].y;
            if db != 0.0 {
                let tc = (lines[j].x - lines[i].x) / db;
                if tc > a && tc < b {
                    n += 1;
                    cuts[n] = tc;
                }
            }
        }
    }
    // Sort the (at most three) crossings, then integrate each piece on its own line.
    for (var i = 1; i <= n; i++) {
        for (var j = i + 1; j <= n; j++) {
            if cuts[j] < cuts[i] {
                let tmp = cuts[i];
                cuts[i] = cuts[j];
                cuts[j] = tmp;
            }
        }
    }
    cuts[n + 1] = b;
    var total = 0.0;
    for (var i = 0; i <= n; i++) {
        let p0 = cuts[i];
        let p1 = cuts[i + 1];
        if p1 <= p0 {
            continue;
        }
        let mid = 0.5 * (p0 + p1);
        var line = l0;
        if l1.x + l1.y * mid < line.x + line.y * mid {
            line = l1;
        }
        if l2.x + l2.y * mid < line.x + line.y * mid {
            line = l2;
        }
        let seg = exp_segment(p1 - p0, sig * (1.0 + line.y));
        let at = select(p0, p1, seg.y > 0.5);
        let e = exp(-sig * ((at - t0) + light_exit(dir, at)));
        total += e * seg.x;
    }
    return total;
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
    let uv = vec2<f32>(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5);
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
// ray (moved by the per-pixel jitter). With a light map (LM.enabled) each lit sample adds its
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
    let offset = P.jitter * (hash(id.x, id.y) - 0.5);
    let map = LM.enabled != 0u;
    var lit = 0.0;
    var weighted = 0.0;
    var acc = vec3<f32>(0.0);
    for (var i = 0u; i < P.steps; i++) {
        let t = t0 + (f32(i) + 0.5 + offset) / f32(P.steps) * len;
        let x = P.eye + dir * t;
        let v = visible(x);
        lit += v;
        if v > 0.0 && (map || P.light_extinction != 0u) {
            // Sample i stands for its interval of the segment.
            let a = t0 + f32(i) / f32(P.steps) * len;
            let b = t0 + f32(i + 1u) / f32(P.steps) * len;
            let w = weight(dir, t0, a, b);
            weighted += w;
            if map {
                acc += w * light_map_at(x);
            }
        }
    }
    let vbar = select(1.0, lit / f32(P.steps), len > 0.0 || P.bounded == 0u);
    if map {
        let base = P.sigma_t * P.albedo * phase(dot(dir, P.to_sun));
        textureStore(out_vis, id.xy, vec4<f32>(vbar, 0.0, 0.0, 1.0));
        textureStore(out_inscatter, id.xy, vec4<f32>(P.radiance * base * acc, 1.0));
        textureStore(out_transmittance, id.xy, vec4<f32>(exp(-len * P.sigma_t), 0.0, 0.0, 1.0));
    } else {
        store(id.xy, dir, vbar, len, weighted);
    }
}

// Write the outputs of one pixel. Light extinction off: the seed's factored form (eq. 2),
// σt ρ f · (1 − e^{−Lσt})/σt · V̄ over the medium's length L on the ray; on: σt ρ f · ∫ V E dt.
fn store(p: vec2<u32>, dir: vec3<f32>, vbar: f32, len: f32, weighted: f32) {
    let base = P.sigma_t * P.albedo * phase(dot(dir, P.to_sun));
    var k = base * transmittance_integral(len, P.sigma_t) * vbar;
    if P.light_extinction != 0u {
        k = base * weighted;
    }
    textureStore(out_vis, p, vec4<f32>(vbar, 0.0, 0.0, 1.0));
    textureStore(out_inscatter, p, vec4<f32>(P.radiance * k, 1.0));
    textureStore(out_transmittance, p, vec4<f32>(exp(-len * P.sigma_t), 0.0, 0.0, 1.0));
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

// The MinMax traversal of one view ray (direction `dir`, surface at `s`): (V̄, medium length,
// extinction-weighted lit integral).
fn min_max_ray(dir: vec3<f32>, s: f32) -> vec3<f32> {
    let seg = medium_segment(dir, s);
    let t0 = seg.x;
    let t1 = max(seg.y, seg.x);
    let ext = P.light_extinction != 0u;
    let msize = vec2<f32>(textureDimensions(shadow));
    // The ray in level-0 texel units and light depth: p(t) = a + d t.
    let c0 = P.light_view_proj * vec4<f32>(P.eye, 1.0);
    let c1 = P.light_view_proj * vec4<f32>(P.eye + dir, 1.0);
    let a = vec3<f32>((c0.x * 0.5 + 0.5) * msize.x, (0.5 - c0.y * 0.5) * msize.y, c0.z);
    let d = vec3<f32>((c1.x - c0.x) * 0.5 * msize.x, -(c1.y - c0.y) * 0.5 * msize.y, c1.z - c0.z);
    // Clip [t0, t1] to the map and the light box; the rest of the ray is lit.
    var tin = t0;
    var tout = t1;
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
    var lit = t1 - t0;
    var weighted = 0.0;
    if ext {
        weighted = weight(dir, t0, t0, t1);
    }
    if tout > tin {
        lit = (t1 - t0) - (tout - tin);
        if ext {
            weighted = weight(dir, t0, t0, tin) + weight(dir, t0, tout, t1);
        }
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
                if ext {
                    weighted += weight(dir, t0, t, t_exit);
                }
                t = t_exit;
                level = up;
            } else if min(z0, z1) > mm.y + P.bias {
                t = t_exit;
                level = up;
            } else if level == 0u {
                let part = lit_part(t, t_exit, z0, z1, mm.x + P.bias);
                lit += part;
                if ext {
                    // The lit part is at the end where the depth is under the occluder.
                    if z0 <= mm.x + P.bias {
                        weighted += weight(dir, t0, t, t + part);
                    } else {
                        weighted += weight(dir, t0, t_exit - part, t_exit);
                    }
                }
                t = t_exit;
            } else if level <= P.min_level {
                // Quality knob: estimate a mixed block instead of refining it, taking its
                // occluder depth as spread evenly over [min, max].
                let zm = 0.5 * (z0 + z1);
                let frac = clamp((mm.y + P.bias - zm) / max(mm.y - mm.x, 1e-6), 0.0, 1.0);
                lit += (t_exit - t) * frac;
                if ext {
                    weighted += weight(dir, t0, t, t_exit) * frac;
                }
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
                let v = visible(P.eye + dir * ti);
                lit += v * (tout - t) / f32(n);
                if ext && v > 0.0 {
                    let a = t + f32(i) / f32(n) * (tout - t);
                    weighted += weight(dir, t0, a, a + (tout - t) / f32(n));
                }
            }
        }
    }
    let len = t1 - t0;
    let vbar = select(1.0, clamp(lit / len, 0.0, 1.0), len > 0.0);
    return vec3<f32>(vbar, len, weighted);
}

@compute @workgroup_size(8, 8)
fn min_max(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
    let r = min_max_ray(dir, textureLoad(depth, id.xy, 0).r);
    store(id.xy, dir, r.x, r.y, r.z);
}
