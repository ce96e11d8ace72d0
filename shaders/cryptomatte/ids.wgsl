// Cryptomatte, pass 1 (nodes/cryptomatte.rs): the object each sub-pixel sample sees. The scene is
// rasterised at `samples` × the output size; each sample holds its object's index + 1 as a
// float (exact to 2^24 objects), 0 where no surface is (the sky; fog has no ID).

struct IdParams {
    view_proj: mat4x4<f32>,
}

@group(0) @binding(0) var<uniform> P: IdParams;

// Each object's placement (scene::PLACEMENT_FLOATS): object → world, and the normal matrix;
// object i is drawn as instance i.
struct Placement {
    world: mat4x4<f32>,
    normal: mat4x4<f32>,
}
@group(1) @binding(0) var<storage, read> placements: array<Placement>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) @interpolate(flat) object: u32,
}

@vertex
fn vs(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) colour: vec4<f32>, @builtin(instance_index) object: u32) -> VsOut {
    var o: VsOut;
    let world = placements[object].world * vec4<f32>(position, 1.0);
    o.clip = P.view_proj * vec4<f32>(world.xyz, 1.0);
    o.object = object;
    return o;
}

@fragment
fn fs(v: VsOut) -> @location(0) vec4<f32> {
    return vec4<f32>(f32(v.object + 1u), 0.0, 0.0, 1.0);
}
