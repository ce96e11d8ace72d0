// HoleMap: H = 1 (hole) where the noise is below the threshold, else 0 (nodes/hole_map.rs;
// SPEC §4 eq. 4).

struct Params {
    threshold: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var noise: texture_2d<f32>;
@group(0) @binding(2) var out_holes: texture_storage_2d<r32float, write>;

@compute @workgroup_size(8, 8)
fn threshold(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_holes);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let n = textureLoad(noise, id.xy, 0).r;
    textureStore(out_holes, id.xy, vec4<f32>(select(0.0, 1.0, n < P.threshold), 0.0, 0.0, 1.0));
}
