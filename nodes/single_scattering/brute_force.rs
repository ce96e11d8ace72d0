//! Method `BruteForce`: the CPU reference of one pixel (the oracle of every method).

use crate::algorithms::shader_lib::{decay_integral, henyey_greenstein};

use super::{medium_segment, weight, Mat4, PixelResult, Raster, ScatterParams, Vec3};

use crate::algorithms::shader_lib::{light_uvz, sun_reaches};

/// CPU reference of the brute-force method for pixel (x, y) of a `w × h` image, with the
/// built-in Henyey–Greenstein phase function.
pub fn reference_pixel(
    p: &ScatterParams,
    shadow: &Raster,
    s: f32,
    x: u32,
    y: u32,
    w: u32,
    h: u32,
) -> PixelResult {
    reference_pixel_phase(p, None, shadow, s, (x, y), (w, h))
}

/// [`reference_pixel`] with a phase table (`None`: Henyey–Greenstein `g`) for pixel `xy` of a
/// `size` image.
pub fn reference_pixel_phase(
    p: &ScatterParams,
    phase: Option<&crate::algorithms::phase_function::PhaseTable>,
    shadow: &Raster,
    s: f32,
    (x, y): (u32, u32),
    (w, h): (u32, u32),
) -> PixelResult {
    let inv = Mat4::from_cols_array_2d(&p.inv_view_proj);
    let lvp = Mat4::from_cols_array_2d(&p.light_view_proj);
    let eye = Vec3::from(p.eye);
    let dir = tyndall_engine::eval::pixel_ray(inv, eye, x, y, w, h);
    let (t0, t1) = medium_segment(p, dir, s);
    let len = (t1 - t0).max(0.0);
    let hash = crate::algorithms::shader_lib::pixel_jitter(x, y) + p.jitter_phase;
    let offset = p.jitter * ((hash - hash.floor()) - 0.5);
    let mut lit = 0u32;
    let mut weighted = 0.0f32;
    let n = p.steps as f32;
    for i in 0..p.steps {
        let t = t0 + (i as f32 + 0.5 + offset) / n * len;
        let visible = sun_reaches(shadow, light_uvz(lvp, eye + dir * t), p.bias);
        lit += visible as u32;
        if p.light_extinction != 0 && visible {
            let a = t0 + i as f32 / n * len;
            let b = t0 + (i + 1) as f32 / n * len;
            weighted += weight(p, dir, t0, a, b);
        }
    }
    let vbar = if len > 0.0 || p.bounded == 0 {
        lit as f32 / n
    } else {
        1.0
    };
    let cos = dir.dot(Vec3::from(p.to_sun));
    let f = phase.map_or([henyey_greenstein(p.g, cos); 3], |t| t.lookup(cos));
    let k = if p.light_extinction != 0 {
        weighted
    } else {
        decay_integral(len, p.sigma_t) * vbar
    };
    let rad = [0, 1, 2].map(|c| p.radiance[c] * p.sigma_t * p.albedo * f[c] * k);
    (vbar, rad, (-len * p.sigma_t).exp())
}
