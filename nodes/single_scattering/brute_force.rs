//! Method `BruteForce`: the CPU reference of one pixel (the oracle of every method), for the sun
//! and for a spot or point light (`ScatterParams::local`).

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
    let lvp = Mat4::from_cols_array_2d(&p.light.view_proj);
    let eye = Vec3::from(p.eye);
    let dir = tyndall_engine::eval::pixel_ray(inv, eye, x, y, w, h);
    let (t0, t1) = medium_segment(p, dir, s);
    let len = (t1 - t0).max(0.0);
    let hash = crate::algorithms::shader_lib::pixel_jitter(x, y) + p.jitter_phase;
    let offset = p.jitter * ((hash - hash.floor()) - 0.5);
    if let Some(light) = p.local() {
        let n = p.steps as f32;
        let delta = len / n;
        let (mut lit, mut acc) = (0u32, [0.0f32; 3]);
        for i in 0..p.steps {
            let t = t0 + (i as f32 + 0.5 + offset) / n * len;
            let x = eye + dir * t;
            let l = light.uvz(lvp, x).unwrap_or(Vec3::new(-1.0, -1.0, 2.0));
            if !sun_reaches(shadow, l, p.bias) {
                continue;
            }
            lit += 1;
            let mut e = (-p.sigma_t * (t - t0)).exp();
            if p.light_extinction != 0 {
                e *= (-p.sigma_t * light_path(p, &light, x)).exp();
            }
            let cos = dir.dot((light.position() - x).normalize());
            let f = phase.map_or([henyey_greenstein(p.g, cos); 3], |t| t.lookup(cos));
            let k = light.falloff(x) * e * delta;
            for c in 0..3 {
                acc[c] += f[c] * k;
            }
        }
        let vbar = if len > 0.0 || p.bounded == 0 {
            lit as f32 / n
        } else {
            1.0
        };
        let rad = [0, 1, 2].map(|c| p.light.radiance[c] * (p.sigma_t * p.albedo) * acc[c]);
        return (vbar, rad, (-len * p.sigma_t).exp());
    }
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
    let cos = dir.dot(p.to_sun());
    let f = phase.map_or([henyey_greenstein(p.g, cos); 3], |t| t.lookup(cos));
    let k = if p.light_extinction != 0 {
        weighted
    } else {
        decay_integral(len, p.sigma_t) * vbar
    };
    let rad = [0, 1, 2].map(|c| p.light.radiance[c] * p.sigma_t * p.albedo * f[c] * k);
    (vbar, rad, (-len * p.sigma_t).exp())
}

/// Distance from `x` (inside the medium's box) to the box's boundary towards the light, at
/// most the distance to the light (the WGSL `local_light_path`).
pub fn light_path(p: &ScatterParams, light: &tyndall_engine::scene::LocalLight, x: Vec3) -> f32 {
    let l = light.position() - x;
    let r = l.length();
    if r <= 0.0 {
        return 0.0;
    }
    let d = l / r;
    let mut ell = r;
    for k in 0..3 {
        if d[k] != 0.0 {
            let face = if d[k] > 0.0 {
                p.box_max[k]
            } else {
                p.box_min[k]
            };
            ell = ell.min(((face - x[k]) / d[k]).max(0.0));
        }
    }
    ell
}
