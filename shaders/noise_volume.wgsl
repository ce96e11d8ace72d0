// NoiseVolume (nodes/noise_volume.rs): 3D Perlin noise (Perlin's improved noise with a hashed
// lattice) summed over octaves and mapped to [0, 1]; the mip chain is algorithms/volume_mips.
#import lib/hash

struct Params {
    size: vec3<u32>,
    octaves: u32,
    offset: vec3<f32>,
    frequency: f32,
    persistence: f32,
    seed: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var out_level: texture_storage_3d<r32float, write>;

fn hash(i: vec3<i32>, seed: u32) -> u32 {
    return pcg(bitcast<u32>(i.x) * 73856093u ^ bitcast<u32>(i.y) * 19349663u
        ^ bitcast<u32>(i.z) * 83492791u ^ seed * 2654435761u);
}

fn grad(h: u32, p: vec3<f32>) -> f32 {
    let k = h & 15u;
    let u = select(p.y, p.x, k < 8u);
    var v = p.z;
    if k < 4u {
        v = p.y;
    } else if k == 12u || k == 14u {
        v = p.x;
    }
    return select(-u, u, (k & 1u) == 0u) + select(-v, v, (k & 2u) == 0u);
}

fn fade(t: vec3<f32>) -> vec3<f32> {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

fn perlin(p: vec3<f32>, seed: u32) -> f32 {
    let i = vec3<i32>(floor(p));
    let f = p - floor(p);
    let u = fade(f);
    var c: array<f32, 8>;
    for (var k = 0; k < 8; k++) {
        let o = vec3<i32>(k & 1, (k >> 1u) & 1, (k >> 2u) & 1);
        c[k] = grad(hash(i + o, seed), f - vec3<f32>(o));
    }
    let x00 = mix(c[0], c[1], u.x);
    let x10 = mix(c[2], c[3], u.x);
    let x01 = mix(c[4], c[5], u.x);
    let x11 = mix(c[6], c[7], u.x);
    return mix(mix(x00, x10, u.y), mix(x01, x11, u.y), u.z);
}

@compute @workgroup_size(4, 4, 4)
fn noise(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id >= P.size) {
        return;
    }
    let q = (vec3<f32>(id) + 0.5) / vec3<f32>(P.size) * P.frequency + P.offset;
    var sum = 0.0;
    var norm = 0.0;
    var amp = 1.0;
    var scale = 1.0;
    for (var o = 0u; o < P.octaves; o++) {
        sum += amp * perlin(q * scale, P.seed + o);
        norm += amp;
        amp *= P.persistence;
        scale *= 2.0;
    }
    let v = clamp(0.5 + 0.5 * sum / max(norm, 1e-12), 0.0, 1.0);
    textureStore(out_level, id, vec4<f32>(v, 0.0, 0.0, 1.0));
}
