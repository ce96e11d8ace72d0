// Shadow-map tests (CPU twins: nodes/algorithms/shader_lib.rs, `shadow`).
//
// A shadow map holds, per texel, the light-space depth (0 at the light box's near plane, 1 at its
// far one) of the first surface the sun meets; `light_view_proj` maps world points to light NDC.

// Light-space (u, v, depth) of world point `x`: u, v in [0, 1] across the map (v down).
fn light_uvz(light_view_proj: mat4x4<f32>, x: vec3<f32>) -> vec3<f32> {
    let c = light_view_proj * vec4<f32>(x, 1.0);
    return vec3<f32>(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z);
}

// Whether the sun reaches light-space point `l` (see `light_uvz`): nearest texel, depth `bias`
// (light-depth units); a point outside the map or the light box is lit.
fn sun_reaches(shadow: texture_2d<f32>, l: vec3<f32>, bias: f32) -> bool {
    if l.x < 0.0 || l.x >= 1.0 || l.y < 0.0 || l.y >= 1.0 || l.z < 0.0 || l.z > 1.0 {
        return true;
    }
    let size = vec2<f32>(textureDimensions(shadow));
    let t = min(vec2<u32>(l.xy * size), vec2<u32>(size) - 1u);
    return l.z <= textureLoad(shadow, t, 0).r + bias;
}
