// HoleComposite: punch holes into an object-only shadow map, then combine with the rest of the
// scene's map (nodes/hole_composite.rs; SPEC §4 hole creation).
#import lib/shadow

@group(0) @binding(0) var object_map: texture_2d<f32>;
@group(0) @binding(1) var holes: texture_2d<f32>;
@group(0) @binding(2) var rest_map: texture_2d<f32>;
@group(0) @binding(3) var out_map: texture_storage_2d<r32float, write>;

@compute @workgroup_size(8, 8)
fn composite(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_map);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    // The hole map may have another size: sample it at the same normalised position (nearest).
    let hs = textureDimensions(holes);
    let hc = min(vec2<u32>((vec2<f32>(id.xy) + 0.5) / vec2<f32>(size) * vec2<f32>(hs)), hs - 1u);
    let hole = textureLoad(holes, hc, 0).r > 0.5;
    // A hole is clear: no occluder, at any depth.
    let object = select(textureLoad(object_map, id.xy, 0).r, SHADOW_CLEAR, hole);
    textureStore(out_map, id.xy, vec4<f32>(min(object, textureLoad(rest_map, id.xy, 0).r), 0.0, 0.0, 1.0));
}
