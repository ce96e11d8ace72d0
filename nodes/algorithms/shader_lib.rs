//! The CPU twins of `shaders/lib/*.wgsl`, for the nodes' CPU references (the camera's are
//! `tyndall_engine::eval::screen_ray` / `pixel_ray`, which predate the library; `exp_segment` has no
//! twin: the scattering reference integrates its pieces inline).
//! A change to one side is a change to both (`tests/platform/shader_lib.rs` runs the WGSL side on the
//! GPU and compares).

use glam::{Mat4, Vec3};

use tyndall_engine::io::Raster;

// ---- shaders/lib/medium.wgsl -------------------------------------------------------------

/// `(1 − e^{−len·m})/m` for m ≥ 0, `∫_0^len e^{−m t} dt` (world units): exactly `len` at m = 0,
/// → 1/m for large `len·m`, accurate between (a seven-term series below `len·m = 0.5`, whose
/// truncation is below 2·10⁻⁷ relative; the closed form above, where it no longer cancels).
pub fn decay_integral(len: f32, m: f32) -> f32 {
    let x = len * m;
    if x < 0.5 {
        let series = 1.0
            - x / 2.0
                * (1.0
                    - x / 3.0
                        * (1.0 - x / 4.0 * (1.0 - x / 5.0 * (1.0 - x / 6.0 * (1.0 - x / 7.0)))));
        return len * series;
    }
    (1.0 - (-x).exp()) / m
}

/// The Henyey–Greenstein phase function (1/sr) for asymmetry g ∈ (−1, 1) at cos θ.
pub fn henyey_greenstein(g: f32, cos_theta: f32) -> f32 {
    let d = (1.0 + g * g - 2.0 * g * cos_theta).max(1e-12);
    (1.0 - g * g) / (4.0 * std::f32::consts::PI * d * d.sqrt())
}

// ---- shaders/lib/hash.wgsl ---------------------------------------------------------------

/// PCG's output stage (RXS-M-XS) after one LCG step: a well-mixed u32 from a seed word.
pub fn pcg(seed: u32) -> u32 {
    let v = seed.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let w = ((v >> ((v >> 28) + 4)) ^ v).wrapping_mul(277_803_737);
    (w >> 22) ^ w
}

/// A per-pixel jitter in [0, 1) for pixel (x, y).
pub fn pixel_jitter(x: u32, y: u32) -> f32 {
    let seed = x
        .wrapping_mul(1_973)
        .wrapping_add(y.wrapping_mul(9_277))
        .wrapping_add(26_699)
        | 1;
    pcg(seed) as f32 / 4_294_967_296.0
}

// ---- shaders/lib/camera.wgsl: its twins are `tyndall_engine::eval::screen_ray` / `pixel_ray` ----------

// ---- shaders/lib/shadow.wgsl -------------------------------------------------------------

/// Light-space (u, v, depth) of world point `x`: u, v ∈ [0, 1] across the map, v down.
pub fn light_uvz(light_view_proj: Mat4, x: Vec3) -> Vec3 {
    let c = light_view_proj * x.extend(1.0);
    Vec3::new(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z)
}

/// `f`, a value computed from depth `z` by an increasing map (a slope, a perspective q), or
/// clear when `z` is: clear is +∞, and every increasing map keeps +∞ where it is.
pub fn keep_clear(z: f32, f: f32) -> f32 {
    if tyndall_engine::eval::is_clear(z) {
        tyndall_engine::eval::SHADOW_CLEAR
    } else {
        f
    }
}

/// Whether the light reaches light-space point `l`: nearest texel of `shadow`, depth `bias`;
/// outside the map's footprint: lit; at any depth (past 1 too) behind its texel's occluder:
/// shadowed; under a clear texel ([`tyndall_engine::eval::SHADOW_CLEAR`]): lit.
pub fn sun_reaches(shadow: &Raster, l: Vec3, bias: f32) -> bool {
    if l.x < 0.0 || l.x >= 1.0 || l.y < 0.0 || l.y >= 1.0 {
        return true;
    }
    let tx = ((l.x * shadow.width as f32) as u32).min(shadow.width - 1);
    let ty = ((l.y * shadow.height as f32) as u32).min(shadow.height - 1);
    l.z <= shadow.pixel(tx, ty)[0] + bias
}

// ---- shaders/lib/sampling.wgsl -----------------------------------------------------------

/// Bilinear sample of every channel of `r` at `p` in texel units (texel i's centre at i + 0.5),
/// clamped to the edge.
pub fn bilinear_texels(r: &Raster, p: [f32; 2]) -> Vec<f32> {
    let (w, h, c) = (r.width as i64, r.height as i64, r.channels as usize);
    let q = [p[0] - 0.5, p[1] - 0.5];
    let f = [q[0] - q[0].floor(), q[1] - q[1].floor()];
    let (x0, y0) = (q[0].floor() as i64, q[1].floor() as i64);
    let at = |x: i64, y: i64, k: usize| {
        let (x, y) = (x.clamp(0, w - 1), y.clamp(0, h - 1));
        r.data[(y * w + x) as usize * c + k]
    };
    (0..c)
        .map(|k| {
            let top = at(x0, y0, k) + (at(x0 + 1, y0, k) - at(x0, y0, k)) * f[0];
            let bottom = at(x0, y0 + 1, k) + (at(x0 + 1, y0 + 1, k) - at(x0, y0 + 1, k)) * f[0];
            top + (bottom - top) * f[1]
        })
        .collect()
}
