// Math: element-wise operations on Scalar/Image operands (nodes/math.rs).

struct Params {
    op: u32,
    a_mode: u32,
    b_mode: u32,
    _pad0: u32,
    a_const: f32,
    b_const: f32,
    factor: f32,
    lo: f32,
    hi: f32,
    _pad1: f32,
    _pad2: f32,
    _pad3: f32,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var tex_a: texture_2d<f32>;
@group(0) @binding(2) var tex_b: texture_2d<f32>;
@group(0) @binding(3) var out_scalar: texture_storage_2d<r32float, write>;
@group(0) @binding(4) var out_image: texture_storage_2d<rgba32float, write>;

// mode 0: the constant; 1: a Scalar texture broadcast to four channels; 2: an Image texture.
// 1×1 textures broadcast over the output (the coordinate is clamped to the texture).
fn operand_a(p: vec2<i32>) -> vec4<f32> {
    if P.a_mode == 0u {
        return vec4<f32>(P.a_const);
    }
    let v = textureLoad(tex_a, min(p, vec2<i32>(textureDimensions(tex_a)) - 1), 0);
    return select(v, vec4<f32>(v.r), P.a_mode == 1u);
}

fn operand_b(p: vec2<i32>) -> vec4<f32> {
    if P.b_mode == 0u {
        return vec4<f32>(P.b_const);
    }
    let v = textureLoad(tex_b, min(p, vec2<i32>(textureDimensions(tex_b)) - 1), 0);
    return select(v, vec4<f32>(v.r), P.b_mode == 1u);
}

fn safe_pow(a: f32, b: f32) -> f32 {
    let m = abs(a);
    if m == 0.0 {
        return select(0.0, 1.0, b == 0.0);
    }
    return sign(a) * pow(m, b);
}

fn apply(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    switch P.op {
        case 0u: { return a + b; }
        case 1u: { return a - b; }
        case 2u: { return a * b; }
        case 3u: { return select(a / b, vec4<f32>(0.0), b == vec4<f32>(0.0)); }
        case 4u: { return min(a, b); }
        case 5u: { return max(a, b); }
        case 6u: { return a + (b - a) * P.factor; }
        case 7u: { return min(max(a, vec4<f32>(P.lo)), vec4<f32>(P.hi)); }
        case 8u: {
            return vec4<f32>(safe_pow(a.x, b.x), safe_pow(a.y, b.y), safe_pow(a.z, b.z), safe_pow(a.w, b.w));
        }
        default: { return a; }
    }
}

@compute @workgroup_size(8, 8)
fn math_scalar(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_scalar);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    let r = apply(operand_a(p), operand_b(p));
    textureStore(out_scalar, p, vec4<f32>(r.x, 0.0, 0.0, 1.0));
}

@compute @workgroup_size(8, 8)
fn math_image(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(out_image);
    if id.x >= size.x || id.y >= size.y {
        return;
    }
    let p = vec2<i32>(id.xy);
    textureStore(out_image, p, apply(operand_a(p), operand_b(p)));
}
