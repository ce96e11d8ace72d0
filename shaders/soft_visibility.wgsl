// SoftVisibility: iterative-convolution soft shadows (nodes/soft_visibility/; seed 004).
// One dispatch per slice: A_k = min(1, (A_{k−1} ∗ κ_k) + o_k), written to the next buffer and
// to slice k of the volume.
//
// The buffers are `tiles` of (res + 2 gutter)² texels side by side: one tile for a sun's or a
// spot's map (gutter 0), 3 × 2 for a point light's cube atlas, each face with a gutter in which
// its neighbours' occluders are seen (the map padded the same way, `map_gutter` texels, by
// algorithms/cube_atlas.wgsl), so penumbrae cross the cube's seams. A tile's convolution reads
// nothing outside it; the volume keeps each tile's inner res² texels.

struct Params {
    res: u32,
    slice: u32,
    slices: u32,
    taps: u32,
    // One tile of the map (the whole map but for a cube atlas), texels.
    map_tile: vec2<u32>,
    footprint: u32,
    bias: f32,
    // growth = linear: the per-axis variance added per slice is (2 n̄ − 1) · step_var, n̄ the
    // occluders' mean age in slices (linear = 0: growth = seed, the stencil).
    step_var: vec2<f32>,
    linear: u32,
    // 1: a spot's perspective map, whose slices are equal steps of q = 1 − near / w (w the
    // distance along its axis) instead of equal steps of depth.
    persp: u32,
    near: f32,
    far: f32,
    // Where a spot's slices start, m along its axis: its nearest occluder (nothing nearer
    // casts a shadow, so no slice is spent there).
    start: f32,
    // Each tile's gutter, buffer texels.
    gutter: u32,
    // Tiles across and down: (1, 1), or (3, 2) for a cube atlas.
    tiles: vec2<u32>,
    // Each map tile's gutter, map texels.
    map_gutter: u32,
    // Tangent of a lamp map's half-angle (1 on a cube face).
    tan_half: f32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var prev: texture_2d<f32>;
@group(0) @binding(2) var stencil: texture_2d<f32>;
@group(0) @binding(3) var shadow: texture_2d<f32>;
@group(0) @binding(4) var next: texture_storage_2d<rg32float, write>;
@group(0) @binding(5) var volume: texture_storage_3d<r32float, write>;

// The tile this invocation works in.
var<private> CELL: vec2<u32>;

// A tile's side in buffer texels.
fn tile_side() -> u32 {
    return P.res + 2u * P.gutter;
}

// (A, Z) of the previous slice at texel q of this tile, zero outside it.
fn load(q: vec2<i32>) -> vec2<f32> {
    let side = i32(tile_side());
    if q.x < 0 || q.y < 0 || q.x >= side || q.y >= side {
        return vec2<f32>(0.0);
    }
    return textureLoad(prev, CELL * tile_side() + vec2<u32>(q), 0).rg;
}

// Bilinear (A, Z) at p + o.
fn bilinear(p: vec2<i32>, o: vec2<f32>) -> vec2<f32> {
    let f = floor(o);
    let a = o - f;
    let q = p + vec2<i32>(f);
    return mix(
        mix(load(q), load(q + vec2<i32>(1, 0)), a.x),
        mix(load(q + vec2<i32>(0, 1)), load(q + vec2<i32>(1, 1)), a.x),
        a.y,
    );
}

// The offset s ≥ 0 whose symmetric pair ±s, read bilinearly, has variance v:
// m² + f (2m + 1) = v with s = m + f.
fn pair_offset(v: f32) -> f32 {
    let m = floor(sqrt(max(v, 0.0)));
    return m + (max(v, 0.0) - m * m) / (2.0 * m + 1.0);
}

// The per-axis factor (1 + m²) on a lamp's per-slice variance at tile texel position q (map
// tangent m): a sphere of light seen off the axis spreads a shadow edge wider
// (soft_visibility::off_axis); 1 for the sun.
fn off_axis(q: vec2<f32>) -> vec2<f32> {
    if P.persp == 0u {
        return vec2<f32>(1.0);
    }
    let m = ((q - f32(P.gutter) + 0.5) / f32(P.res) * 2.0 - 1.0) * P.tan_half;
    return vec2<f32>(1.0) + m * m;
}

// Where depth z falls along the slices, 0…1: z itself (the sun's box), or for a spot
// q / q_far, q = 1 − start / w and w = near + z (far − near) (1/w, not w, is affine across a
// perspective map, and a sphere of light's penumbra grows linearly in 1/w behind an occluder).
fn slice_coord(z: f32) -> f32 {
    if P.persp == 0u {
        return z;
    }
    let w = P.near + z * (P.far - P.near);
    return (1.0 - P.start / w) / (1.0 - P.start / P.far);
}

// The part of tile texel p's footprint in the shadow map whose occluder (map depth + bias) lies
// in slice k: [k, k + 1)/slices of `slice_coord`. Texel p − gutter of the face's res² maps to
// the map tile's inner part, past its gutter.
fn coverage(p: vec2<u32>) -> f32 {
    let lo = f32(P.slice) / f32(P.slices);
    let hi = f32(P.slice + 1u) / f32(P.slices);
    let inner = vec2<f32>(P.map_tile - 2u * P.map_gutter);
    let g = f32(P.gutter);
    var hit = 0.0;
    let n = P.footprint;
    for (var j = 0u; j < n; j++) {
        for (var i = 0u; i < n; i++) {
            let u = ((f32(p.x) - g) + (f32(i) + 0.5) / f32(n)) / f32(P.res);
            let v = ((f32(p.y) - g) + (f32(j) + 0.5) / f32(n)) / f32(P.res);
            let m = max(vec2<f32>(u, v) * inner + f32(P.map_gutter), vec2<f32>(0.0));
            let t = min(vec2<u32>(m), P.map_tile - 1u) + CELL * P.map_tile;
            // A neighbour's occluder seen in a cube face's gutter can lie nearer than the
            // slices' start: it falls in the first slice.
            let d = max(slice_coord(textureLoad(shadow, t, 0).r + P.bias), 0.0);
            if d >= lo && d < hi {
                hit += 1.0;
            }
        }
    }
    return hit / f32(n * n);
}

@compute @workgroup_size(8, 8)
fn propagate(@builtin(global_invocation_id) id: vec3<u32>) {
    let side = tile_side();
    if id.x >= P.tiles.x * side || id.y >= P.tiles.y * side {
        return;
    }
    CELL = id.xy / side;
    let local = id.xy % side;
    var acc = vec2<f32>(0.0);
    if P.slice > 0u {
        let p = vec2<i32>(local);
        if P.linear != 0u {
            let sv = P.step_var * off_axis(vec2<f32>(p));
            // The occluders' mean age near p: probe two standard deviations of the oldest
            // possible occluder's spread (slice 0: k √step_var) plus a texel, so lit texels
            // beside a shadow see its age too.
            let r = 2.0 * f32(P.slice) * sqrt(sv) + vec2<f32>(1.0);
            let c = load(p) + bilinear(p, vec2<f32>(-r.x, -r.y)) + bilinear(p, vec2<f32>(r.x, -r.y))
                + bilinear(p, vec2<f32>(-r.x, r.y)) + bilinear(p, vec2<f32>(r.x, r.y));
            var age = 0.0;
            if c.x > 0.0 {
                age = f32(P.slice) - c.y / c.x;
            }
            // n slices behind an occluder the variance grows from (n − 1)² to n² step_var.
            let base = max(2.0 * age - 1.0, 1.0) * P.step_var;
            let v = base * off_axis(vec2<f32>(p));
            var lo = vec2<f32>(pair_offset(v.x), pair_offset(v.y));
            var hi = lo;
            if P.persp != 0u {
                // Each occluder spreads by the variance where it lies, not where its shadow
                // lands (else the half shadow drifts towards the wider side): a tap's offset is
                // the one at its source, p ∓ the offset here.
                let vl = base * off_axis(vec2<f32>(p) - lo);
                let vh = base * off_axis(vec2<f32>(p) + lo);
                lo = vec2<f32>(pair_offset(vl.x), pair_offset(vl.y));
                hi = vec2<f32>(pair_offset(vh.x), pair_offset(vh.y));
            }
            acc = 0.25 * (bilinear(p, vec2<f32>(-lo.x, -lo.y)) + bilinear(p, vec2<f32>(hi.x, -lo.y))
                + bilinear(p, vec2<f32>(-lo.x, hi.y)) + bilinear(p, vec2<f32>(hi.x, hi.y)));
        } else {
            for (var t = 0u; t < P.taps; t++) {
                let st = textureLoad(stencil, vec2<u32>(t, P.slice), 0);
                acc += st.z * load(p + vec2<i32>(i32(st.x), i32(st.y)));
            }
        }
    }
    let o = coverage(local);
    let a = min(1.0, acc.x + o);
    // Z: the occlusion-weighted slice index of the occluders, carried like A.
    textureStore(next, id.xy, vec4<f32>(a, acc.y + o * f32(P.slice), 0.0, 1.0));
    // The volume holds each tile's inner res² texels.
    let q = local - vec2<u32>(P.gutter);
    if all(local >= vec2<u32>(P.gutter)) && all(q < vec2<u32>(P.res)) {
        textureStore(volume, vec3<u32>(CELL * P.res + q, P.slice), vec4<f32>(a, 0.0, 0.0, 1.0));
    }
}
