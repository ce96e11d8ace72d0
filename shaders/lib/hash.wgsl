// Hashing (CPU twins: nodes/algorithms/shader_lib.rs, `hash`).

// The output stage of PCG (RXS-M-XS) after one LCG step: a well-mixed u32 from a seed word.
fn pcg(seed: u32) -> u32 {
    let v = seed * 747796405u + 2891336453u;
    let w = ((v >> ((v >> 28u) + 4u)) ^ v) * 277803737u;
    return (w >> 22u) ^ w;
}

// A per-pixel jitter in [0, 1) for pixel (x, y).
fn pixel_jitter(x: u32, y: u32) -> f32 {
    return f32(pcg((x * 1973u + y * 9277u + 26699u) | 1u)) / 4294967296.0;
}
