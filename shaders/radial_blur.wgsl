// RadialBlur (nodes/radial_blur.rs): seed 003 Algorithm 1, the screen-space light-shaft blur.
// p = the pixel centre, Δ = (p − light)·density/samples; for i = 0…samples−1: p −= Δ,
// sum += bilinear(p)·decay^i·weight; out = sum·exposure. Coordinates are pixels, texel centres
// at i + 0.5; the bilinear lookup clamps to the edge.
#import lib/sampling

struct Params {
    light: vec2<f32>,
    samples: u32,
    density: f32,
    decay: f32,
    weight: f32,
    exposure: f32,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(3) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(4) var out_image: texture_storage_2d<rgba32float, write>;

fn bilinear(p: vec2<f32>) -> vec4<f32> {
    return bilinear_texels(src, p);
}

fn blur(id: vec2<u32>) -> vec4<f32> {
    var p = vec2<f32>(id) + 0.5;
    let delta = (p - P.light) * P.density / f32(P.samples);
    var sum = vec4<f32>(0.0);
    var decay = 1.0;
    for (var i = 0u; i < P.samples; i++) {
        p -= delta;
        sum += bilinear(p) * decay * P.weight;
        decay *= P.decay;
    }
    return sum * P.exposure;
}

@compute @workgroup_size(8, 8)
fn radial_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_scalar, vec2<i32>(id.xy), vec4<f32>(blur(id.xy).r, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn radial_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    textureStore(out_image, vec2<i32>(id.xy), blur(id.xy));
}
