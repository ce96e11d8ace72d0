// Sampling textures (CPU twin: nodes/algorithms/shader_lib.rs, `sampling`).

// Bilinear sample of `t` at `p` in texel units (texel i's centre at i + 0.5), clamped to the
// edge: a point outside the texture takes the nearest edge texels. Only `textureLoad`, so it
// works on unfilterable 32-bit float textures.
fn bilinear_texels(t: texture_2d<f32>, p: vec2<f32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(t));
    let q = p - 0.5;
    let f = q - floor(q);
    let i0 = clamp(vec2<i32>(floor(q)), vec2<i32>(0), size - 1);
    let i1 = clamp(vec2<i32>(floor(q)) + 1, vec2<i32>(0), size - 1);
    let top = mix(textureLoad(t, vec2<i32>(i0.x, i0.y), 0), textureLoad(t, vec2<i32>(i1.x, i0.y), 0), f.x);
    let bottom = mix(textureLoad(t, vec2<i32>(i0.x, i1.y), 0), textureLoad(t, vec2<i32>(i1.x, i1.y), 0), f.x);
    return mix(top, bottom, f.y);
}
