// Dilate2D / Erode2D / Closure2D, circle by `method = Fast` at larger radii: min (or max) along
// the digital lines of one direction (nodes/morphology2d/polygon.rs). The polygon close to the
// disk is a Minkowski sum of such segments in up to eight directions, one pair of passes each.
//
// A direction v = (vx, vy) (gcd 1, |vx|, |vy| ≤ 2) cuts the map into lines {p + t·v}: a texel's
// line is c = vy·x − vx·y and its place on it t = a·x + b·y, with a·vx + b·vy = 1 (t grows by
// one per step v, and (x, y) = (vx·t + b·c, vy·t − a·c)). Each line is laid out in a row of
// `width` slots of the prefix and suffix buffers: slot u holds t = t0 + u − m (t0 the line's
// first texel in the map), slots outside the map the operation's identity, so texels outside
// the map are not part of a segment and no bounds are tested per texel. Along each row,
// van Herk / Gil–Werman as in chords.wgsl: blocks of k = 2m + 1 slots; `blocks` writes the
// running min/max from each block's start (prefix) and to its end (suffix); `combine` takes
// suffix(u − m) ⊕ prefix(u + m). A pass covers the lines [lo, lo + lines): maps too large for
// one buffer run in several.

struct Line {
    vx: i32,
    vy: i32,
    a: i32,
    b: i32,
    m: i32,
    op: u32,
    lo: i32,
    lines: i32,
    width: i32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> L: Line;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var<storage, read_write> prefix: array<f32>;
@group(0) @binding(3) var<storage, read_write> suffix: array<f32>;
@group(0) @binding(6) var out_map: texture_storage_2d<r32float, write>;

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
    let d = vec2<i32>(textureDimensions(src));
    var r = vec2<i32>(-2147483647, 2147483647);
    r = clip(r, L.vx, L.b * c, d.x - 1);
    r = clip(r, L.vy, -L.a * c, d.y - 1);
    return r;
}

fn at(t: i32, c: i32) -> vec2<u32> {
    return vec2<u32>(u32(L.vx * t + L.b * c), u32(L.vy * t - L.a * c));
}

// One thread per (block of slots, line).
@compute @workgroup_size(8, 8)
fn blocks(@builtin(global_invocation_id) id: vec3<u32>) {
    let row = i32(id.y);
    let k = 2 * L.m + 1;
    let start = i32(id.x) * k;
    if row >= L.lines || start >= L.width {
        return;
    }
    let c = L.lo + row;
    let r = t_range(c);
    if r.x > r.y {
        return;
    }
    let base = row * L.width;
    let end = min(start + k, L.width);
    var acc = identity();
    for (var u = start; u < end; u++) {
        let t = r.x + u - L.m;
        if t >= r.x && t <= r.y {
            acc = pick(acc, textureLoad(src, at(t, c), 0).r);
        }
        prefix[base + u] = acc;
    }
    acc = identity();
    for (var u = end - 1; u >= start; u--) {
        let t = r.x + u - L.m;
        if t >= r.x && t <= r.y {
            acc = pick(acc, textureLoad(src, at(t, c), 0).r);
        }
        suffix[base + u] = acc;
    }
}

@compute @workgroup_size(8, 8)
fn combine(@builtin(global_invocation_id) id: vec3<u32>) {
    let d = textureDimensions(src);
    if id.x >= d.x || id.y >= d.y {
        return;
    }
    let x = i32(id.x);
    let y = i32(id.y);
    let c = L.vy * x - L.vx * y;
    let row = c - L.lo;
    if row < 0 || row >= L.lines {
        return;
    }
    let t = L.a * x + L.b * y;
    // Slot of t is u = t − t0 + m; the window [u − m, u + m] spans at most two blocks.
    let u = t - t_range(c).x + L.m;
    let base = row * L.width;
    let v = pick(suffix[base + u - L.m], prefix[base + u + L.m]);
    textureStore(out_map, id.xy, vec4<f32>(v, 0.0, 0.0, 1.0));
}
