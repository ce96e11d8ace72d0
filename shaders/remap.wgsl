// Remap: linear range-to-range map with optional clamp (nodes/remap.rs).

struct Params {
    from_min: f32,
    from_max: f32,
    to_min: f32,
    to_max: f32,
    clamp: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(3) var out_image: texture_storage_2d<rgba32float, write>;

fn remap(x: f32) -> f32 {
    let span = P.from_max - P.from_min;
    var y: f32;
    if span == 0.0 {
        y = select(P.to_max, P.to_min, x < P.from_min);
    } else {
        y = P.to_min + (x - P.from_min) * ((P.to_max - P.to_min) / span);
    }
    if P.clamp != 0u {
        y = min(max(y, min(P.to_min, P.to_max)), max(P.to_min, P.to_max));
    }
    return y;
}

@compute @workgroup_size(8, 8)
fn remap_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    let v = textureLoad(src, p, 0);
    textureStore(out_scalar, p, vec4<f32>(remap(v.r), 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn remap_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    let v = textureLoad(src, p, 0);
    textureStore(out_image, p, vec4<f32>(remap(v.r), remap(v.g), remap(v.b), v.a));
}
