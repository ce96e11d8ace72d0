// SoftVisibility: iterative-convolution soft shadows (nodes/soft_visibility/; seed 004).
// One dispatch per slice: A_k = min(1, (A_{k−1} ∗ κ_k) + o_k), written to the next buffer and
// to slice k of the volume.

struct Params {
    res: u32,
    slice: u32,
    slices: u32,
    taps: u32,
    map_size: vec2<u32>,
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
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var prev: texture_2d<f32>;
@group(0) @binding(2) var stencil: texture_2d<f32>;
@group(0) @binding(3) var shadow: texture_2d<f32>;
@group(0) @binding(4) var next: texture_storage_2d<rg32float, write>;
@group(0) @binding(5) var volume: texture_storage_3d<r32float, write>;

// (A, Z) of the previous slice at texel q, zero outside the buffer.
fn load(q: vec2<i32>) -> vec2<f32> {
    if q.x < 0 || q.y < 0 || q.x >= i32(P.res) || q.y >= i32(P.res) {
        return vec2<f32>(0.0);
    }
    return textureLoad(prev, vec2<u32>(q), 0).rg;
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

// The part of texel p's footprint in the shadow map whose occluder (map depth + bias) lies in
// slice k: [k, k + 1)/slices of `slice_coord`.
fn coverage(p: vec2<u32>) -> f32 {
    let lo = f32(P.slice) / f32(P.slices);
    let hi = f32(P.slice + 1u) / f32(P.slices);
    var hit = 0.0;
    let n = P.footprint;
    for (var j = 0u; j < n; j++) {
        for (var i = 0u; i < n; i++) {
            let u = (f32(p.x) + (f32(i) + 0.5) / f32(n)) / f32(P.res);
            let v = (f32(p.y) + (f32(j) + 0.5) / f32(n)) / f32(P.res);
            let t = min(vec2<u32>(vec2<f32>(u, v) * vec2<f32>(P.map_size)), P.map_size - 1u);
            let d = slice_coord(textureLoad(shadow, t, 0).r + P.bias);
            if d >= lo && d < hi {
                hit += 1.0;
            }
        }
    }
    return hit / f32(n * n);
}

@compute @workgroup_size(8, 8)
fn propagate(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= P.res || id.y >= P.res {
        return;
    }
    var acc = vec2<f32>(0.0);
    if P.slice > 0u {
        let p = vec2<i32>(id.xy);
        if P.linear != 0u {
            // The occluders' mean age near p: probe two standard deviations of the oldest
            // possible occluder's spread (slice 0: k √step_var) plus a texel, so lit texels
            // beside a shadow see its age too.
            let r = 2.0 * f32(P.slice) * sqrt(P.step_var) + vec2<f32>(1.0);
            let c = load(p) + bilinear(p, vec2<f32>(-r.x, -r.y)) + bilinear(p, vec2<f32>(r.x, -r.y))
                + bilinear(p, vec2<f32>(-r.x, r.y)) + bilinear(p, vec2<f32>(r.x, r.y));
            var age = 0.0;
            if c.x > 0.0 {
                age = f32(P.slice) - c.y / c.x;
            }
            // n slices behind an occluder the variance grows from (n − 1)² to n² step_var.
            let v = max(2.0 * age - 1.0, 1.0) * P.step_var;
            let s = vec2<f32>(pair_offset(v.x), pair_offset(v.y));
            acc = 0.25 * (bilinear(p, vec2<f32>(-s.x, -s.y)) + bilinear(p, vec2<f32>(s.x, -s.y))
                + bilinear(p, vec2<f32>(-s.x, s.y)) + bilinear(p, vec2<f32>(s.x, s.y)));
        } else {
            for (var t = 0u; t < P.taps; t++) {
                let st = textureLoad(stencil, vec2<u32>(t, P.slice), 0);
                acc += st.z * load(p + vec2<i32>(i32(st.x), i32(st.y)));
            }
        }
    }
    let o = coverage(id.xy);
    let a = min(1.0, acc.x + o);
    // Z: the occlusion-weighted slice index of the occluders, carried like A.
    textureStore(next, id.xy, vec4<f32>(a, acc.y + o * f32(P.slice), 0.0, 1.0));
    textureStore(volume, vec3<u32>(id.xy, P.slice), vec4<f32>(a, 0.0, 0.0, 1.0));
}
