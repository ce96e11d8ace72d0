// SideBySide: two images next to each other, left then right (nodes/side_by_side.rs).

@group(0) @binding(0) var left: texture_2d<f32>;
@group(0) @binding(1) var right: texture_2d<f32>;
@group(0) @binding(2) var out_image: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(8, 8)
fn join(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let lw = textureDimensions(left);
    let rw = textureDimensions(right);
    var v = vec4<f32>(0.0, 0.0, 0.0, 1.0);
    if id.x < lw.x {
        if id.y < lw.y {
            v = textureLoad(left, id.xy, 0);
        }
    } else {
        let p = vec2<u32>(id.x - lw.x, id.y);
        if p.y < rw.y {
            v = textureLoad(right, p, 0);
        }
    }
    textureStore(out_image, id.xy, v);
}
