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

// Pipeline constants, set by the node for each dispatch (the defaults keep every path): whether
// light extinction, a light map and a soft visibility volume can be on. With one off, its code is compiled away; a SIMD
// driver (lavapipe) otherwise steps through it, masked, in every loop iteration.
override EXTINCTION: bool = true;
override LIGHT_MAP: bool = true;
override SOFT: bool = true;

// Light extinction on (the pipeline allows it and the uniforms ask for it).
fn extinction() -> bool {
    return EXTINCTION && P.light_extinction != 0u;
}

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
    if SOFT && P.soft_slices != 0u {
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

// Where lines i and j of ℓ cross inside (a, b); b when they do not.
fn crossing(li: vec2<f32>, lj: vec2<f32>, a: f32, b: f32) -> f32 {
    let db = li.y - lj.y;
    if db != 0.0 {
        let tc = (lj.x - li.x) / db;
        if tc > a && tc < b {
            return tc;
        }
    }
    return b;
}

// ∫_{p0}^{p1} E(t) dt over a piece on which ℓ follows one line (the lowest at its middle).
fn weight_piece(dir: vec3<f32>, t0: f32, l0: vec2<f32>, l1: vec2<f32>, l2: vec2<f32>, p0: f32, p1: f32) -> f32 {
    if p1 <= p0 {
        return 0.0;
    }
    let mid = 0.5 * (p0 + p1);
    var line = l0;
    if l1.x + l1.y * mid < line.x + line.y * mid {
        line = l1;
    }
    if l2.x + l2.y * mid < line.x + line.y * mid {
        line = l2;
    }
    let seg = exp_segment(p1 - p0, P.sigma_t * (1.0 + line.y));
    let at = select(p0, p1, seg.y > 0.5);
    return exp(-P.sigma_t * ((at - t0) + light_exit(dir, at))) * seg.x;
}

// ∫_a^b E(t) dt over a stretch [a, b] of [t0, t1] (see above). With light extinction, ℓ may
// switch lines where two of them cross inside (a, b): the (at most three) crossings, sorted,
// cut [a, b] into pieces integrated on their own line. (No local arrays: lavapipe gives
// function-local arrays stack space per inlined call, and a loop calling this from several
// places overflowed its stack.)
fn weight(dir: vec3<f32>, t0: f32, a: f32, b: f32) -> f32 {
    if b <= a {
        return 0.0;
    }
    let sig = P.sigma_t;
    if !extinction() {
        return exp(-sig * (a - t0)) * decay_integral(b - a, sig);
    }
    let l0 = light_line(dir, 0);
    let l1 = light_line(dir, 1);
    let l2 = light_line(dir, 2);
    let c0 = crossing(l0, l1, a, b);
    let c1 = crossing(l0, l2, a, b);
    let c2 = crossing(l1, l2, a, b);
    let s0 = min(c0, c1);
    let s1 = max(c0, c1);
    let m0 = min(s1, c2);
    let hi = max(s1, c2);
    let lo = min(s0, m0);
    let mid = max(s0, m0);
    return weight_piece(dir, t0, l0, l1, l2, a, lo) + weight_piece(dir, t0, l0, l1, l2, lo, mid)
        + weight_piece(dir, t0, l0, l1, l2, mid, hi) + weight_piece(dir, t0, l0, l1, l2, hi, b);
}

// Unit direction of the view ray through the screen point `q` (pixels, continuous, y down) of
// a `size` image.
fn screen_ray(q: vec2<f32>, size: vec2<u32>) -> vec3<f32> {
    let ndc = vec4<f32>(q.x / f32(size.x) * 2.0 - 1.0, 1.0 - q.y / f32(size.y) * 2.0, 1.0, 1.0);
    let far = P.inv_view_proj * ndc;
    let dir = far.xyz / far.w - P.eye;
    return select(vec3<f32>(0.0, 0.0, -1.0), normalize(dir), dot(dir, dir) > 0.0);
}

// Unit direction of the view ray through the centre of pixel `p` of a `size` image.
fn view_ray(p: vec2<u32>, size: vec2<u32>) -> vec3<f32> {
    return screen_ray(vec2<f32>(p) + 0.5, size);
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
    let map = LIGHT_MAP && LM.enabled != 0u;
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
    if extinction() {
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

// A view ray in the map's texel units and light depth, p(t) = a + d t, its medium segment
// [t0, t1] and the part [tin, tout] of it inside the map and the light box (tout ≤ tin: none);
// the rest of the segment is lit.
struct MapRay {
    a: vec3<f32>,
    d: vec3<f32>,
    t0: f32,
    t1: f32,
    tin: f32,
    tout: f32,
}

fn map_ray(dir: vec3<f32>, s: f32) -> MapRay {
    let seg = medium_segment(dir, s);
    let msize = vec2<f32>(textureDimensions(shadow));
    let c0 = P.light_view_proj * vec4<f32>(P.eye, 1.0);
    let c1 = P.light_view_proj * vec4<f32>(P.eye + dir, 1.0);
    var r: MapRay;
    r.a = vec3<f32>((c0.x * 0.5 + 0.5) * msize.x, (0.5 - c0.y * 0.5) * msize.y, c0.z);
    r.d = vec3<f32>((c1.x - c0.x) * 0.5 * msize.x, -(c1.y - c0.y) * 0.5 * msize.y, c1.z - c0.z);
    r.t0 = seg.x;
    r.t1 = max(seg.y, seg.x);
    r.tin = r.t0;
    r.tout = r.t1;
    let hi = vec3<f32>(msize, 1.0);
    for (var k = 0; k < 3; k++) {
        if abs(r.d[k]) < 1e-12 {
            if r.a[k] < 0.0 || r.a[k] > hi[k] {
                r.tout = -1.0;
            }
        } else {
            let ta = (0.0 - r.a[k]) / r.d[k];
            let tb = (hi[k] - r.a[k]) / r.d[k];
            r.tin = max(r.tin, min(ta, tb));
            r.tout = min(r.tout, max(ta, tb));
        }
    }
    return r;
}

// (V̄, medium length, lit weight) of a ray from the lit length and weight found inside the map.
fn ray_result(r: MapRay, dir: vec3<f32>, lit_inside: f32, weighted_inside: f32) -> vec3<f32> {
    let len = r.t1 - r.t0;
    let ext = extinction();
    var lit = len;
    var weighted = 0.0;
    if ext {
        weighted = weight(dir, r.t0, r.t0, r.t1);
    }
    if r.tout > r.tin {
        lit = len - (r.tout - r.tin) + lit_inside;
        if ext {
            weighted = weight(dir, r.t0, r.t0, r.tin) + weight(dir, r.t0, r.tout, r.t1) + weighted_inside;
        }
    }
    let vbar = select(1.0, clamp(lit / len, 0.0, 1.0), len > 0.0);
    return vec3<f32>(vbar, len, weighted);
}

// The MinMax traversal of one view ray (direction `dir`, surface at `s`): (V̄, medium length,
// extinction-weighted lit integral).
fn min_max_ray(dir: vec3<f32>, s: f32) -> vec3<f32> {
    let r = map_ray(dir, s);
    let a = r.a;
    let d = r.d;
    let t0 = r.t0;
    let tout = r.tout;
    let ext = extinction();
    let msize = vec2<f32>(textureDimensions(shadow));
    var lit = 0.0;
    var weighted = 0.0;
    if tout > r.tin {
        let top = L.count;
        var level = top;
        var t = r.tin;
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
    return ray_result(r, dir, lit, weighted);
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

// ---- Method Epipolar: epipolar sampling with 1D min-max trees (see the node's doc) ----------
//
// The slice table (width = slices): row 0 (entry.xy, dir.xy) of the slice's screen segment,
// row 1 (length, chord), row 2 (origin.xy, direction.xy) of its line in the map (texels). The
// trees: row k of `tree` holds 2n entries (min, max), level j (n/2^j wide) at 2n − 2n/2^j.

struct Epi {
    epipole: vec2<f32>,
    u_start: f32,
    arc: f32,
    size: vec2<f32>,
    slices: u32,
    samples: u32,
    inside: u32,
    tree_n: u32,
    tree_top: u32,
    tree_level: u32,
    threshold: f32,
    // Level being built (epi_tree); number of listed pixels (epi_fallback).
    level: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(16) var<uniform> E: Epi;
@group(0) @binding(17) var slice_table: texture_2d<f32>;
@group(0) @binding(18) var<storage, read_write> tree: array<vec2<f32>>;
@group(0) @binding(19) var out_samples: texture_storage_2d<rgba32float, write>;
@group(0) @binding(20) var samples_in: texture_2d<f32>;

// Depth of texels outside the map and of leaves past a chord's end: always lit.
const FAR_DEPTH: f32 = 3.0e38;
// Texels one leaf's stretch of a ray can cross (three, and one for rounding left-overs).
const LEAF_CELLS: u32 = 4u;

// The map's depth at the texel whose corner is `cell` (floored texel coordinates).
fn map_depth(cell: vec2<f32>) -> f32 {
    let size = vec2<f32>(textureDimensions(shadow));
    if !(cell.x >= 0.0 && cell.y >= 0.0 && cell.x < size.x && cell.y < size.y) {
        return FAR_DEPTH;
    }
    let t = min(vec2<u32>(cell), vec2<u32>(size) - 1u);
    return textureLoad(shadow, t, 0).r;
}

// Leaf i of slice k: (min, max) depth over the texels the slice's map line crosses between
// distances i and i + 1 from its origin, walked texel by texel.
@compute @workgroup_size(8, 8)
fn epi_rectify(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= E.tree_n || id.y >= E.slices {
        return;
    }
    let chord = textureLoad(slice_table, vec2<u32>(id.y, 1u), 0).y;
    let line = textureLoad(slice_table, vec2<u32>(id.y, 2u), 0);
    var leaf = vec2<f32>(FAR_DEPTH);
    let i = f32(id.x);
    if i < chord {
        let d = line.zw;
        let start = line.xy + d * i;
        let len = min(chord - i, 1.0);
        let nudge = sign(d) * 1e-4;
        var mn = FAR_DEPTH;
        var mx = -FAR_DEPTH;
        var t = 0.0;
        for (var it = 0; it < 4; it++) {
            if t >= len {
                break;
            }
            let cell = floor(start + d * t + nudge);
            var te = len;
            for (var k = 0; k < 2; k++) {
                if d[k] > 1e-9 {
                    te = min(te, (cell[k] + 1.0 - start[k]) / d[k]);
                } else if d[k] < -1e-9 {
                    te = min(te, (cell[k] - start[k]) / d[k]);
                }
            }
            let z = map_depth(cell);
            mn = min(mn, z);
            mx = max(mx, z);
            t = max(te, t + 1e-4);
        }
        leaf = vec2<f32>(mn, mx);
    }
    tree[id.y * 2u * E.tree_n + id.x] = leaf;
}

// Level E.level of every slice's tree from the level below.
@compute @workgroup_size(8, 8)
fn epi_tree(@builtin(global_invocation_id) id: vec3<u32>) {
    let width = E.tree_n >> E.level;
    if id.x >= width || id.y >= E.slices {
        return;
    }
    let row = id.y * 2u * E.tree_n;
    let src = row + 2u * E.tree_n - 4u * width;
    let dst = row + 2u * E.tree_n - 2u * width;
    let a = tree[src + 2u * id.x];
    let b = tree[src + 2u * id.x + 1u];
    tree[dst + id.x] = vec2<f32>(min(a.x, b.x), max(a.y, b.y));
}

// Lit length and lit weight of the stretch [from, to] of a ray, texel by texel (at most
// `max_cells` texels; the last one taken takes the rest of the stretch).
fn texel_walk(r: MapRay, dir: vec3<f32>, t_from: f32, t_to: f32, max_cells: u32) -> vec2<f32> {
    let nudge = sign(r.d.xy) * 1e-3;
    var lit = 0.0;
    var weighted = 0.0;
    var t = t_from;
    let ext = extinction();
    for (var i = 0u; i < max_cells; i++) {
        if t >= t_to {
            break;
        }
        let q = r.a + r.d * t;
        let cell = floor(q.xy + nudge);
        var te = t_to;
        if i + 1u < max_cells {
            for (var k = 0; k < 2; k++) {
                if r.d[k] > 1e-12 {
                    te = min(te, (cell[k] + 1.0 - r.a[k]) / r.d[k]);
                } else if r.d[k] < -1e-12 {
                    te = min(te, (cell[k] - r.a[k]) / r.d[k]);
                }
            }
        }
        te = max(te, t);
        let c = map_depth(cell) + P.bias;
        let z0 = r.a.z + r.d.z * t;
        let z1 = r.a.z + r.d.z * te;
        let part = lit_part(t, te, z0, z1, c);
        lit += part;
        if ext {
            if z0 <= c {
                weighted += weight(dir, r.t0, t, t + part);
            } else {
                weighted += weight(dir, r.t0, te - part, te);
            }
        }
        t = select(t_to, te, te > t);
    }
    return vec2<f32>(lit, weighted);
}

// Visibility of a sample ray of slice k through the slice's min-max tree (`line`: the slice's
// map line): (V̄, medium length, lit weight). The walk is MinMax's, in one dimension: the ray's
// position along the line, b(t) = b0 + bd t, and its light depth are affine in t.
fn tree_ray(k: u32, line: vec4<f32>, dir: vec3<f32>, s: f32) -> vec3<f32> {
    let r = map_ray(dir, s);
    if r.tout <= r.tin {
        return ray_result(r, dir, 0.0, 0.0);
    }
    let b0 = dot(r.a.xy - line.xy, line.zw);
    let bd = dot(r.d.xy, line.zw);
    let nudge = select(-1e-3, 1e-3, bd > 0.0);
    let n = E.tree_n;
    let top = E.tree_top;
    let coarse = E.tree_level;
    let row = k * 2u * n;
    let ext = extinction();
    var level = top;
    var t = r.tin;
    var iter = 0u;
    var lit = 0.0;
    var weighted = 0.0;
    while t < r.tout && iter < MAX_ITER {
        iter++;
        let scale = f32(1u << level);
        let width = n >> level;
        let idx = min(u32(max(floor((b0 + bd * t + nudge) / scale), 0.0)), width - 1u);
        let lo = f32(idx) * scale;
        let hi = f32(idx + 1u) * scale;
        var t_exit = r.tout;
        if bd > 1e-12 {
            t_exit = min(t_exit, (hi - b0) / bd);
        } else if bd < -1e-12 {
            t_exit = min(t_exit, (lo - b0) / bd);
        }
        t_exit = max(t_exit, t);
        let z0 = r.a.z + r.d.z * t;
        let z1 = r.a.z + r.d.z * t_exit;
        let mm = tree[row + 2u * n - 2u * width + idx];
        let next = u32(max(floor((b0 + bd * t_exit + nudge) / (2.0 * scale)), 0.0));
        let up = select(level, min(level + 1u, top), next != (idx >> 1u));
        // What this node settles: the lit stretch [t, lit_end] (times `share`), or a walk over
        // the leaf's own texels; then the next position and level. One `weight` and one
        // `texel_walk` per iteration (several inlined copies in this loop crashed lavapipe's
        // shader compiler).
        var lit_end = t;
        var share = 0.0;
        var walk = false;
        var t_next = t_exit;
        var next_level = up;
        let lit_all = max(z0, z1) <= mm.x + P.bias;
        let dark_all = min(z0, z1) > mm.y + P.bias;
        if lit_all || dark_all || (level > 0u && level <= coarse) {
            // Settled: lit, shadowed, or (quality knob) a mixed node estimated with its
            // occluder depth spread evenly over [min, max].
            let zm = 0.5 * (z0 + z1);
            let estimate = clamp((mm.y + P.bias - zm) / max(mm.y - mm.x, 1e-6), 0.0, 1.0);
            share = select(select(estimate, 0.0, dark_all), 1.0, lit_all);
            lit_end = t_exit;
        } else if level == 0u {
            walk = true;
            next_level = level;
        } else {
            t_next = t;
            next_level = level - 1u;
        }
        if walk {
            let w = texel_walk(r, dir, t, t_exit, LEAF_CELLS);
            lit += w.x;
            weighted += w.y;
        }
        lit += (lit_end - t) * share;
        // `ext` is false at compile time when the pipeline constant EXTINCTION is off.
        if ext {
            if lit_end > t && share > 0.0 {
                weighted += weight(dir, r.t0, t, lit_end) * share;
            }
        }
        t = t_next;
        level = next_level;
    }
    if t < r.tout {
        let w = texel_walk(r, dir, t, r.tout, MAX_ITER);
        lit += w.x;
        weighted += w.y;
    }
    return ray_result(r, dir, lit, weighted);
}

// The lit share of a ray's weight (1 when it is 0 or light extinction is off).
fn lit_fraction(dir: vec3<f32>, len: f32, weighted: f32, s: f32) -> f32 {
    if !extinction() {
        return 1.0;
    }
    let t0 = medium_segment(dir, s).x;
    let full = weight(dir, t0, t0, t0 + len);
    if full > 0.0 {
        return clamp(weighted / full, 0.0, 1.0);
    }
    return 1.0;
}

// Sample (id.x) of slice (id.y): (V̄, lit fraction of the weight, camera depth, medium length).
@compute @workgroup_size(8, 8)
fn epi_sample(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= E.samples || id.y >= E.slices {
        return;
    }
    let seg = textureLoad(slice_table, vec2<u32>(id.y, 0u), 0);
    let lengths = textureLoad(slice_table, vec2<u32>(id.y, 1u), 0);
    let line = textureLoad(slice_table, vec2<u32>(id.y, 2u), 0);
    let f = f32(id.x) / f32(max(E.samples - 1u, 1u));
    let q = seg.xy + seg.zw * (lengths.x * f);
    let size = textureDimensions(depth);
    let px = min(vec2<u32>(max(floor(q), vec2<f32>(0.0))), size - 1u);
    let s = textureLoad(depth, px, 0).r;
    let dir = screen_ray(q, size);
    let res = tree_ray(id.y, line, dir, s);
    let frac = lit_fraction(dir, res.y, res.z, s);
    textureStore(out_samples, id.xy, vec4<f32>(res.x, frac, s, res.y));
}

// The border coordinate where the ray pc + r t, t > 0, from a point on the screen leaves it
// (0 top-left corner, clockwise, one unit per edge).
fn border_coordinate(pc: vec2<f32>, r: vec2<f32>) -> f32 {
    var tx = 3.0e38;
    var ty = 3.0e38;
    if r.x > 1e-9 {
        tx = (E.size.x - pc.x) / r.x;
    } else if r.x < -1e-9 {
        tx = -pc.x / r.x;
    }
    if r.y > 1e-9 {
        ty = (E.size.y - pc.y) / r.y;
    } else if r.y < -1e-9 {
        ty = -pc.y / r.y;
    }
    if tx <= ty {
        let y = clamp((pc.y + r.y * tx) / E.size.y, 0.0, 1.0);
        return select(4.0 - y, 1.0 + y, r.x > 0.0);
    }
    let x = clamp((pc.x + r.x * ty) / E.size.x, 0.0, 1.0);
    return select(3.0 - x, x, r.y < 0.0);
}

// The pixel centred at pc (camera depth s, medium length len) from the samples of the two
// slices around its line through the epipole, bilinearly, leaving out samples farther than the
// threshold in depth or medium length: (V̄, lit fraction, 1), or (0, 0, 0) when none is usable.
fn epi_interpolate(pc: vec2<f32>, s: f32, len: f32) -> vec3<f32> {
    let rv = pc - E.epipole;
    if dot(rv, rv) < 1e-6 {
        return vec3<f32>(0.0);
    }
    let u = border_coordinate(pc, normalize(rv));
    let count = E.slices;
    var rel = u - E.u_start;
    if rel < 0.0 {
        rel += 4.0;
    }
    var f = rel / E.arc * f32(count) - 0.5;
    var k0: u32;
    var k1: u32;
    var wk: f32;
    if E.inside != 0u {
        if f < 0.0 {
            f += f32(count);
        }
        k0 = min(u32(max(floor(f), 0.0)), count - 1u);
        wk = clamp(f - f32(k0), 0.0, 1.0);
        k1 = (k0 + 1u) % count;
    } else {
        f = clamp(f, 0.0, f32(count - 1u));
        k0 = min(u32(floor(f)), count - 1u);
        wk = f - f32(k0);
        k1 = min(k0 + 1u, count - 1u);
    }
    let m = E.samples;
    var total = 0.0;
    var acc = vec2<f32>(0.0);
    for (var side = 0u; side < 2u; side++) {
        let k = select(k0, k1, side == 1u);
        let wslice = select(1.0 - wk, wk, side == 1u);
        let seg = textureLoad(slice_table, vec2<u32>(k, 0u), 0);
        let slen = textureLoad(slice_table, vec2<u32>(k, 1u), 0).x;
        let along = dot(pc - seg.xy, seg.zw);
        var j = 0.0;
        if slen > 1e-6 {
            j = clamp(along / slen * f32(m - 1u), 0.0, f32(m - 1u));
        }
        let j0 = min(u32(floor(j)), m - 1u);
        let j1 = min(j0 + 1u, m - 1u);
        let wj = j - f32(j0);
        for (var q = 0u; q < 2u; q++) {
            let jj = select(j0, j1, q == 1u);
            let wt = wslice * select(1.0 - wj, wj, q == 1u);
            let v = textureLoad(samples_in, vec2<u32>(jj, k), 0);
            let near = abs(v.z - s) <= E.threshold * abs(s) && abs(v.w - len) <= E.threshold * len;
            if near && wt > 0.0 {
                total += wt;
                acc += wt * v.xy;
            }
        }
    }
    if total > 1e-6 {
        return vec3<f32>(acc / total, 1.0);
    }
    return vec3<f32>(0.0);
}

@group(0) @binding(21) var<storage, read_write> fallback: array<u32>;
@group(0) @binding(22) var<storage, read_write> fallback_count: array<atomic<u32>>;

// Every pixel interpolated from the samples; one with no usable sample is appended to the
// fall-back list (its own ray is traced by `epi_fallback`: kept out of this pass, whose SIMD
// lanes would otherwise all step through the MinMax walk's code masked).
@compute @workgroup_size(8, 8)
fn epi_gather(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let dir = view_ray(id.xy, size);
    let s = textureLoad(depth, id.xy, 0).r;
    let seg = medium_segment(dir, s);
    let len = max(seg.y - seg.x, 0.0);
    let got = epi_interpolate(vec2<f32>(id.xy) + 0.5, s, len);
    if got.z > 0.5 {
        var weighted = 0.0;
        if extinction() {
            weighted = got.y * weight(dir, seg.x, seg.x, seg.x + len);
        }
        store(id.xy, dir, got.x, len, weighted);
    } else {
        let slot = atomicAdd(&fallback_count[0], 1u);
        fallback[min(slot, arrayLength(&fallback) - 1u)] = id.y * size.x + id.x;
    }
}

// The listed pixels (E.level of them, 256 per row of the dispatch) trace their own MinMax ray.
@compute @workgroup_size(8, 8)
fn epi_fallback(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.y * 256u + id.x;
    if id.x >= 256u || i >= E.level {
        return;
    }
    let size = textureDimensions(depth);
    let index = fallback[i];
    let p = vec2<u32>(index % size.x, min(index / size.x, size.y - 1u));
    let dir = view_ray(p, size);
    let r = min_max_ray(dir, textureLoad(depth, p, 0).r);
    store(p, dir, r.x, r.y, r.z);
}
