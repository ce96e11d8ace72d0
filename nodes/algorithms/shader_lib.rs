//! The CPU twins of `shaders/lib/*.wgsl`, function for function, for the nodes' CPU references.
//! A change to one side is a change to both (`tests/shader_lib.rs` runs the WGSL side on the
//! GPU and compares).

use glam::{Mat4, Vec2, Vec3, Vec4};

use crate::io::Raster;

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

/// `∫_a^b e^{−m (t − a)} dt` over `len = b − a` for m of either sign, from the end where the
/// exponent is largest: `(integral relative to the integrand at that end, which end: 0 = a,
/// 1 = b)`.
pub fn exp_segment(len: f32, m: f32) -> (f32, u32) {
    if m >= 0.0 {
        (decay_integral(len, m), 0)
    } else {
        (decay_integral(len, -m), 1)
    }
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

// ---- shaders/lib/camera.wgsl -------------------------------------------------------------

/// Unit direction of the view ray through screen point `q` (pixels, continuous, y down) of a
/// `size` image; (0, 0, −1) for a degenerate camera.
pub fn camera_ray(inv_view_proj: Mat4, eye: Vec3, q: Vec2, size: (u32, u32)) -> Vec3 {
    let ndc = Vec4::new(
        q.x / size.0 as f32 * 2.0 - 1.0,
        1.0 - q.y / size.1 as f32 * 2.0,
        1.0,
        1.0,
    );
    let far = inv_view_proj * ndc;
    let dir = far.truncate() / far.w - eye;
    if dir.dot(dir) > 0.0 {
        dir.normalize()
    } else {
        Vec3::new(0.0, 0.0, -1.0)
    }
}

/// Unit direction of the view ray through the centre of pixel `p`.
pub fn pixel_ray(inv_view_proj: Mat4, eye: Vec3, p: (u32, u32), size: (u32, u32)) -> Vec3 {
    let q = Vec2::new(p.0 as f32 + 0.5, p.1 as f32 + 0.5);
    camera_ray(inv_view_proj, eye, q, size)
}

// ---- shaders/lib/shadow.wgsl -------------------------------------------------------------

/// Light-space (u, v, depth) of world point `x`: u, v ∈ [0, 1] across the map, v down.
pub fn light_uvz(light_view_proj: Mat4, x: Vec3) -> Vec3 {
    let c = light_view_proj * x.extend(1.0);
    Vec3::new(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5, c.z)
}

/// Whether the sun reaches light-space point `l`: nearest texel of `shadow`, depth `bias`;
/// outside the map or the light box: lit.
pub fn sun_reaches(shadow: &Raster, l: Vec3, bias: f32) -> bool {
    if l.x < 0.0 || l.x >= 1.0 || l.y < 0.0 || l.y >= 1.0 || l.z < 0.0 || l.z > 1.0 {
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
