// LightMapSolve (nodes/light_map_solve/): the two matrix-free halves of the normal equations.
// `forward` is T x for the constraint pixels of one view, `adjoint` adds Tᵀ r into the light
// map's texels. Row k of T (a constraint pixel's view ray, marched to its first surface in
// `steps` equal intervals) holds the weights ŵ_i V_i of its samples, ŵ_i = ∫_{interval i}
// e^{−σt t} dt / ∫_0^s e^{−σt t} dt, spread bilinearly over the four light-map texels around
// each sample: (T x)_k = Σ_i V_i ŵ_i x(uv_i). WGSL has no float atomics, so `adjoint` adds in
// 64-bit fixed point made of two u32 words per value (low word with atomicAdd, the carry read
// from the value it returns, then the high word): each contribution is multiplied by `scale`
// (per channel, chosen by the caller so that no sum can reach 2^62: Σ|r| · scale ≤ 2^61, since
// Σ_i ŵ_i ≤ 1 and bilinear weights sum to 1) and keeps f32's relative precision (6e-8), where
// one i32 word would round each contribution to ~1e-4 of itself on large problems.
#import lib/camera
#import lib/medium
#import lib/shadow

struct View {
    inv_view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    steps: u32,
    scale: vec3<f32>,
    sigma_t: f32,
    map_size: vec2<u32>,
    bias: f32,
    row_offset: u32,
    g: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    // The light map's light (lib/shadow.wgsl): a spot (kind 1) weighs each sample by its
    // falloff and HG g; the sun (kind 0) by nothing.
    light: Light,
}

// The resident solve's vector passes (`combine`, `mask_frozen`, `reduce`, `decode`, `clear`).
struct Vectors {
    scale: vec4<f32>,
    count: u32,
    mode: u32,
    slot: u32,
    clamp_at_zero: u32,
    alpha: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: View;
@group(0) @binding(1) var shadow: texture_2d<f32>;
@group(0) @binding(2) var depth: texture_2d<f32>;
@group(0) @binding(3) var targets: texture_2d<f32>;
@group(0) @binding(4) var x_map: texture_2d<f32>;
@group(0) @binding(5) var out_tx: texture_storage_2d<rgba32float, write>;
@group(0) @binding(6) var residual: texture_2d<f32>;
@group(0) @binding(7) var<storage, read_write> acc: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read_write> vin: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> vout: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> pixels: array<u32>;
@group(0) @binding(11) var<storage, read_write> vin2: array<vec4<f32>>;
@group(0) @binding(12) var<storage, read_write> partials: array<vec4<f32>>;
@group(0) @binding(13) var<uniform> V: Vectors;

fn view_ray(p: vec2<u32>, size: vec2<u32>) -> vec3<f32> {
    return pixel_ray(P.inv_view_proj, P.eye, p, size);
}

// Light-space (u, v, depth) of a world point, and whether the sun reaches it (nearest texel,
// depth bias; outside the map or the light box: lit).
fn light_uv(x: vec3<f32>) -> vec3<f32> {
    if P.light.kind != 0u {
        return light_uvz_local(P.light, P.light.view_proj, x);
    }
    return light_uvz(P.light.view_proj, x);
}

// A spot's falloff and phase at distance t along the ray (1 for the sun: one factor of every
// row, which cancels).
fn lamp(dir: vec3<f32>, t: f32) -> f32 {
    if P.light.kind == 0u {
        return 1.0;
    }
    let x = P.eye + dir * t;
    let l = P.light.position - x;
    let to_light = select(vec3<f32>(0.0), l / length(l), dot(l, l) > 0.0);
    return light_falloff(P.light, x) * henyey_greenstein(P.g, dot(dir, to_light));
}

// The row's normaliser: ∫_0^s e^{−σt t} dt for the sun; for a spot the sum of every sample's
// falloff × phase × interval weight, lit or not (so Σ_i ŵ_i ≤ 1 still holds).
fn row_total(dir: vec3<f32>, s: f32) -> f32 {
    if P.light.kind == 0u {
        return decay_integral(s, P.sigma_t);
    }
    let n = f32(P.steps);
    var sum = 0.0;
    for (var i = 0u; i < P.steps; i++) {
        sum += lamp(dir, (f32(i) + 0.5) / n * s) * exp(-P.sigma_t * (f32(i) / n * s));
    }
    return sum * decay_integral(s / n, P.sigma_t);
}

fn visible(l: vec3<f32>) -> bool {
    return sun_reaches(shadow, l, P.bias);
}

// The four texels around light-map coordinate uv and their bilinear weights (clamp to edge).
struct Corners {
    idx: vec4<i32>,
    w: vec4<f32>,
}

fn corners(uv: vec2<f32>) -> Corners {
    let size = vec2<i32>(P.map_size);
    let q = uv * vec2<f32>(size) - 0.5;
    let f = q - floor(q);
    let i0 = clamp(vec2<i32>(floor(q)), vec2<i32>(0), size - 1);
    let i1 = clamp(vec2<i32>(floor(q)) + 1, vec2<i32>(0), size - 1);
    var c: Corners;
    c.idx = vec4<i32>(i0.y * size.x + i0.x, i0.y * size.x + i1.x, i1.y * size.x + i0.x, i1.y * size.x + i1.x);
    c.w = vec4<f32>((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
    return c;
}

// Sample i of `steps` along a constraint pixel's view ray (direction `dir`, surface at `s`):
// its light-space point and its weight ŵ_i V_i (0 when shadowed or for an empty ray).
struct Sample {
    l: vec3<f32>,
    w: f32,
}

fn sample_at(dir: vec3<f32>, s: f32, i: u32, total: f32) -> Sample {
    let n = f32(P.steps);
    let t = (f32(i) + 0.5) / n * s;
    var m: Sample;
    m.l = light_uv(P.eye + dir * t);
    m.w = 0.0;
    if visible(m.l) && total > 0.0 {
        let a = f32(i) / n * s;
        m.w = lamp(dir, t) * exp(-P.sigma_t * a) * decay_integral(s / n, P.sigma_t) / total;
    }
    return m;
}

fn x_at(idx: i32) -> vec3<f32> {
    let w = i32(P.map_size.x);
    return textureLoad(x_map, vec2<i32>(idx % w, idx / w), 0).rgb;
}

@compute @workgroup_size(8, 8)
fn forward(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    if textureLoad(targets, id.xy, 0).a <= 0.0 {
        textureStore(out_tx, id.xy, vec4<f32>(0.0));
        return;
    }
    let dir = view_ray(id.xy, size);
    let s = textureLoad(depth, id.xy, 0).r;
    var sum = vec3<f32>(0.0);
    let total = row_total(dir, s);
    for (var i = 0u; i < P.steps; i++) {
        let m = sample_at(dir, s, i, total);
        if m.w <= 0.0 {
            continue;
        }
        let w = m.w;
        let c = corners(m.l.xy);
        let v = c.w.x * x_at(c.idx.x) + c.w.y * x_at(c.idx.y) + c.w.z * x_at(c.idx.z) + c.w.w * x_at(c.idx.w);
        sum += w * v;
    }
    textureStore(out_tx, id.xy, vec4<f32>(sum, 1.0));
}

// Add x (an integer-valued f32 up to 2^62 in magnitude) to the 64-bit two's-complement value
// in words (2 w, 2 w + 1) = (low, high).
fn add64(w: i32, x: f32) {
    let a = abs(x);
    var hi = u32(floor(a / 4294967296.0));
    var lo = u32(a - f32(hi) * 4294967296.0);
    if x < 0.0 {
        lo = ~lo + 1u;
        hi = ~hi + select(0u, 1u, lo == 0u);
    }
    if lo == 0u && hi == 0u {
        return;
    }
    let old = atomicAdd(&acc[2 * w], lo);
    let carry = select(0u, 1u, old + lo < old);
    atomicAdd(&acc[2 * w + 1], hi + carry);
}

fn add(idx: i32, v: vec3<f32>) {
    let n = i32(P.map_size.x * P.map_size.y);
    let q = round(v * P.scale);
    add64(idx, q.x);
    add64(n + idx, q.y);
    add64(2 * n + idx, q.z);
}

@compute @workgroup_size(8, 8)
fn adjoint(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(depth);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    if textureLoad(targets, id.xy, 0).a <= 0.0 {
        return;
    }
    let r = textureLoad(residual, id.xy, 0).rgb;
    let dir = view_ray(id.xy, size);
    let s = textureLoad(depth, id.xy, 0).r;
    let total = row_total(dir, s);
    for (var i = 0u; i < P.steps; i++) {
        let m = sample_at(dir, s, i, total);
        if m.w <= 0.0 {
            continue;
        }
        let w = m.w;
        let c = corners(m.l.xy);
        add(c.idx.x, r * (w * c.w.x));
        add(c.idx.y, r * (w * c.w.y));
        add(c.idx.z, r * (w * c.w.z));
        add(c.idx.w, r * (w * c.w.w));
    }
}

// ---------------------------------------------------------------------------------------------
// The resident solve (nodes/light_map_solve/resident.rs): T and Tᵀ over the constraint pixels
// listed in `pixels` (one invocation per row, rows stored at `row_offset` + j of the row
// vectors), and the CG vector work on buffers of vec4 (rgb; a unused). Consecutive samples of a
// ray in the same four texels are summed before they touch the map (the weights of the four
// corners add up): the same sums, one fetch or atomic add per texel crossed instead of per sample.

fn pixel_of(j: u32) -> vec2<u32> {
    let w = textureDimensions(depth).x;
    let k = pixels[j];
    return vec2<u32>(k % w, k / w);
}

@compute @workgroup_size(64)
fn forward_rows(@builtin(global_invocation_id) id: vec3<u32>) {
    let j = id.x;
    if j >= arrayLength(&pixels) {
        return;
    }
    let px = pixel_of(j);
    let dir = view_ray(px, textureDimensions(depth));
    let s = textureLoad(depth, px, 0).r;
    var sum = vec3<f32>(0.0);
    var cur = vec4<i32>(-1);
    var wc = vec4<f32>(0.0);
    let total = row_total(dir, s);
    for (var i = 0u; i < P.steps; i++) {
        let m = sample_at(dir, s, i, total);
        if m.w <= 0.0 {
            continue;
        }
        let c = corners(m.l.xy);
        if any(c.idx != cur) {
            if cur.x >= 0 {
                sum += wc.x * vin[cur.x].rgb + wc.y * vin[cur.y].rgb + wc.z * vin[cur.z].rgb + wc.w * vin[cur.w].rgb;
            }
            cur = c.idx;
            wc = vec4<f32>(0.0);
        }
        wc += m.w * c.w;
    }
    if cur.x >= 0 {
        sum += wc.x * vin[cur.x].rgb + wc.y * vin[cur.y].rgb + wc.z * vin[cur.z].rgb + wc.w * vin[cur.w].rgb;
    }
    vout[P.row_offset + j] = vec4<f32>(sum, 0.0);
}

fn add_corners(idx: vec4<i32>, r: vec3<f32>, wc: vec4<f32>) {
    add(idx.x, r * wc.x);
    add(idx.y, r * wc.y);
    add(idx.z, r * wc.z);
    add(idx.w, r * wc.w);
}

@compute @workgroup_size(64)
fn adjoint_rows(@builtin(global_invocation_id) id: vec3<u32>) {
    let j = id.x;
    if j >= arrayLength(&pixels) {
        return;
    }
    let r = vin[P.row_offset + j].rgb;
    if all(r == vec3<f32>(0.0)) {
        return;
    }
    let px = pixel_of(j);
    let dir = view_ray(px, textureDimensions(depth));
    let s = textureLoad(depth, px, 0).r;
    var cur = vec4<i32>(-1);
    var wc = vec4<f32>(0.0);
    let total = row_total(dir, s);
    for (var i = 0u; i < P.steps; i++) {
        let m = sample_at(dir, s, i, total);
        if m.w <= 0.0 {
            continue;
        }
        let c = corners(m.l.xy);
        if any(c.idx != cur) {
            if cur.x >= 0 {
                add_corners(cur, r, wc);
            }
            cur = c.idx;
            wc = vec4<f32>(0.0);
        }
        wc += m.w * c.w;
    }
    if cur.x >= 0 {
        add_corners(cur, r, wc);
    }
}

// vout = u + alpha v (vin, vin2), clamped at 0 when `clamp_at_zero`.
@compute @workgroup_size(64)
fn combine(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= V.count {
        return;
    }
    var o = vin[id.x] + V.alpha * vin2[id.x];
    if V.clamp_at_zero != 0u {
        o = max(o, vec4<f32>(0.0));
    }
    vout[id.x] = o;
}

// Frozen texels do not move: p (vout) is 0 where x (vin) ≤ 0 and s (vin2) = 0.
@compute @workgroup_size(64)
fn mask_frozen(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= V.count {
        return;
    }
    let frozen = vin[id.x] <= vec4<f32>(0.0) & vin2[id.x] == vec4<f32>(0.0);
    vout[id.x] = select(vout[id.x], vec4<f32>(0.0), frozen);
}

// One of up to 64 partial results per reduction, written at partials[slot * 64 + workgroup]
// (the caller adds those of the workgroups it ran in f64: one per 256 elements, at most 64, so a
// short vector is not swept by 16384 idle invocations). mode 0: Σ u·v per channel; 1: Σ |u|; 2: min u;
// 3: min over v < 0 of −u / v (the longest step along v that keeps u ≥ 0; 3.4e38 if none);
// 4: Σ u² (v unused: a buffer may not be bound twice as writable storage).
var<workgroup> part: array<vec4<f32>, 256>;

@compute @workgroup_size(256)
fn reduce(@builtin(global_invocation_id) id: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let threads = groups.x * 256u;
    let big = vec4<f32>(3.4e38);
    let minimum = V.mode == 2u || V.mode == 3u;
    var acc4 = select(vec4<f32>(0.0), big, vec4<bool>(minimum));
    for (var i = id.x; i < V.count; i += threads) {
        let u = vin[i];
        let v = vin2[i];
        switch V.mode {
            case 0u: { acc4 += u * v; }
            case 1u: { acc4 += abs(u); }
            case 2u: { acc4 = min(acc4, u); }
            case 4u: { acc4 += u * u; }
            case 3u: {
                let lim = select(big, max(-u / v, vec4<f32>(0.0)), v < vec4<f32>(0.0));
                acc4 = min(acc4, lim);
            }
            default: {}
        }
    }
    part[li] = acc4;
    workgroupBarrier();
    for (var h = 128u; h > 0u; h = h / 2u) {
        if li < h {
            if minimum {
                part[li] = min(part[li], part[li + h]);
            } else {
                part[li] = part[li] + part[li + h];
            }
        }
        workgroupBarrier();
    }
    if li == 0u {
        partials[V.slot * 64u + wg.x] = part[0];
    }
}

// The 64-bit fixed-point sums of `adjoint_rows` (count texels) as floats, divided by the
// channels' scale, into vout; with `clamp_at_zero`, texels frozen at 0 (x = vin ≤ 0) whose
// gradient points below 0 get 0.
@compute @workgroup_size(64)
fn decode(@builtin(global_invocation_id) id: vec3<u32>) {
    let n = V.count;
    if id.x >= n {
        return;
    }
    var o = vec4<f32>(0.0);
    for (var c = 0u; c < 3u; c++) {
        let w = c * n + id.x;
        let lo = atomicLoad(&acc[2u * w]);
        let hi = atomicLoad(&acc[2u * w + 1u]);
        // Two's complement: negative values are −(~v + 1).
        var mag = f32(hi) * 4294967296.0 + f32(lo);
        if (hi & 0x80000000u) != 0u {
            let nlo = ~lo + 1u;
            let nhi = ~hi + select(0u, 1u, nlo == 0u);
            mag = -(f32(nhi) * 4294967296.0 + f32(nlo));
        }
        if V.scale[c] > 0.0 {
            o[c] = mag / V.scale[c];
        }
    }
    if V.clamp_at_zero != 0u {
        let frozen = vin[id.x] <= vec4<f32>(0.0) & o < vec4<f32>(0.0);
        o = select(o, vec4<f32>(0.0), frozen);
    }
    vout[id.x] = vec4<f32>(o.rgb, 0.0);
}

// acc = 0 (count words).
@compute @workgroup_size(64)
fn clear(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x < V.count {
        atomicStore(&acc[id.x], 0u);
    }
}
