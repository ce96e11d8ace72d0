// EpipolarDilation / EpipolarClosure: 1D min (then max) along epipolar rays in slope space
// (nodes/epipolar/; SPEC §4 eq. 3, seed 001 §4.1).
//
// Each texel t (centre c_t, distance d_t from the epipole l) has the slope
// κ_t = (z_t − z_l) / d_t. Dilation: κ'_t = min(κ_t, κ_s over the `length` samples s from t
// towards l); erosion: max over the samples on the far side. Then z'_t = z_l + d_t κ'_t, which
// is the seed's `d_t/d_s · (z_s − z_l) + z_l` minimised over s.
#import lib/shadow

struct Params {
    epipole: vec2<f32>,
    z_l: f32,
    length: i32,
    op: u32,
    // 1: samples on the other side (a spot's map seen by a camera behind the spot's plane,
    // whose view rays' images run towards the epipole as they leave the camera).
    reverse: u32,
    // Tiles across and down: (1, 1), or (3, 2) for a point light's padded cube faces, each its
    // own map with its own epipole (`faces`); a walk stops at its tile's border.
    tiles: vec2<u32>,
    // Per face of a cube atlas: epipole (texels from the tile's corner), z_l, reverse (0 or 1).
    faces: array<vec4<f32>, 6>,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_map: texture_storage_2d<r32float, write>;

// Depth z at distance d from the epipole ↔ slope κ = (z − z_l) / d. A clear texel (no
// occluder, SHADOW_CLEAR) has slope +∞ and maps back to clear.
fn to_slope(z: f32, z_l: f32, d: f32) -> f32 {
    return keep_clear(z, (z - z_l) / d);
}

fn from_slope(k: f32, z_l: f32, d: f32) -> f32 {
    return keep_clear(k, z_l + d * k);
}

fn slope(texel: vec2<i32>, d: f32, z_l: f32) -> f32 {
    return to_slope(textureLoad(src, texel, 0).r, z_l, d);
}

// The texel a sample lands on: the reference's exact f32 steps, shared by both methods.
fn sample_texel(c: vec2<f32>, dir: vec2<f32>, i: i32) -> vec2<i32> {
    return vec2<i32>(floor(c + dir * f32(i)));
}

// The reference definition: `length` nearest-texel samples along the exact line, O(length).
@compute @workgroup_size(8, 8)
fn reference(@builtin(global_invocation_id) id: vec3<u32>) {
    let full = vec2<i32>(textureDimensions(src));
    if i32(id.x) >= full.x || i32(id.y) >= full.y {
        return;
    }
    // The tile this texel lies in: the whole map, or one padded cube face.
    let size = full / vec2<i32>(P.tiles);
    let cell = vec2<i32>(id.xy) / size;
    let lo = cell * size;
    let hi = lo + size;
    var epipole = P.epipole;
    var z_l = P.z_l;
    var reverse = P.reverse;
    if P.tiles.x * P.tiles.y > 1u {
        let f = P.faces[cell.x + 3 * cell.y];
        epipole = f.xy + vec2<f32>(lo);
        z_l = f.z;
        reverse = u32(f.w);
    }
    let t = vec2<i32>(id.xy);
    let c = vec2<f32>(t) + 0.5;
    let z = textureLoad(src, t, 0).r;
    let to_l = epipole - c;
    let d_t = length(to_l);
    if d_t <= 0.0 {
        textureStore(out_map, id.xy, vec4<f32>(z, 0.0, 0.0, 1.0));
        return;
    }
    // Dilation walks towards l and stops before reaching it; erosion walks away from l
    // (`reverse` swaps the sides, not the operations).
    let towards = (P.op == 0u) != (reverse == 1u);
    let dir = select(-to_l / d_t, to_l / d_t, towards);
    var k = to_slope(z, z_l, d_t);
    for (var i = 1; i <= P.length; i++) {
        if towards && f32(i) >= d_t {
            break;
        }
        let s = sample_texel(c, dir, i);
        if s.x < lo.x || s.y < lo.y || s.x >= hi.x || s.y >= hi.y {
            break;
        }
        let d_s = length(epipole - (vec2<f32>(s) + 0.5));
        if d_s <= 0.0 {
            continue;
        }
        let ks = slope(s, d_s, z_l);
        k = select(min(k, ks), max(k, ks), P.op == 1u);
    }
    textureStore(out_map, id.xy, vec4<f32>(from_slope(k, z_l, d_t), 0.0, 0.0, 1.0));
}

// ---- Fast path: exact, with a cost flat in `length` on shadow maps -------------------------
//
// A texel's samples do not lie on a shared grid (each texel rounds its own line), so no
// rectification reproduces the definition sample for sample. The fast path therefore proves
// each texel's answer instead of approximating it:
//
// 1. `kappa`: κ of every texel (the operation's identity at the epipole's own texel centre).
// 2. `rectify`: a grid of epipolar rays from l (row j: direction dir_j from a table computed in
//    f64 on the CPU, about one row per texel of arc at the map's far edge; column m: distance
//    d0 + m, one column per texel). Each cell holds the min (max) of κ over the 3×3 block of
//    texels around its point g: a bound on κ of any texel that a sample within 1.0 texel of g
//    can land on.
// 3. `grid_blocks` + `grid_combine`: van Herk / Gil–Werman along each row over the interior
//    samples E+1 … length−E (constant cost per cell whatever the length).
// 4. `project_back`: per texel, the samples 1…E and last−E+1…last exactly (last = the final
//    sample before the border or l, found by bisection), then the interior's bound from the
//    grid. When the exact ends already beat the bound, the ends' value IS the definition's
//    (no interior sample can be lower); otherwise — or when the texel's samples stray further
//    from the grid points than the block covers — the texel runs the exact O(length) loop.
// The result equals `reference` on every texel; only the share of texels that fall back (a few
// % on shadow maps, more on noise) depends on the map, and with it the cost.

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
    ends: i32,
    length: i32,
    _pad0: u32,
}

@group(0) @binding(3) var<uniform> R: Rect;
@group(0) @binding(4) var grid: texture_2d<f32>;
@group(0) @binding(5) var grid_out: texture_storage_2d<r32float, write>;
@group(0) @binding(6) var prefix_out: texture_storage_2d<r32float, write>;
@group(0) @binding(7) var suffix_out: texture_storage_2d<r32float, write>;
@group(0) @binding(8) var prefix_in: texture_2d<f32>;
@group(0) @binding(9) var suffix_in: texture_2d<f32>;
@group(0) @binding(10) var kappa_in: texture_2d<f32>;
@group(0) @binding(11) var rows_in: texture_2d<f32>;

const BIG: f32 = 3.4028235e38;

fn identity_r() -> f32 {
    return select(BIG, -BIG, R.op == 1u);
}

fn pick_r(a: f32, b: f32) -> f32 {
    return select(min(a, b), max(a, b), R.op == 1u);
}

@compute @workgroup_size(8, 8)
fn kappa(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(src));
    if i32(id.x) >= size.x || i32(id.y) >= size.y {
        return;
    }
    let s = vec2<i32>(id.xy);
    let d_s = length(R.epipole - (vec2<f32>(s) + 0.5));
    var v = identity_r();
    if d_s > 0.0 {
        v = to_slope(textureLoad(src, s, 0).r, R.z_l, d_s);
    }
    textureStore(grid_out, id.xy, vec4<f32>(v, 0.0, 0.0, 1.0));
}

// Point of grid cell (column m, row j): the row's base point (distance d0) plus m along its
// direction. `rectify` and `project_back` share it so both see the same f32 value.
fn grid_point(m: i32, row: vec4<f32>) -> vec2<f32> {
    return row.zw + row.xy * f32(m);
}

@compute @workgroup_size(8, 8)
fn rectify(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= R.cols || id.y >= R.rows {
        return;
    }
    let row = textureLoad(rows_in, vec2<u32>(id.y, 0u), 0);
    // The 3×3 block of texels a point within one texel of g can land on.
    let o = vec2<i32>(floor(grid_point(i32(id.x), row))) - 1;
    let size = vec2<i32>(textureDimensions(kappa_in));
    var v = identity_r();
    for (var by = 0; by < 3; by++) {
        for (var bx = 0; bx < 3; bx++) {
            let t = o + vec2<i32>(bx, by);
            if t.x >= 0 && t.y >= 0 && t.x < size.x && t.y < size.y {
                v = pick_r(v, textureLoad(kappa_in, t, 0).r);
            }
        }
    }
    textureStore(grid_out, id.xy, vec4<f32>(v, 0.0, 0.0, 1.0));
}

// Each row is filtered in blocks of k = lo + hi + 1 columns aligned at the row's start.
@compute @workgroup_size(8, 8)
fn grid_blocks(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = u32(R.lo + R.hi + 1);
    let row = id.y;
    let n = R.cols;
    let start = id.x * k;
    if start >= n || row >= R.rows {
        return;
    }
    let end = min(start + k, n);
    var acc = identity_r();
    for (var i = start; i < end; i++) {
        let c = vec2<u32>(i, row);
        acc = pick_r(acc, textureLoad(grid, c, 0).r);
        textureStore(prefix_out, c, vec4<f32>(acc, 0.0, 0.0, 1.0));
    }
    acc = identity_r();
    for (var i = end; i > start; i--) {
        let c = vec2<u32>(i - 1u, row);
        acc = pick_r(acc, textureLoad(grid, c, 0).r);
        textureStore(suffix_out, c, vec4<f32>(acc, 0.0, 0.0, 1.0));
    }
}

// W[m] = ⊕ G[m − lo .. m + hi] = suffix(m − lo) ⊕ prefix(m + hi); columns outside the grid
// contribute nothing (identity).
@compute @workgroup_size(8, 8)
fn grid_combine(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= R.cols || id.y >= R.rows {
        return;
    }
    let n = i32(R.cols);
    let k = R.lo + R.hi + 1;
    let x = i32(id.x);
    var s = identity_r();
    let a = x - R.lo;
    if a >= 0 {
        s = textureLoad(suffix_in, vec2<i32>(a, i32(id.y)), 0).r;
    }
    var p = identity_r();
    let b = x + R.hi;
    if b < n {
        p = textureLoad(prefix_in, vec2<i32>(b, i32(id.y)), 0).r;
    } else if b / k == (n - 1) / k {
        p = textureLoad(prefix_in, vec2<i32>(n - 1, i32(id.y)), 0).r;
    }
    textureStore(grid_out, id.xy, vec4<f32>(pick_r(s, p), 0.0, 0.0, 1.0));
}

// atan for x ≥ 0 (Cephes atanf: range reduction to |x| ≤ tan(π/8), then a degree-9 odd
// polynomial; ~2e-7 relative), so row look-ups do not depend on the driver's atan precision.
fn atan_pos(x0: f32) -> f32 {
    var x = x0;
    var y = 0.0;
    if x > 2.4142135 {
        y = 1.5707964;
        x = -1.0 / x;
    } else if x > 0.41421357 {
        y = 0.7853982;
        x = (x - 1.0) / (x + 1.0);
    }
    let z = x * x;
    return y + ((((0.080537446 * z - 0.13877685) * z + 0.19977711) * z - 0.33332950) * z * x + x);
}

fn atan2_precise(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    var a: f32;
    if ay > ax {
        a = 1.5707964 - atan_pos(ax / ay);
    } else {
        a = atan_pos(ay / ax);
    }
    if x < 0.0 {
        a = 3.1415927 - a;
    }
    return select(a, -a, y < 0.0);
}

// Is sample i of the texel at c valid (before the border and, for dilation, before l)? The
// valid samples are 1 … last: each coordinate of c + dir·i is monotone in i.
fn valid_sample(c: vec2<f32>, dir: vec2<f32>, d_t: f32, i: i32, size: vec2<i32>) -> bool {
    if R.op == 0u && f32(i) >= d_t {
        return false;
    }
    let s = sample_texel(c, dir, i);
    return s.x >= 0 && s.y >= 0 && s.x < size.x && s.y < size.y;
}

// Does the grid point of column m on `row` cover the exact sample point p (every coordinate
// within one texel, the 3×3 block's half-width, less a margin for f32 rounding)?
fn covered(p: vec2<f32>, m: i32, row: vec4<f32>) -> bool {
    let reach = 0.99;
    let off = abs(p - grid_point(m, row));
    return m >= 0 && m < i32(R.cols) && off.x <= reach && off.y <= reach;
}

@compute @workgroup_size(8, 8)
fn project_back(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(src));
    if i32(id.x) >= size.x || i32(id.y) >= size.y {
        return;
    }
    let c = vec2<f32>(id.xy) + 0.5;
    let z = textureLoad(src, id.xy, 0).r;
    let to_l = R.epipole - c;
    let d_t = length(to_l);
    if d_t <= 0.0 {
        textureStore(out_map, id.xy, vec4<f32>(z, 0.0, 0.0, 1.0));
        return;
    }
    let erode = R.op == 1u;
    let dir = select(to_l / d_t, -to_l / d_t, erode);
    // last valid sample by bisection: valid(lo) holds, valid(hi + 1) does not.
    var lo = 0;
    var hi = R.length;
    if !valid_sample(c, dir, d_t, hi, size) {
        hi -= 1;
        while lo < hi {
            let mid = (lo + hi + 1) / 2;
            if valid_sample(c, dir, d_t, mid, size) {
                lo = mid;
            } else {
                hi = mid - 1;
            }
        }
    }
    let last = hi;
    let e = R.ends;
    var acc = to_slope(z, R.z_l, d_t);
    for (var i = 1; i <= min(e, last); i++) {
        acc = pick_r(acc, textureLoad(kappa_in, sample_texel(c, dir, i), 0).r);
    }
    for (var i = max(e + 1, last - e + 1); i <= last; i++) {
        acc = pick_r(acc, textureLoad(kappa_in, sample_texel(c, dir, i), 0).r);
    }
    if last > 2 * e {
        // Interior samples e+1 … last−e: bounded by the grid window starting at sample e+1.
        var proven = false;
        let v = -to_l;
        let phi = atan2_precise(R.u_c.x * v.y - R.u_c.y * v.x, dot(R.u_c, v));
        let j = i32(round((phi - R.phi0) / R.dphi));
        if j >= 0 && j < i32(R.rows) {
            let row = textureLoad(rows_in, vec2<i32>(j, 0), 0);
            let step = select(-1, 1, erode);
            let first = select(d_t - 1.0, d_t + 1.0, erode);
            let m = i32(round(first - R.d0)) + e * step;
            let m_last = m + (last - 2 * e - 1) * step;
            if covered(c + dir * f32(e + 1), m, row) && covered(c + dir * f32(last - e), m_last, row) {
                let bound = textureLoad(grid, vec2<i32>(m, j), 0).r;
                proven = pick_r(acc, bound) == acc;
            }
        }
        if !proven {
            for (var i = e + 1; i <= last - e; i++) {
                acc = pick_r(acc, textureLoad(kappa_in, sample_texel(c, dir, i), 0).r);
            }
        }
    }
    textureStore(out_map, id.xy, vec4<f32>(from_slope(acc, R.z_l, d_t), 0.0, 0.0, 1.0));
}

// ---- A spot's perspective map (nodes/epipolar/lamp.rs, `Perspective`) ----------------------------
//
// Its depth z is linear in the distance w = near + z (far − near) along the spot's axis, and in
// a perspective projection 1/w, not w, is affine across the map: along a view ray's image
// (a line through the epipole) q = 1 − near / w changes linearly with the distance from the
// epipole. The passes above run on q; `to_q` converts before, `from_q` after (a texel the
// filter left as it was keeps its depth bit for bit).

struct Persp {
    near: f32,
    far: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(12) var<uniform> Q: Persp;
@group(0) @binding(13) var q_in: texture_2d<f32>;

@compute @workgroup_size(8, 8)
fn to_q(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(src);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let z = textureLoad(src, id.xy, 0).r;
    let w = Q.near + z * (Q.far - Q.near);
    textureStore(out_map, id.xy, vec4<f32>(keep_clear(z, 1.0 - Q.near / w), 0.0, 0.0, 1.0));
}

// `src`: the original depths; `q_in`: their q before the filter; `kappa_in`: q after it.
@compute @workgroup_size(8, 8)
fn from_q(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(src);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let before = textureLoad(q_in, id.xy, 0).r;
    let after = textureLoad(kappa_in, id.xy, 0).r;
    var z = textureLoad(src, id.xy, 0).r;
    if after != before {
        // q ≥ 1 lies at or past infinity along the spot's axis (a silhouette extruded beyond
        // it, or a clear texel): no occluder, so clear, not a negative depth.
        z = select((Q.near / (1.0 - after) - Q.near) / (Q.far - Q.near), SHADOW_CLEAR, after >= 1.0);
    }
    textureStore(out_map, id.xy, vec4<f32>(z, 0.0, 0.0, 1.0));
}
