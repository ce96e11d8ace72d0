// SingleScattering, method MinMax: the min-max pyramid's layout and bindings, shared by the
// sun's walk (min_max.wgsl) and the lamps' (min_max_lamp.wgsl); Epipolar's fall-back rays
// read it too.
#import single_scattering/map_ray

struct Levels {
    count: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    rect: array<vec4<u32>, 16>,
}

@group(0) @binding(6) var atlas: texture_2d<f32>;
@group(0) @binding(10) var<uniform> L: Levels;
