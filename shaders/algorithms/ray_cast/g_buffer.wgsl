// The G-buffer by ray casting: the compute alternative to the raster pass of
// algorithms/g_buffer.wgsl, writing what it writes (nodes/algorithms/ray_cast.rs).
#import algorithms/ray_cast/common

// Six vec4 per triangle: the corners' normals, then their colours.
@group(0) @binding(3) var<storage, read_write> attributes: array<vec4<f32>>;
@group(0) @binding(4) var depth_out: texture_storage_2d<r32float, write>;
@group(0) @binding(5) var normal_out: texture_storage_2d<rgba32float, write>;
@group(0) @binding(6) var albedo_out: texture_storage_2d<rgba32float, write>;

@compute @workgroup_size(8, 8)
fn g_buffer(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= P.width || id.y >= P.height { return; }
    let ray = texel_ray(id.xy);
    let h = nearest_hit(ray.a, ray.b);
    if !h.found {
        textureStore(depth_out, id.xy, vec4<f32>(P.far, 0.0, 0.0, 0.0));
        textureStore(normal_out, id.xy, vec4<f32>(0.0));
        textureStore(albedo_out, id.xy, vec4<f32>(0.0));
        return;
    }
    let w = vec3<f32>(1.0 - h.u - h.v, h.u, h.v);
    let world = ray.a + h.s * ray.b;
    let a = 6u * h.tri;
    let normal = w.x * attributes[a].xyz + w.y * attributes[a + 1u].xyz + w.z * attributes[a + 2u].xyz;
    let colour = w.x * attributes[a + 3u] + w.y * attributes[a + 4u] + w.z * attributes[a + 5u];
    // As the raster pass's fragment: normals face the eye, depth is the distance to it.
    let to_eye = P.eye - world;
    var n = normalize(normal);
    if dot(n, to_eye) < 0.0 {
        n = -n;
    }
    textureStore(depth_out, id.xy, vec4<f32>(min(length(to_eye), P.far), 0.0, 0.0, 1.0));
    textureStore(normal_out, id.xy, vec4<f32>(n, 1.0));
    textureStore(albedo_out, id.xy, vec4<f32>(colour.rgb, 1.0));
}
