// EpipolarDilation / EpipolarClosure: 1D min (then max) along epipolar rays in slope space
// (nodes/epipolar.rs; SPEC §4 eq. 3, seed 001 §4.1).
//
// Each texel t (centre c_t, distance d_t from the epipole l) has the slope
// κ_t = (z_t − z_l) / d_t. Dilation: κ'_t = min(κ_t, κ_s over the `length` samples s from t
// towards l); erosion: max over the samples on the far side. Then z'_t = z_l + d_t κ'_t, which
// is the seed's `d_t/d_s · (z_s − z_l) + z_l` minimised over s.

struct Params {
    epipole: vec2<f32>,
    z_l: f32,
    length: i32,
    op: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_map: texture_storage_2d<r32float, write>;

fn slope(texel: vec2<i32>, d: f32) -> f32 {
    return (textureLoad(src, texel, 0).r - P.z_l) / d;
}

// The reference definition: `length` nearest-texel samples along the exact line, O(length).
@compute @workgroup_size(8, 8)
fn reference(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = vec2<i32>(textureDimensions(src));
    if i32(id.x) >= size.x || i32(id.y) >= size.y {
        return;
    }
    let t = vec2<i32>(id.xy);
    let c = vec2<f32>(t) + 0.5;
    let z = textureLoad(src, t, 0).r;
    let to_l = P.epipole - c;
    let d_t = length(to_l);
    if d_t <= 0.0 {
        textureStore(out_map, id.xy, vec4<f32>(z, 0.0, 0.0, 1.0));
        return;
    }
    // Dilation walks towards l and stops before reaching it; erosion walks away from l.
    let dir = select(to_l / d_t, -to_l / d_t, P.op == 1u);
    var k = (z - P.z_l) / d_t;
    for (var i = 1; i <= P.length; i++) {
        if P.op == 0u && f32(i) >= d_t {
            break;
        }
        let s = vec2<i32>(floor(c + dir * f32(i)));
        if s.x < 0 || s.y < 0 || s.x >= size.x || s.y >= size.y {
            break;
        }
        let d_s = length(P.epipole - (vec2<f32>(s) + 0.5));
        if d_s <= 0.0 {
            continue;
        }
        let ks = slope(s, d_s);
        k = select(min(k, ks), max(k, ks), P.op == 1u);
    }
    textureStore(out_map, id.xy, vec4<f32>(P.z_l + d_t * k, 0.0, 0.0, 1.0));
}
