// A point light's 3 × 2 cube atlas with gutters, so neighbourhood filters cross the faces'
// seams (nodes/algorithms/cube_atlas.rs; CPU reference there). `pad` widens every face by `gutter` texels
// on each side: a gutter texel is the face's own image plane extended (the direction
// f + a·s + b·u at |a| or |b| > 1), looked up in whichever face that direction falls on, its
// depth re-measured along this face's axis — what rendering the face with a wider field of
// view would store. A filter then runs on the padded atlas as on any map, and `crop` takes
// each face's inner square back out.

#import lib/shadow

struct CubeParams {
    // Face size, texels.
    face: u32,
    // Gutter width, texels.
    gutter: u32,
    // The map's depth range along each face's axis, m (LocalLight.near, .far).
    near: f32,
    far: f32,
}

@group(0) @binding(0) var<uniform> P: CubeParams;
@group(0) @binding(1) var src: texture_2d<f32>;
@group(0) @binding(2) var out_map: texture_storage_2d<r32float, write>;

@compute @workgroup_size(8, 8)
fn pad(@builtin(global_invocation_id) id: vec3<u32>) {
    let pf = P.face + 2u * P.gutter;
    if id.x >= 3u * pf || id.y >= 2u * pf {
        return;
    }
    let face = id.x / pf + 3u * (id.y / pf);
    let n = f32(P.face);
    // The texel's centre in this face's texel coordinates (outside [0, n) in the gutter).
    let t = vec2<f32>(id.xy % pf) + 0.5 - f32(P.gutter);
    let ndc = vec2<f32>(t.x / n * 2.0 - 1.0, 1.0 - t.y / n * 2.0);
    let frame = cube_frame(face);
    let dir = frame[0] + ndc.x * frame[1] + ndc.y * frame[2];
    let other = cube_face(dir);
    let g = cube_frame(other);
    let along = dot(g[0], dir);
    let ndc_g = vec2<f32>(dot(g[1], dir), dot(g[2], dir)) / along;
    let uv = clamp(vec2<f32>(ndc_g.x * 0.5 + 0.5, 0.5 - ndc_g.y * 0.5), vec2<f32>(0.0), vec2<f32>(0.999999));
    let texel = min(vec2<u32>(uv * n), vec2<u32>(P.face - 1u))
        + vec2<u32>(other % 3u, other / 3u) * P.face;
    let v = textureLoad(src, texel, 0).r;
    var out = v;
    if v < SHADOW_CLEAR && other != face {
        // The occluder lies at k · dir with k · along = its depth along the other face's axis;
        // along this face's axis (dot(f, dir) = 1) its depth is k.
        let span = P.far - P.near;
        let k = (P.near + v * span) / along;
        out = (k - P.near) / span;
    }
    textureStore(out_map, id.xy, vec4<f32>(out, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn crop(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= 3u * P.face || id.y >= 2u * P.face {
        return;
    }
    let pf = P.face + 2u * P.gutter;
    let face = id.x / P.face + 3u * (id.y / P.face);
    let texel = vec2<u32>(face % 3u, face / 3u) * pf + P.gutter + id.xy % P.face;
    textureStore(out_map, id.xy, textureLoad(src, texel, 0));
}
