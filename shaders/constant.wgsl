// Constant: fill a one-channel or an RGBA texture with a uniform value (nodes/constant.rs).

struct Params {
    colour: vec4<f32>,
    value: f32,
    _pad0: f32,
    _pad1: f32,
    _pad2: f32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(2) var out_image: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(8, 8)
fn fill_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_scalar, vec2<i32>(id.xy), vec4<f32>(P.value, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn fill_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_image, vec2<i32>(id.xy), P.colour);
}
