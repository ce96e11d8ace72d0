// SingleScattering, shared by its passes (nodes/single_scattering/; SPEC §3, seed 000 eq. 1–2):
// the uniforms and bindings every pass reads, the phase function, the sun's visibility, the
// medium's extent and weights along a view ray, view rays, and the store of one pixel.
#import lib/camera
#import lib/hash
#import lib/medium
#import lib/shadow

struct Params {
    inv_view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    steps: u32,
    sigma_t: f32,
    albedo: f32,
    g: f32,
    jitter: f32,
    bias: f32,
    min_level: u32,
    phase_width: u32,
    soft_slices: u32,
    box_min: vec3<f32>,
    bounded: u32,
    box_max: vec3<f32>,
    light_extinction: u32,
    jitter_phase: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    // The light of the shadow map (lib/shadow.wgsl), its radiance × tint × intensity.
    light: Light,
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
    // A point light's position (persp = 2).
    position: vec3<f32>,
    // 0: the sun's box; 1: a spot's perspective volume; 2: a point light's six faces (3 × 2).
    persp: u32,
    near: f32,
    far: f32,
    _pad0: u32,
    _pad1: u32,
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
// Whether the light can be a spot or point light (`local_kind` ≠ 0; BruteForce only).
override LOCAL: bool = true;
// Whether the light can be a point light (its cube atlas walked face by face in MinMax).
override POINT: bool = true;

// Light extinction on (the pipeline allows it and the uniforms ask for it).
fn extinction() -> bool {
    return EXTINCTION && P.light_extinction != 0u;
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
    var uvz = vec3<f32>(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z);
    if POINT && SV.persp == 2u {
        // A point light's faces: the face x lies in, w along its axis.
        let d = x - SV.position;
        let face = cube_face(d);
        let frame = cube_frame(face);
        let w = dot(frame[0], d);
        if w <= 1e-6 {
            return 1.0;
        }
        let ndc = vec2<f32>(dot(frame[1], d), dot(frame[2], d)) / w;
        let uv = clamp(vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5), vec2<f32>(0.0), vec2<f32>(0.999999));
        let cell = vec2<f32>(f32(face % 3u), f32(face / 3u));
        uvz = vec3<f32>((cell.x + uv.x) / 3.0, (cell.y + uv.y) / 2.0,
            (1.0 - SV.near / w) / (1.0 - SV.near / SV.far));
    } else if SV.persp != 0u {
        // A spot's volume: the perspective divide, and slices in q = 1 − near / w.
        if c.w <= 1e-6 {
            return 1.0;
        }
        uvz = vec3<f32>(c.x / c.w * 0.5 + 0.5, 0.5 - c.y / c.w * 0.5,
            (1.0 - SV.near / c.w) / (1.0 - SV.near / SV.far));
    }
    if uvz.x < 0.0 || uvz.x >= 1.0 || uvz.y < 0.0 || uvz.y >= 1.0 || uvz.z < 0.0 {
        return 1.0;
    }
    // Past the far end of the slices (the casters' range) every occluder lies in front: the
    // last slice's occlusion holds on, however far the medium reaches.
    uvz.z = min(uvz.z, 1.0);
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

// ---- Spot and point lights (LOCAL; lib/shadow.wgsl) ----------------------------------------

fn local_falloff(x: vec3<f32>) -> f32 {
    return light_falloff(P.light, x);
}

fn local_uvz(x: vec3<f32>) -> vec3<f32> {
    return light_uvz_local(P.light, P.light.view_proj, x);
}

// Distance from x (inside the medium's box) to the box's boundary towards the light, at most
// the distance to the light: what the light crosses of the medium to reach x.
fn local_light_path(x: vec3<f32>) -> f32 {
    let l = P.light.position - x;
    let r = length(l);
    if r <= 0.0 {
        return 0.0;
    }
    let d = l / r;
    var ell = r;
    for (var k = 0; k < 3; k++) {
        if d[k] != 0.0 {
            let face = select(P.box_min[k], P.box_max[k], d[k] > 0.0);
            ell = min(ell, max((face - x[k]) / d[k], 0.0));
        }
    }
    return ell;
}

fn visible(x: vec3<f32>) -> f32 {
    if SOFT && P.soft_slices != 0u {
        return soft_visible(x);
    }
    if LOCAL && P.light.kind != 0u {
        return select(0.0, 1.0, sun_reaches(shadow, local_uvz(x), P.bias));
    }
    return select(0.0, 1.0, sun_reaches(shadow, light_uvz(P.light.view_proj, x), P.bias));
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
    let sk = towards_sun(P.light)[k];
    if abs(sk) < 1e-12 {
        return vec2<f32>(3.0e38, 0.0);
    }
    let face = select(P.box_min[k], P.box_max[k], sk > 0.0);
    return vec2<f32>((face - P.eye[k]) / sk, -dir[k] / sk);
}


// ℓ at distance t along the view ray, from the point itself (the lines above carry terms of
// order 1/|sun_k|, which cancel badly in f32 when the sun is nearly parallel to a face).
fn light_exit(dir: vec3<f32>, t: f32) -> f32 {
    let q = P.eye + dir * t;
    var ell = 3.0e38;
    for (var k = 0; k < 3; k++) {
        let sk = towards_sun(P.light)[k];
        if abs(sk) >= 1e-12 {
            let face = select(P.box_min[k], P.box_max[k], sk > 0.0);
            ell = min(ell, (face - q[k]) / sk);
        }
    }
    return max(ell, 0.0);
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
    return camera_ray(P.inv_view_proj, P.eye, q, size);
}

// Unit direction of the view ray through the centre of pixel `p` of a `size` image.
fn view_ray(p: vec2<u32>, size: vec2<u32>) -> vec3<f32> {
    return screen_ray(vec2<f32>(p) + 0.5, size);
}

// Write the outputs of one pixel. Light extinction off: the seed's factored form (eq. 2),
// σt ρ f · (1 − e^{−Lσt})/σt · V̄ over the medium's length L on the ray; on: σt ρ f · ∫ V E dt.
fn store(p: vec2<u32>, dir: vec3<f32>, vbar: f32, len: f32, weighted: f32) {
    let base = P.sigma_t * P.albedo * phase(dot(dir, towards_sun(P.light)));
    var k = base * decay_integral(len, P.sigma_t) * vbar;
    if extinction() {
        k = base * weighted;
    }
    textureStore(out_vis, p, vec4<f32>(vbar, 0.0, 0.0, 1.0));
    textureStore(out_inscatter, p, vec4<f32>(P.light.radiance * k, 1.0));
    textureStore(out_transmittance, p, vec4<f32>(exp(-len * P.sigma_t), 0.0, 0.0, 1.0));
}
