// Integrals of a homogeneous medium (CPU twins: nodes/algorithms/shader_lib.rs, `medium`).

// (1 − e^{−len·m})/m for m ≥ 0: ∫_0^len e^{−m t} dt, the transmittance integral of a stretch of
// length `len` through extinction m (1/world unit). Accurate from m = 0 (exactly `len`) to large
// len·m (→ 1/m): below x = len·m = 0.5 a seven-term series (truncation < 2e-7 relative), so
// 1 − e^{−x} never cancels against the driver's exp; above it the closed form, which no longer
// cancels. Checked against f64 at the limits by tests/shader_lib.rs.
fn decay_integral(len: f32, m: f32) -> f32 {
    let x = len * m;
    if x < 0.5 {
        return len * (1.0 - x / 2.0 * (1.0 - x / 3.0 * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0 * (1.0 - x / 7.0))))));
    }
    return (1.0 - exp(-x)) / m;
}

// ∫_a^b e^{−m (t − a)} dt over len = b − a for m of either sign, from the end where the
// exponent is largest, so nothing overflows: (integral relative to the integrand at that end,
// which end: 0 = a, 1 = b).
fn exp_segment(len: f32, m: f32) -> vec2<f32> {
    if m >= 0.0 {
        return vec2<f32>(decay_integral(len, m), 0.0);
    }
    return vec2<f32>(decay_integral(len, -m), 1.0);
}

// The Henyey–Greenstein phase function (1/sr) for asymmetry g at cos θ.
fn henyey_greenstein(g: f32, cos_theta: f32) -> f32 {
    let d = max(1.0 + g * g - 2.0 * g * cos_theta, 1e-12);
    return (1.0 - g * g) / (4.0 * 3.14159265358979 * d * sqrt(d));
}
