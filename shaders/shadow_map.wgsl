// ShadowMap: rasterise the scene from a light, writing light-space depth in [0, 1]
// (nodes/shadow_map.rs).

struct Params {
    light_view_proj: mat4x4<f32>,
    // 1 for a spot's or point light's perspective map, whose matrix gives linear depth in clip z
    // (scene::local_proj): the fragment writes clip z before the divide by w.
    linear_depth: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;

// Each object's placement (scene::PLACEMENT_FLOATS): object → world, and the normal matrix;
// object i is drawn as instance i.
struct Placement {
    world: mat4x4<f32>,
    normal: mat4x4<f32>,
}
@group(1) @binding(0) var<storage, read> placements: array<Placement>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) depth: f32,
}

@vertex
fn vs(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) colour: vec4<f32>, @builtin(instance_index) object: u32) -> VsOut {
    var o: VsOut;
    let world = placements[object].world * vec4<f32>(position, 1.0);
    o.clip = P.light_view_proj * vec4<f32>(world.xyz, 1.0);
    o.depth = o.clip.z;
    return o;
}

@fragment
fn fs(v: VsOut) -> @location(0) vec4<f32> {
    if P.linear_depth != 0u {
        return vec4<f32>(v.depth, 0.0, 0.0, 1.0);
    }
    // Orthographic: the fragment's depth is linear in light space.
    return vec4<f32>(v.clip.z, 0.0, 0.0, 1.0);
}
