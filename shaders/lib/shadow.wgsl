// Shadow-map tests (CPU twins: nodes/algorithms/shader_lib.rs, `shadow`).
//
// A shadow map holds, per texel, the light-space depth (0 at the light box's near plane, 1 at its
// far one) of the first surface the light meets, or SHADOW_CLEAR where it meets none;
// `light_view_proj` maps world points to light NDC. An occluder at depth d shadows every point
// farther than d along its texel's ray, past 1 too: the map's range bounds the casters, not how
// far the light reaches.

// A clear texel (no occluder): larger than any depth, finite (tyndall_engine::eval::SHADOW_CLEAR).
const SHADOW_CLEAR: f32 = 1.0e30;

// `f`, a value computed from depth `z` by an increasing map (a slope, a perspective q), or clear
// when z is: clear is +∞, and every increasing map keeps +∞ where it is.
fn keep_clear(z: f32, f: f32) -> f32 {
    return select(f, SHADOW_CLEAR, z >= SHADOW_CLEAR);
}

// Light-space (u, v, depth) of world point `x`: u, v in [0, 1] across the map (v down).
fn light_uvz(light_view_proj: mat4x4<f32>, x: vec3<f32>) -> vec3<f32> {
    let c = light_view_proj * vec4<f32>(x, 1.0);
    return vec3<f32>(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z);
}

// Whether the light reaches light-space point `l` (see `light_uvz`): nearest texel, depth `bias`
// (light-depth units); a point outside the map's footprint is lit (no caster lies there), and so
// is one in front of its texel's occluder or under a clear texel, at any depth.
fn sun_reaches(shadow: texture_2d<f32>, l: vec3<f32>, bias: f32) -> bool {
    if l.x < 0.0 || l.x >= 1.0 || l.y < 0.0 || l.y >= 1.0 {
        return true;
    }
    let size = vec2<f32>(textureDimensions(shadow));
    let t = min(vec2<u32>(l.xy * size), vec2<u32>(size) - 1u);
    return l.z <= textureLoad(shadow, t, 0).r + bias;
}

// ---- Spot and point lights (CPU twin: tyndall_engine::scene::LocalLight) --------------------

// One light as every uniform that carries one holds it (its member `light`; Rust:
// tyndall_engine::eval::LightBlock, 128 bytes): kind 0 the sun, 1 a spot, 2 a point light;
// `view_proj` world → the light map's clip (identity for a point light's atlas); `direction`
// the way the light shines (the sun's travel, a spot's axis); `radiance` W/m² (sun) or W/sr.
struct Light {
    view_proj: mat4x4<f32>,
    position: vec3<f32>,
    kind: u32,
    direction: vec3<f32>,
    cos_inner: f32,
    radiance: vec3<f32>,
    cos_outer: f32,
    range: f32,
    near: f32,
    far: f32,
    _pad: u32,
}

// The unit direction towards a directional light (the sun).
fn towards_sun(l: Light) -> vec3<f32> {
    return -l.direction;
}

// glTF's attenuation at x: inverse square, windowed by the range, times a spot's smooth cone.
fn light_falloff(l: Light, x: vec3<f32>) -> f32 {
    let v = l.position - x;
    let d2 = max(dot(v, v), 1e-12);
    var a = 1.0 / d2;
    if l.range > 0.0 {
        let q = d2 / (l.range * l.range);
        a *= clamp(1.0 - q * q, 0.0, 1.0);
    }
    if l.kind == 1u {
        let cd = dot(l.direction, -v / sqrt(d2));
        let s = clamp((cd - l.cos_outer) / max(l.cos_inner - l.cos_outer, 1e-3), 0.0, 1.0);
        a *= s * s;
    }
    return a;
}

// Cube face of direction d from a point light: 0 +X, 1 −X, 2 +Y, 3 −Y, 4 +Z, 5 −Z.
fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    if a.x >= a.y && a.x >= a.z {
        return select(0u, 1u, d.x < 0.0);
    }
    if a.y >= a.z {
        return select(2u, 3u, d.y < 0.0);
    }
    return select(4u, 5u, d.z < 0.0);
}

// The frame of cube face `face` (see `cube_face`): columns forward f, right s, up u; the face
// shows direction f + a·s + b·u at ndc (a, b), v down (CPU twin: scene::face_basis).
fn cube_frame(face: u32) -> mat3x3<f32> {
    var f = vec3<f32>(0.0, 0.0, -1.0);
    var up = vec3<f32>(0.0, 1.0, 0.0);
    switch face {
        case 0u: { f = vec3<f32>(1.0, 0.0, 0.0); }
        case 1u: { f = vec3<f32>(-1.0, 0.0, 0.0); }
        case 2u: { f = vec3<f32>(0.0, 1.0, 0.0); up = vec3<f32>(0.0, 0.0, 1.0); }
        case 3u: { f = vec3<f32>(0.0, -1.0, 0.0); up = vec3<f32>(0.0, 0.0, 1.0); }
        case 4u: { f = vec3<f32>(0.0, 0.0, 1.0); }
        default: {}
    }
    let s = normalize(cross(f, up));
    return mat3x3<f32>(f, s, cross(s, f));
}

// Light-space (u, v, depth) of x in a spot's map (world → clip `view_proj`, linear clip z) or
// a point light's 3 × 2 cube atlas; a point behind a spot maps outside (lit, as outside any map;
// its cone gives it nothing).
fn light_uvz_local(l: Light, view_proj: mat4x4<f32>, x: vec3<f32>) -> vec3<f32> {
    if l.kind == 2u {
        let d = x - l.position;
        let face = cube_face(d);
        let frame = cube_frame(face);
        let f = frame[0];
        let s = frame[1];
        let u = frame[2];
        let depth = dot(f, d);
        let ndc = vec2<f32>(dot(s, d), dot(u, d)) / max(depth, 1e-12);
        let uv = clamp(vec2<f32>(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5), vec2<f32>(0.0), vec2<f32>(0.999999));
        let cell = vec2<f32>(f32(face % 3u), f32(face / 3u));
        return vec3<f32>((cell.x + uv.x) / 3.0, (cell.y + uv.y) / 2.0, (depth - l.near) / (l.far - l.near));
    }
    let c = view_proj * vec4<f32>(x, 1.0);
    if c.w <= 1e-9 {
        return vec3<f32>(-1.0, -1.0, 2.0);
    }
    return vec3<f32>(c.x / c.w * 0.5 + 0.5, 0.5 - c.y / c.w * 0.5, c.z);
}
