// Composite: Lambert + ambient surfaces shadowed with the original shadow map, attenuated by
// the medium, plus in-scatter (nodes/composite.rs).
#import lib/camera
#import lib/sampling
#import lib/shadow
#import lib/box_volume

struct Params {
    inv_view_proj: mat4x4<f32>,
    eye: vec3<f32>,
    pcf: u32,
    bias: f32,
    has_inscatter: u32,
    has_transmittance: u32,
    has_aerial_transmittance: u32,
    has_aerial_inscatter: u32,
    has_light_map: u32,
    has_light_transmittance: u32,
    _pad1: u32,
    ambient: vec4<f32>,
    sky: vec4<f32>,
    light_map_view_proj: mat4x4<f32>,
    // The light transmittance volume's box (SingleScattering with a density).
    tr_lo: vec3<f32>,
    _pad2: u32,
    tr_hi: vec3<f32>,
    _pad3: u32,
    // The shadow map's light (lib/shadow.wgsl).
    light: Light,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var albedo: texture_2d<f32>;
@group(0) @binding(2) var normal: texture_2d<f32>;
@group(0) @binding(3) var depth: texture_2d<f32>;
@group(0) @binding(4) var shadow: texture_2d<f32>;
@group(0) @binding(5) var inscatter: texture_2d<f32>;
@group(0) @binding(6) var transmittance: texture_2d<f32>;
@group(0) @binding(7) var out_image: texture_storage_2d<rgba32float, write>;
@group(0) @binding(8) var aerial_transmittance: texture_2d<f32>;
@group(0) @binding(9) var aerial_inscatter: texture_2d<f32>;
@group(0) @binding(10) var light_map: texture_2d<f32>;
@group(0) @binding(11) var light_tr: texture_3d<f32>;

// The light map's colour at world point `x` (1 when none is connected): bilinear, texel centres
// at (i + 0.5)/size, clamped to the edge, as SingleScattering reads it for the medium.
fn sun_colour(x: vec3<f32>) -> vec3<f32> {
    if P.has_light_map == 0u {
        return vec3<f32>(1.0);
    }
    let c = P.light_map_view_proj * vec4<f32>(x, 1.0);
    let uv = vec2<f32>(c.x / c.w * 0.5 + 0.5, 0.5 - c.y / c.w * 0.5);
    return bilinear_texels(light_map, uv * vec2<f32>(textureDimensions(light_map))).rgb;
}

fn surface_shadow(x: vec3<f32>) -> f32 {
    var uvz = light_uvz(P.light.view_proj, x);
    if P.light.kind != 0u {
        uvz = light_uvz_local(P.light, P.light.view_proj, x);
    }
    let size = vec2<i32>(textureDimensions(shadow));
    let centre = vec2<i32>(floor(uvz.xy * vec2<f32>(size)));
    let r = i32(P.pcf);
    var lit = 0.0;
    var n = 0.0;
    for (var dy = -r; dy <= r; dy++) {
        for (var dx = -r; dx <= r; dx++) {
            let t = centre + vec2<i32>(dx, dy);
            n += 1.0;
            if t.x < 0 || t.y < 0 || t.x >= size.x || t.y >= size.y {
                lit += 1.0;
            } else {
                lit += select(0.0, 1.0, uvz.z <= textureLoad(shadow, t, 0).r + P.bias);
            }
        }
    }
    return lit / n;
}

@compute @workgroup_size(8, 8)
fn composite(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let a = textureLoad(albedo, id.xy, 0);
    var colour: vec3<f32>;
    if a.a > 0.5 {
        let dir = pixel_ray(P.inv_view_proj, P.eye, id.xy, size);
        let x = P.eye + dir * textureLoad(depth, id.xy, 0).r;
        let n = textureLoad(normal, id.xy, 0).xyz;
        var to_light = towards_sun(P.light);
        var falloff = 1.0;
        var far = 1e30;
        if P.light.kind != 0u {
            to_light = normalize(P.light.position - x);
            falloff = light_falloff(P.light, x);
            far = length(P.light.position - x);
        }
        var through = 1.0;
        if P.has_light_transmittance != 0u {
            through = box_towards(light_tr, P.tr_lo, P.tr_hi, x, to_light, far);
        }
        let direct = P.light.radiance * sun_colour(x) * (max(dot(n, to_light), 0.0) * falloff) * (surface_shadow(x) * through);
        colour = a.rgb * (P.ambient.rgb + direct);
    } else {
        colour = P.sky.rgb;
    }
    if P.has_transmittance != 0u {
        colour *= textureLoad(transmittance, id.xy, 0).r;
    }
    if P.has_inscatter != 0u {
        colour += textureLoad(inscatter, id.xy, 0).rgb;
    }
    if P.has_aerial_transmittance != 0u {
        colour *= textureLoad(aerial_transmittance, id.xy, 0).rgb;
    }
    if P.has_aerial_inscatter != 0u {
        colour += textureLoad(aerial_inscatter, id.xy, 0).rgb;
    }
    textureStore(out_image, id.xy, vec4<f32>(colour, 1.0));
}
