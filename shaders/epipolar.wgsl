// EpipolarDilation / EpipolarClosure: 1D min (then max) along epipolar rays in slope space
// (nodes/epipolar.rs; SPEC §4 eq. 3, seed 001 §4.1).
//
// Each texel t (centre c_t, distance d_t from the epipole l) has the slope
// κ_t = (z_t − z_l) / d_t. Dilation: κ'_t = min(κ_t, κ_s over the `length` samples s from t
// towards l); erosion: max over the samples on the far side. Then z'_t = z_l + d_t κ'_t, which
// is the seed's `d_t/d_s · (z_s − z_l) + z_l` minimised over s.

struct Params {
    epipole: vec2<f32>,
    z_l: f32,
    length: i32,
    op: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_map: texture_storage_2d<r32float, write>;

fn slope(texel: vec2<i32>, d: f32) -> f32 {
    return (textureLoad(src, texel, 0).r - P.z_l) / d;
}

// The reference definition: `length` nearest-texel samples along the exact line, O(length).
@compute @workgroup_size(8, 8)
fn reference(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(src));
    if i32(id.x) >= size.x || i32(id.y) >= size.y {
        return;
    }
    let t = vec2<i32>(id.xy);
    let c = vec2<f32>(t) + 0.5;
    let z = textureLoad(src, t, 0).r;
    let to_l = P.epipole - c;
    let d_t = length(to_l);
    if d_t <= 0.0 {
        textureStore(out_map, id.xy, vec4<f32>(z, 0.0, 0.0, 1.0));
        return;
    }
    // Dilation walks towards l and stops before reaching it; erosion walks away from l.
    let dir = select(to_l / d_t, -to_l / d_t, P.op == 1u);
    var k = (z - P.z_l) / d_t;
    for (var i = 1; i <= P.length; i++) {
        if P.op == 0u && f32(i) >= d_t {
            break;
        }
        let s = vec2<i32>(floor(c + dir * f32(i)));
        if s.x < 0 || s.y < 0 || s.x >= size.x || s.y >= size.y {
            break;
        }
        let d_s = length(P.epipole - (vec2<f32>(s) + 0.5));
        if d_s <= 0.0 {
            continue;
        }
        let ks = slope(s, d_s);
        k = select(min(k, ks), max(k, ks), P.op == 1u);
    }
    textureStore(out_map, id.xy, vec4<f32>(P.z_l + d_t * k, 0.0, 0.0, 1.0));
}

// ---- Fast path: rectify along epipolar lines, 1D van Herk on κ, project back ----------------
//
// Row j of the rectified grid is the ray from l at angle phi0 + j · dphi measured from the unit
// direction u_c (towards the map's centre, so far epipoles keep precise small angles); column m
// is the point at distance d0 + m from l (unit spacing). R[j][m] = κ of the nearest texel there
// (the operation's identity outside the map or at l). A one-sided window of k samples is a van
// Herk min/max with blocks of k: W[j][m] = ⊕ R[j][m − lo .. m + hi], lo + hi + 1 = k. Texel t
// reads W at its own row (nearest angle) and the column of its nearest sample, so the cost per
// texel does not depend on k.

struct Rect {
    u_c: vec2<f32>,
    phi0: f32,
    dphi: f32,
    epipole: vec2<f32>,
    d0: f32,
    z_l: f32,
    lo: i32,
    hi: i32,
    op: u32,
    rows: u32,
    cols: u32,
    stride: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(3) var<uniform> R: Rect;
@group(0) @binding(4) var grid: texture_2d<f32>;
@group(0) @binding(5) var grid_out: texture_storage_2d<r32float, write>;
@group(0) @binding(6) var prefix_out: texture_storage_2d<r32float, write>;
@group(0) @binding(7) var suffix_out: texture_storage_2d<r32float, write>;
@group(0) @binding(8) var prefix_in: texture_2d<f32>;
@group(0) @binding(9) var suffix_in: texture_2d<f32>;

const BIG: f32 = 3.4028235e38;

fn identity_r() -> f32 {
    return select(BIG, -BIG, R.op == 1u);
}

fn pick_r(a: f32, b: f32) -> f32 {
    return select(min(a, b), max(a, b), R.op == 1u);
}

@compute @workgroup_size(8, 8)
fn rectify(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= R.cols || id.y >= R.rows {
        return;
    }
    let phi = R.phi0 + f32(id.y) * R.dphi;
    let c = cos(phi);
    let s = sin(phi);
    let dir = vec2<f32>(R.u_c.x * c - R.u_c.y * s, R.u_c.x * s + R.u_c.y * c);
    let p = R.epipole + dir * (R.d0 + f32(id.x) / f32(R.stride));
    let size = vec2<i32>(textureDimensions(src));
    let t = vec2<i32>(floor(p));
    var v = identity_r();
    if t.x >= 0 && t.y >= 0 && t.x < size.x && t.y < size.y {
        let d_s = length(R.epipole - (vec2<f32>(t) + 0.5));
        if d_s > 0.0 {
            v = (textureLoad(src, t, 0).r - R.z_l) / d_s;
        }
    }
    textureStore(grid_out, id.xy, vec4<f32>(v, 0.0, 0.0, 1.0));
}

// Columns are `stride` sub-steps per texel; a window of k samples one texel apart takes every
// stride-th column, so each row splits into `stride` interleaved sequences (residue r: columns
// r, r + stride, …), filtered separately in blocks of k aligned at their first element.
fn seq_len(r: u32) -> u32 {
    return (R.cols + R.stride - 1u - r) / R.stride;
}

@compute @workgroup_size(8, 8)
fn grid_blocks(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = u32(R.lo + R.hi + 1);
    let row = id.y / R.stride;
    let r = id.y % R.stride;
    let n = seq_len(r);
    let start = id.x * k;
    if start >= n || row >= R.rows {
        return;
    }
    let end = min(start + k, n);
    var acc = identity_r();
    for (var i = start; i < end; i++) {
        let c = vec2<u32>(i * R.stride + r, row);
        acc = pick_r(acc, textureLoad(grid, c, 0).r);
        textureStore(prefix_out, c, vec4<f32>(acc, 0.0, 0.0, 1.0));
    }
    acc = identity_r();
    for (var i = end; i > start; i--) {
        let c = vec2<u32>((i - 1u) * R.stride + r, row);
        acc = pick_r(acc, textureLoad(grid, c, 0).r);
        textureStore(suffix_out, c, vec4<f32>(acc, 0.0, 0.0, 1.0));
    }
}

// W[m] = ⊕ R[m − lo .. m + hi] = suffix(m − lo) ⊕ prefix(m + hi); columns outside the grid
// are outside the map (identity).
@compute @workgroup_size(8, 8)
fn grid_combine(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= R.cols || id.y >= R.rows {
        return;
    }
    let r = id.x % R.stride;
    let n = i32(seq_len(r));
    let k = R.lo + R.hi + 1;
    let x = i32(id.x / R.stride);
    var s = identity_r();
    let a = x - R.lo;
    if a >= 0 {
        s = textureLoad(suffix_in, vec2<i32>(a * i32(R.stride) + i32(r), i32(id.y)), 0).r;
    }
    var p = identity_r();
    let b = x + R.hi;
    if b < n {
        p = textureLoad(prefix_in, vec2<i32>(b * i32(R.stride) + i32(r), i32(id.y)), 0).r;
    } else if b / k == (n - 1) / k {
        p = textureLoad(prefix_in, vec2<i32>((n - 1) * i32(R.stride) + i32(r), i32(id.y)), 0).r;
    }
    textureStore(grid_out, id.xy, vec4<f32>(pick_r(s, p), 0.0, 0.0, 1.0));
}

// Back to the map: z' = z_l + d_t · (κ_t ⊕ W[row(t)][column of the nearest sample]).
@compute @workgroup_size(8, 8)
fn project_back(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(src));
    if i32(id.x) >= size.x || i32(id.y) >= size.y {
        return;
    }
    let c = vec2<f32>(id.xy) + 0.5;
    let z = textureLoad(src, id.xy, 0).r;
    let v = c - R.epipole;
    let d_t = length(v);
    if d_t <= 0.0 {
        textureStore(out_map, id.xy, vec4<f32>(z, 0.0, 0.0, 1.0));
        return;
    }
    let phi = atan2(R.u_c.x * v.y - R.u_c.y * v.x, dot(R.u_c, v));
    let row = clamp(i32(round((phi - R.phi0) / R.dphi)), 0, i32(R.rows) - 1);
    // Dilation: samples at d_t − 1 … d_t − k (window ending at the first); erosion: d_t + 1 ….
    let first = select(d_t - 1.0, d_t + 1.0, R.op == 1u);
    let col = i32(round((first - R.d0) * f32(R.stride)));
    var k = (z - R.z_l) / d_t;
    if col >= 0 && col < i32(R.cols) {
        k = pick_r(k, textureLoad(grid, vec2<i32>(col, row), 0).r);
    }
    textureStore(out_map, id.xy, vec4<f32>(R.z_l + d_t * k, 0.0, 0.0, 1.0));
}
