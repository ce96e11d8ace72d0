// Blur: one pass of a separable Gaussian along x or y (nodes/blur.rs). The weights come from the
// CPU (normalised there), so this pass and the CPU reference add the same terms in the same
// order; texels beyond the border repeat the edge texel.

struct Params {
    radius: i32,
    axis: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var weights: texture_2d<f32>;
@group(0) @binding(3) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(4) var out_image: texture_storage_2d<rgba32float, write>;

// Sum of w[|i|] · src[p + i·step], i = −radius … radius, coordinates clamped to the texture.
fn gather(p: vec2<i32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(src));
    let step = select(vec2<i32>(1, 0), vec2<i32>(0, 1), P.axis == 1u);
    var acc = vec4<f32>(0.0);
    for (var i = -P.radius; i <= P.radius; i++) {
        let q = clamp(p + step * i, vec2<i32>(0), size - 1);
        let w = textureLoad(weights, vec2<i32>(abs(i), 0), 0).r;
        acc += w * textureLoad(src, q, 0);
    }
    return acc;
}

@compute @workgroup_size(8, 8)
fn blur_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    textureStore(out_scalar, p, vec4<f32>(gather(p).r, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn blur_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    textureStore(out_image, p, gather(p));
}
