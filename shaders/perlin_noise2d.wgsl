// PerlinNoise2D: gradient noise for hole maps (nodes/perlin_noise2d.rs; SPEC §4 eq. 4–5).
#import lib/hash

struct Params {
    scale: f32,
    persistence: f32,
    octaves: u32,
    mode: u32,
    seed: u32,
    angle: f32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var out_noise: texture_storage_2d<r32float, write>;

fn hash(x: i32, y: i32, s: u32) -> u32 {
    return pcg(bitcast<u32>(x) * 1597334677u ^ bitcast<u32>(y) * 3812015801u ^ s * 2891336453u);
}

// Eight unit-ish gradients, chosen exactly so CPU and GPU agree.
fn gradient(h: u32) -> vec2<f32> {
    switch h & 7u {
        case 0u: { return vec2<f32>(1.0, 0.0); }
        case 1u: { return vec2<f32>(-1.0, 0.0); }
        case 2u: { return vec2<f32>(0.0, 1.0); }
        case 3u: { return vec2<f32>(0.0, -1.0); }
        case 4u: { return vec2<f32>(0.70710677, 0.70710677); }
        case 5u: { return vec2<f32>(-0.70710677, 0.70710677); }
        case 6u: { return vec2<f32>(0.70710677, -0.70710677); }
        default: { return vec2<f32>(-0.70710677, -0.70710677); }
    }
}

fn fade(t: f32) -> f32 {
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

// Classic 2D Perlin noise, about [−0.71, 0.71].
fn perlin(q: vec2<f32>, s: u32) -> f32 {
    let c = floor(q);
    let f = q - c;
    let i = vec2<i32>(c);
    let n00 = dot(gradient(hash(i.x, i.y, s)), f);
    let n10 = dot(gradient(hash(i.x + 1, i.y, s)), f - vec2<f32>(1.0, 0.0));
    let n01 = dot(gradient(hash(i.x, i.y + 1, s)), f - vec2<f32>(0.0, 1.0));
    let n11 = dot(gradient(hash(i.x + 1, i.y + 1, s)), f - vec2<f32>(1.0, 1.0));
    let u = vec2<f32>(fade(f.x), fade(f.y));
    return mix(mix(n00, n10, u.x), mix(n01, n11, u.x), u.y);
}

// Octave sum normalised to [0, 1]: mode 0 is the seed's eq. 5 as read in SPEC §4
// (octave i samples q / max(1, o − i − 1)), mode 1 classic fBm (octave i samples q · 2^i).
fn octaves(q: vec2<f32>) -> f32 {
    var sum = 0.0;
    var norm = 0.0;
    var amp = 1.0;
    for (var i = 0u; i < P.octaves; i++) {
        var qi: vec2<f32>;
        if P.mode == 0u {
            qi = q / max(1.0, f32(P.octaves) - f32(i) - 1.0);
        } else {
            qi = q * exp2(f32(i));
        }
        sum += amp * perlin(qi, P.seed + i * 7919u);
        norm += amp;
        amp *= P.persistence;
    }
    let n = select(0.0, sum / norm, norm > 0.0);
    return clamp(n / 1.4142135 + 0.5, 0.0, 1.0);
}

@compute @workgroup_size(8, 8)
fn noise(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_noise);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let uv = (vec2<f32>(id.xy) + 0.5) / vec2<f32>(size);
    var q = uv * P.scale;
    if P.angle != 0.0 {
        // Two-step animated lookup (seed 000): rotate the point, look the noise up, use that as
        // an offset to the original point, look up again.
        let c = cos(P.angle);
        let s = sin(P.angle);
        let r = vec2<f32>(c * q.x - s * q.y, s * q.x + c * q.y);
        let o = octaves(r + vec2<f32>(17.0, 31.0)) - 0.5;
        q = q + vec2<f32>(o, -o) * 2.0;
    }
    textureStore(out_noise, id.xy, vec4<f32>(octaves(q), 0.0, 0.0, 1.0));
}
