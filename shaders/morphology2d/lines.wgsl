// Dilate2D / Erode2D / Closure2D, circle by `method = Fast` at larger radii: min (or max) along
// the digital lines of one direction (nodes/morphology2d/polygon.rs). The polygon close to the
// disk is a Minkowski sum of such segments in up to eight directions, one pass each.
//
// A direction v = (vx, vy) (gcd 1, |vx|, |vy| ≤ 2) cuts the map into lines {p + t·v}: a texel's
// line is c = vy·x − vx·y and its place on it t = a·x + b·y, with a·vx + b·vy = 1 (t grows by
// one per step v, and (x, y) = (vx·t + b·c, vy·t − a·c)). Along a line the map's texels are one
// run of t; outside it the operation's identity stands in, so texels outside the map are not part
// of a segment and no bounds are tested per texel.
//
// The passes run between two storage buffers (row-major, the map's size): `from_map` copies the
// map in, each `segment` reads one and writes the other, `to_map` copies the result out.
//
// Van Herk / Gil–Werman, one thread per run of `n` blocks of k = 2m + 1 outputs on one line. The
// windows [u − m, u + m] of a block's outputs u all hold its centre q, so each output is
// S(u − m) ⊕ P(u + m), S the running min/max from q leftwards, P from q rightwards: a leftward
// sweep stores S, a rightward one folds P in; two reads and three operations per texel whatever
// m is.

struct Line {
    // The direction and its Bezout coefficients (a·vx + b·vy = 1).
    vx: i32,
    vy: i32,
    a: i32,
    b: i32,
    // Half-length in steps.
    m: i32,
    // 0: min (dilation of depths), 1: max (erosion).
    op: u32,
    // The pass's first line and its count.
    lo: i32,
    lines: i32,
    // Blocks of 2m + 1 outputs per thread.
    n: i32,
    // The map's size.
    w: i32,
    h: i32,
    _pad: u32,
}

@group(0) @binding(0) var<uniform> L: Line;
@group(0) @binding(1) var src: texture_2d<f32>;
// Only read; read_write because `Bind::Buffer` binds every storage buffer so.
@group(0) @binding(2) var<storage, read_write> src_buf: array<f32>;
@group(0) @binding(3) var<storage, read_write> out_buf: array<f32>;
@group(0) @binding(4) var out_map: texture_storage_2d<r32float, write>;

const BIG: f32 = 3.4028235e38;

fn identity() -> f32 {
    return select(BIG, -BIG, L.op == 1u);
}

fn pick(x: f32, y: f32) -> f32 {
    return select(min(x, y), max(x, y), L.op == 1u);
}

// floor(n / d) for d ∈ {1, 2} (a shift: WGSL's >> on i32 is arithmetic).
fn fdiv(n: i32, d: i32) -> i32 {
    return select(n, n >> 1u, d == 2);
}

// `range` narrowed to the t with 0 ≤ alpha·t + beta ≤ hi, |alpha| ≤ 2 (empty: x > y).
fn clip(range: vec2<i32>, alpha: i32, beta: i32, hi: i32) -> vec2<i32> {
    if alpha == 0 {
        if beta < 0 || beta > hi {
            return vec2<i32>(1, 0);
        }
        return range;
    }
    // alpha > 0: −beta ≤ alpha·t ≤ hi − beta; alpha < 0: beta − hi ≤ |alpha|·t ≤ beta.
    let d = abs(alpha);
    let lo = select(beta - hi, -beta, alpha > 0);
    let up = select(beta, hi - beta, alpha > 0);
    return vec2<i32>(max(range.x, -fdiv(-lo, d)), min(range.y, fdiv(up, d)));
}

// The t of line c that lie in the map.
fn t_range(c: i32) -> vec2<i32> {
    var r = vec2<i32>(-2147483647, 2147483647);
    r = clip(r, L.vx, L.b * c, L.w - 1);
    r = clip(r, L.vy, -L.a * c, L.h - 1);
    return r;
}

// Index in the buffers of place t on line c.
fn at(t: i32, c: i32) -> i32 {
    return (L.vy * t - L.a * c) * L.w + L.vx * t + L.b * c;
}

// The map's value at place t of line c, whose in-map places are `r`; the identity outside.
fn value(t: i32, c: i32, r: vec2<i32>) -> f32 {
    if t < r.x || t > r.y {
        return identity();
    }
    return src_buf[at(t, c)];
}

// One thread per (run of n blocks, line).
@compute @workgroup_size(8, 8)
fn segment(@builtin(global_invocation_id) id: vec3<u32>) {
    let row = i32(id.y);
    if row >= L.lines {
        return;
    }
    let c = L.lo + row;
    let r = t_range(c);
    let m = L.m;
    let k = 2 * m + 1;
    // The centre of the run's first block; its outputs are q − m … q + m.
    var q = r.x + i32(id.x) * L.n * k + m;
    for (var j = 0; j < L.n; j++) {
        if q - m > r.y {
            return;
        }
        // Leftwards: S(x) for x = q … q − 2m, stored at output u = x + m.
        var acc = identity();
        for (var x = q; x >= q - 2 * m; x--) {
            acc = pick(acc, value(x, c, r));
            if x + m <= r.y {
                out_buf[at(x + m, c)] = acc;
            }
        }
        // Rightwards: P(x) for x = q … q + 2m, folded into output u = x − m.
        acc = identity();
        for (var x = q; x <= q + 2 * m && x - m <= r.y; x++) {
            acc = pick(acc, value(x, c, r));
            let i = at(x - m, c);
            out_buf[i] = pick(out_buf[i], acc);
        }
        q += k;
    }
}

@compute @workgroup_size(8, 8)
fn from_map(@builtin(global_invocation_id) id: vec3<u32>) {
    if i32(id.x) < L.w && i32(id.y) < L.h {
        out_buf[i32(id.y) * L.w + i32(id.x)] = textureLoad(src, id.xy, 0).r;
    }
}

@compute @workgroup_size(8, 8)
fn to_map(@builtin(global_invocation_id) id: vec3<u32>) {
    if i32(id.x) < L.w && i32(id.y) < L.h {
        let v = src_buf[i32(id.y) * L.w + i32(id.x)];
        textureStore(out_map, id.xy, vec4<f32>(v, 0.0, 0.0, 1.0));
    }
}
