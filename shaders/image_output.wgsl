// ImageOutput: replace non-finite samples (NaN, ±Inf) by 0 before writing (nodes/image_output.rs).
// WGSL has no isnan/isinf, and compilers may assume finite maths, so test the exponent bits.

@group(0) @binding(0) var src: texture_2d<f32>;
@group(0) @binding(1) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(2) var out_image: texture_storage_2d<rgba32float, write>;

fn finite(v: vec4<f32>) -> vec4<f32> {
    let bad = (bitcast<vec4<u32>>(v) & vec4<u32>(0x7f800000u)) == vec4<u32>(0x7f800000u);
    return select(v, vec4<f32>(0.0), bad);
}

@compute @workgroup_size(8, 8)
fn sanitize_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    textureStore(out_scalar, p, finite(textureLoad(src, p, 0)));
}

@compute @workgroup_size(8, 8)
fn sanitize_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    textureStore(out_image, p, finite(textureLoad(src, p, 0)));
}
