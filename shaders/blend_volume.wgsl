// BlendVolume (nodes/blend_volume.rs): bake painted splats into level 0 of a volume. Each texel
// starts at `base`; splats apply in order: w = opacity · falloff(d), d the ellipsoidal distance
// of the texel centre from the splat's centre in the splat's rotated frame (1 on its surface),
// falloff = 1 inside d ≤ hardness, smoothstep down to 0 at d = 1; v = mix(v, value, w), or
// mix(v, base, w) for an eraser.

struct Params {
    size: vec3<u32>,
    count: u32,
    box_min: vec3<f32>,
    base: f32,
    box_max: vec3<f32>,
    _pad0: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var out_level: texture_storage_3d<r32float, write>;
// Splat k occupies texels (0…3, k): centre.xyz + value; radii.xyz + opacity;
// rotation quaternion xyzw; hardness, erase, 0, 0.
@group(0) @binding(2) var splats: texture_2d<f32>;

fn rotate_inverse(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    // Rotate v by the conjugate of unit quaternion q.
    let u = -q.xyz;
    let t = 2.0 * cross(u, v);
    return v + q.w * t + cross(u, t);
}

@compute @workgroup_size(4, 4, 4)
fn bake(@builtin(global_invocation_id) id: vec3<u32>) {
    if any(id >= P.size) {
        return;
    }
    let x = P.box_min + (vec3<f32>(id) + 0.5) / vec3<f32>(P.size) * (P.box_max - P.box_min);
    var v = P.base;
    for (var k = 0u; k < P.count; k++) {
        let a = textureLoad(splats, vec2<u32>(0u, k), 0);
        let b = textureLoad(splats, vec2<u32>(1u, k), 0);
        let q = textureLoad(splats, vec2<u32>(2u, k), 0);
        let c = textureLoad(splats, vec2<u32>(3u, k), 0);
        if any(b.xyz <= vec3<f32>(0.0)) {
            continue;
        }
        let local = rotate_inverse(q, x - a.xyz) / b.xyz;
        let d = length(local);
        var fall = 1.0;
        if d > c.x {
            fall = 1.0 - smoothstep(c.x, 1.0, d);
        }
        if d >= 1.0 {
            fall = 0.0;
        }
        let w = b.w * fall;
        let target_value = select(a.w, P.base, c.y > 0.5);
        v = mix(v, target_value, w);
    }
    textureStore(out_level, id, vec4<f32>(v, 0.0, 0.0, 1.0));
}
