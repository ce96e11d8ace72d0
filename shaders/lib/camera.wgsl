// Camera and view rays (CPU twins: `screen_ray`, `pixel_ray` in src/eval/value.rs).
//
// A camera is given by the inverse of its view-projection matrix and its eye (world units).
// Screen points are in pixels, continuous, y down, of a `size` image; NDC y is up.

// Unit direction of the view ray through the screen point `q`; straight ahead (0, 0, −1) when
// the matrix maps the point onto the eye (a degenerate camera).
fn camera_ray(inv_view_proj: mat4x4<f32>, eye: vec3<f32>, q: vec2<f32>, size: vec2<u32>) -> vec3<f32> {
    let ndc = vec4<f32>(q.x / f32(size.x) * 2.0 - 1.0, 1.0 - q.y / f32(size.y) * 2.0, 1.0, 1.0);
    let far = inv_view_proj * ndc;
    let dir = far.xyz / far.w - eye;
    return select(vec3<f32>(0.0, 0.0, -1.0), normalize(dir), dot(dir, dir) > 0.0);
}

// Unit direction of the view ray through the centre of pixel `p`.
fn pixel_ray(inv_view_proj: mat4x4<f32>, eye: vec3<f32>, p: vec2<u32>, size: vec2<u32>) -> vec3<f32> {
    return camera_ray(inv_view_proj, eye, vec2<f32>(p) + 0.5, size);
}
