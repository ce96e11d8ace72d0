// ImageInput: turn uploaded file data (1 or 4 channels) into the node's outputs
// (nodes/image_input.rs).

struct Params {
    channels: u32,
    channel: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(3) var out_image: texture_storage_2d<rgba32float, write>;

fn rgba(p: vec2<i32>) -> vec4<f32> {
    let v = textureLoad(src, p, 0);
    if P.channels == 1u {
        return vec4<f32>(v.r, v.r, v.r, 1.0);
    }
    return v;
}

@compute @workgroup_size(8, 8)
fn to_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    textureStore(out_image, p, rgba(p));
}

@compute @workgroup_size(8, 8)
fn to_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    let v = textureLoad(src, p, 0);
    var s: f32;
    if P.channels == 1u {
        s = v.r;
    } else {
        switch P.channel {
            case 1u: { s = v.r; }
            case 2u: { s = v.g; }
            case 3u: { s = v.b; }
            case 4u: { s = v.a; }
            default: { s = v.r * 0.2126 + v.g * 0.7152 + v.b * 0.0722; }
        }
    }
    textureStore(out_scalar, p, vec4<f32>(s, 0.0, 0.0, 1.0));
}
