// Tonemap: exposure and a tone curve (nodes/tonemap.rs).

struct Params {
    scale: f32,
    op: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_image: texture_storage_2d<rgba32float, write>;

fn curve(v: vec3<f32>) -> vec3<f32> {
    // Clamp first: beyond 65504 every curve is at its ceiling, and x² must not overflow.
    let x = clamp(v, vec3<f32>(0.0), vec3<f32>(65504.0));
    switch P.op {
        case 0u: { return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0)); }
        case 1u: { return x / (1.0 + x); }
        default: { return min(x, vec3<f32>(1.0)); }
    }
}

@compute @workgroup_size(8, 8)
fn tonemap(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let v = textureLoad(src, id.xy, 0);
    textureStore(out_image, id.xy, vec4<f32>(curve(v.rgb * P.scale), v.a));
}
