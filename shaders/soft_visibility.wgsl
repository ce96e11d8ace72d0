// SoftVisibility: iterative-convolution soft shadows (nodes/soft_visibility.rs; seed 004).
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
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var prev: texture_2d<f32>;
@group(0) @binding(2) var stencil: texture_2d<f32>;
@group(0) @binding(3) var shadow: texture_2d<f32>;
@group(0) @binding(4) var next: texture_storage_2d<r32float, write>;
@group(0) @binding(5) var volume: texture_storage_3d<r32float, write>;

// The part of texel p's footprint in the shadow map whose occluder (map depth + bias) lies in
// slice k: [k, k + 1)/slices of light depth.
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
            let d = textureLoad(shadow, t, 0).r + P.bias;
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
    var acc = 0.0;
    if P.slice > 0u {
        for (var t = 0u; t < P.taps; t++) {
            let s = textureLoad(stencil, vec2<u32>(t, P.slice), 0);
            let q = vec2<i32>(id.xy) + vec2<i32>(i32(s.x), i32(s.y));
            if q.x >= 0 && q.y >= 0 && q.x < i32(P.res) && q.y < i32(P.res) {
                acc += s.z * textureLoad(prev, vec2<u32>(q), 0).r;
            }
        }
    }
    let a = min(1.0, acc + coverage(id.xy));
    textureStore(next, id.xy, vec4<f32>(a, 0.0, 0.0, 1.0));
    textureStore(volume, vec3<u32>(id.xy, P.slice), vec4<f32>(a, 0.0, 0.0, 1.0));
}
