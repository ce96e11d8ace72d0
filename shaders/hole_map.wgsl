// HoleMap: H = 1 (hole) where the noise is below the threshold, else 0 (nodes/hole_map.rs;
// SPEC §4 eq. 4). Struct Params; bindings P, noise, out_holes, sel. The calibrated threshold's
// key comes in `sel`, selected by shaders/algorithms/quantile.wgsl (word 256: how many values
// took part, word 258: the key).

#import lib/order_key

struct Params {
    threshold: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var noise: texture_2d<f32>;
@group(0) @binding(2) var out_holes: texture_storage_2d<r32float, write>;
@group(0) @binding(3) var<storage, read_write> sel: array<u32>;


@compute @workgroup_size(8, 8)
fn threshold(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_holes);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let n = textureLoad(noise, id.xy, 0).r;
    textureStore(out_holes, id.xy, vec4<f32>(select(0.0, 1.0, n < P.threshold), 0.0, 0.0, 1.0));
}

// The threshold at the selected key (no finite value: no holes).
@compute @workgroup_size(8, 8)
fn threshold_selected(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_holes);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let n = textureLoad(noise, id.xy, 0).r;
    let hole = sel[SELECTED_N] > 0u && n < value_of(sel[SELECTED_KEY]);
    textureStore(out_holes, id.xy, vec4<f32>(select(0.0, 1.0, hole), 0.0, 0.0, 1.0));
}
