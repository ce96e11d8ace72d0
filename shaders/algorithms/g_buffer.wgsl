// A scene's G-buffer: camera linear depth (distance), world normal and albedo
// (nodes/algorithms/g_buffer.rs; the `GBuffer` node, and `LightMapSolve`'s painted views).

struct GBufferParams {
    view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    far: f32,
}

@group(0) @binding(0) var<uniform> P: GBufferParams;

// Each object's placement (scene::PLACEMENT_FLOATS): object → world, and the normal matrix;
// object i is drawn as instance i.
struct Placement {
    world: mat4x4<f32>,
    normal: mat4x4<f32>,
}
@group(1) @binding(0) var<storage, read> placements: array<Placement>;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec4<f32>,
}

struct FsOut {
    @location(0) depth: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) albedo: vec4<f32>,
}

@vertex
fn vs(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) colour: vec4<f32>, @builtin(instance_index) object: u32) -> VsOut {
    var o: VsOut;
    let m = placements[object];
    let world = (m.world * vec4<f32>(position, 1.0)).xyz;
    o.clip = P.view_proj * vec4<f32>(world, 1.0);
    o.world = world;
    o.normal = (m.normal * vec4<f32>(normal, 0.0)).xyz;
    o.colour = colour;
    return o;
}

@fragment
fn fs(v: VsOut) -> FsOut {
    var o: FsOut;
    let to_eye = P.eye - v.world;
    var n = normalize(v.normal);
    if dot(n, to_eye) < 0.0 {
        n = -n;
    }
    o.depth = vec4<f32>(min(length(to_eye), P.far), 0.0, 0.0, 1.0);
    o.normal = vec4<f32>(n, 1.0);
    o.albedo = vec4<f32>(v.colour.rgb, 1.0);
    return o;
}
