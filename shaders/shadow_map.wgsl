// ShadowMap: rasterise the scene from the sun, writing light-space depth in [0, 1]
// (nodes/shadow_map.rs).

struct Params {
    light_view_proj: mat4x4<f32>,
}

@group(0) @binding(0) var<uniform> P: Params;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
}

@vertex
fn vs(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) colour: vec4<f32>) -> VsOut {
    var o: VsOut;
    o.clip = P.light_view_proj * vec4<f32>(position, 1.0);
    return o;
}

@fragment
fn fs(v: VsOut) -> @location(0) vec4<f32> {
    // Orthographic: the fragment's depth is linear in light space.
    return vec4<f32>(v.clip.z, 0.0, 0.0, 1.0);
}
