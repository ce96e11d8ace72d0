// Point sampling by an integer factor (nodes/algorithms/point_sample.rs; the `Downsample` node,
// and `DepthUpsample` when it reduces a depth itself): low-res texel q takes the high-res texel at
// q·f + ⌊f/2⌋ (clamped), so depths stay depths of real surfaces.

struct PointSampleParams {
    factor: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: PointSampleParams;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(3) var out_image: texture_storage_2d<rgba32float, write>;

fn pick(q: vec2<u32>) -> vec4<f32> {
    let size = textureDimensions(src);
    let p = min(q * P.factor + P.factor / 2u, size - 1u);
    return textureLoad(src, p, 0);
}

@compute @workgroup_size(8, 8)
fn downsample_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_scalar, vec2<i32>(id.xy), vec4<f32>(pick(id.xy).r, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn downsample_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_image, vec2<i32>(id.xy), pick(id.xy));
}
