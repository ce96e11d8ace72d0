// A shadow map by ray casting: the compute alternative to the raster pass of shadow_map.wgsl,
// writing what it writes (nodes/algorithms/ray_cast.rs).
#import algorithms/ray_cast/common
#import lib/shadow

@group(0) @binding(3) var depth_out: texture_storage_2d<r32float, write>;

@compute @workgroup_size(8, 8)
fn shadow(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= P.width || id.y >= P.height { return; }
    let ray = texel_ray(id.xy);
    let h = nearest_hit(ray.a, ray.b);
    if !h.found {
        textureStore(depth_out, id.xy, vec4<f32>(SHADOW_CLEAR, 0.0, 0.0, 0.0));
        return;
    }
    let c = P.view_proj * vec4<f32>(ray.a + h.s * ray.b, 1.0);
    let z = select(c.z / c.w, c.z, P.linear_depth != 0u);
    textureStore(depth_out, id.xy, vec4<f32>(z, 0.0, 0.0, 1.0));
}
