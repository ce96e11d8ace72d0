// Dilate2D / Erode2D / Closure2D, the square and the exact circle: min (dilation) or max
// (erosion) over a square or circular footprint (nodes/morphology2d/mod.rs; SPEC §4 hole
// filling). The polygon close to the circle is lines.wgsl.
//
// Fast path: van Herk / Gil–Werman 1D filtering. A line is cut into blocks of k = 2r + 1
// texels aligned at 0; `blocks` writes each texel's running min/max from its block's start
// (prefix) and to its block's end (suffix); `combine` then takes, per texel, the window
// [x − r, x + r] = suffix(x − r) ⊕ prefix(x + r): three operations per texel whatever r is.
// Texels outside the map are not part of the kernel (they act as the operation's identity).
// Square = horizontal then vertical pass. Circle = union of horizontal chords: for each chord
// half-width w, the horizontal result R_w is computed once and `accumulate` folds in the rows
// y + dy whose chord has that half-width; total cost grows linearly with r.

struct Params {
    r: i32,
    op: u32,
    axis: u32,
    shape: u32,
    dy_lo: i32,
    dy_hi: i32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var prefix_out: texture_storage_2d<r32float, write>;
@group(0) @binding(3) var suffix_out: texture_storage_2d<r32float, write>;
@group(0) @binding(4) var prefix_in: texture_2d<f32>;
@group(0) @binding(5) var suffix_in: texture_2d<f32>;
@group(0) @binding(6) var out_map: texture_storage_2d<r32float, write>;
@group(0) @binding(7) var acc_in: texture_2d<f32>;

const BIG: f32 = 3.4028235e38;

fn identity() -> f32 {
    return select(BIG, -BIG, P.op == 1u);
}

fn pick(a: f32, b: f32) -> f32 {
    return select(min(a, b), max(a, b), P.op == 1u);
}

fn at(line: u32, i: u32) -> vec2<u32> {
    return select(vec2<u32>(i, line), vec2<u32>(line, i), P.axis == 1u);
}

fn line_length() -> u32 {
    let d = textureDimensions(src);
    return select(d.x, d.y, P.axis == 1u);
}

// One thread per (block, line).
@compute @workgroup_size(8, 8)
fn blocks(@builtin(global_invocation_id) id: vec3<u32>) {
    let d = textureDimensions(src);
    let n = line_length();
    let lines = select(d.y, d.x, P.axis == 1u);
    let k = u32(2 * P.r + 1);
    let start = id.x * k;
    if start >= n || id.y >= lines {
        return;
    }
    let end = min(start + k, n);
    var acc = identity();
    for (var i = start; i < end; i++) {
        acc = pick(acc, textureLoad(src, at(id.y, i), 0).r);
        textureStore(prefix_out, at(id.y, i), vec4<f32>(acc, 0.0, 0.0, 1.0));
    }
    acc = identity();
    for (var i = end; i > start; i--) {
        acc = pick(acc, textureLoad(src, at(id.y, i - 1u), 0).r);
        textureStore(suffix_out, at(id.y, i - 1u), vec4<f32>(acc, 0.0, 0.0, 1.0));
    }
}

@compute @workgroup_size(8, 8)
fn combine(@builtin(global_invocation_id) id: vec3<u32>) {
    let d = textureDimensions(src);
    if id.x >= d.x || id.y >= d.y {
        return;
    }
    let n = i32(line_length());
    let k = 2 * P.r + 1;
    let x = i32(select(id.x, id.y, P.axis == 1u));
    let line = select(id.y, id.x, P.axis == 1u);
    // suffix(x − r): blocks start at multiples of k, so a negative index lies in a block wholly
    // outside the map.
    var s = identity();
    let a = x - P.r;
    if a >= 0 {
        s = textureLoad(suffix_in, at(line, u32(a)), 0).r;
    }
    // prefix(x + r): past the end, the prefix of the last block stops at the map's edge; a
    // block wholly past the edge contributes nothing.
    var p = identity();
    let b = x + P.r;
    if b < n {
        p = textureLoad(prefix_in, at(line, u32(b)), 0).r;
    } else if b / k == (n - 1) / k {
        p = textureLoad(prefix_in, at(line, u32(n - 1)), 0).r;
    }
    textureStore(out_map, id.xy, vec4<f32>(pick(s, p), 0.0, 0.0, 1.0));
}

// Circle: out = acc ⊕ R_w(x, y + dy) for |dy| in [dy_lo, dy_hi] (src = R_w).
@compute @workgroup_size(8, 8)
fn accumulate(@builtin(global_invocation_id) id: vec3<u32>) {
    let d = textureDimensions(src);
    if id.x >= d.x || id.y >= d.y {
        return;
    }
    var v = textureLoad(acc_in, id.xy, 0).r;
    for (var dy = P.dy_lo; dy <= P.dy_hi; dy++) {
        for (var sgn = -1; sgn <= 1; sgn += 2) {
            if dy == 0 && sgn == 1 {
                continue;
            }
            let y = i32(id.y) + sgn * dy;
            if y >= 0 && y < i32(d.y) {
                v = pick(v, textureLoad(src, vec2<u32>(id.x, u32(y)), 0).r);
            }
        }
    }
    textureStore(out_map, id.xy, vec4<f32>(v, 0.0, 0.0, 1.0));
}

// Reference-speed path: the whole footprint per texel, O(r²).
@compute @workgroup_size(8, 8)
fn brute(@builtin(global_invocation_id) id: vec3<u32>) {
    let d = vec2<i32>(textureDimensions(src));
    if i32(id.x) >= d.x || i32(id.y) >= d.y {
        return;
    }
    var v = identity();
    for (var dy = -P.r; dy <= P.r; dy++) {
        for (var dx = -P.r; dx <= P.r; dx++) {
            if P.shape == 0u && dx * dx + dy * dy > P.r * P.r {
                continue;
            }
            let q = vec2<i32>(id.xy) + vec2<i32>(dx, dy);
            if q.x >= 0 && q.y >= 0 && q.x < d.x && q.y < d.y {
                v = pick(v, textureLoad(src, q, 0).r);
            }
        }
    }
    textureStore(out_map, id.xy, vec4<f32>(v, 0.0, 0.0, 1.0));
}
