//! The medium's extent along a view ray and the weight of each stretch of it (CPU twins of
//! `shaders/single_scattering/common.wgsl`).

use super::{ScatterParams, Vec3};

use crate::algorithms::shader_lib::decay_integral;

/// Result of one pixel: (V̄, in-scatter RGB, transmittance).
pub type PixelResult = (f32, [f32; 3], f32);

/// The part `[t0, t1]` of `[0, s]` inside the medium along the ray `eye + dir·t` (t1 ≤ t0: none).
pub fn medium_segment(p: &ScatterParams, dir: Vec3, s: f32) -> (f32, f32) {
    if p.bounded == 0 {
        return (0.0, s);
    }
    let (mut t0, mut t1) = (0.0f32, s);
    for k in 0..3 {
        if dir[k] == 0.0 {
            if p.eye[k] < p.box_min[k] || p.eye[k] > p.box_max[k] {
                return (0.0, -1.0);
            }
        } else {
            let ta = (p.box_min[k] - p.eye[k]) / dir[k];
            let tb = (p.box_max[k] - p.eye[k]) / dir[k];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
    }
    (t0, t1)
}

/// ℓ along the ray through the face the sun shines through on axis k: `(α, β)` with
/// ℓ_k(t) = α + β t (an axis parallel to the sun never limits ℓ).
pub(super) fn light_line(p: &ScatterParams, dir: Vec3, k: usize) -> (f32, f32) {
    let sk = p.to_sun()[k];
    if sk.abs() < 1e-12 {
        return (3.0e38, 0.0);
    }
    let face = if sk > 0.0 { p.box_max[k] } else { p.box_min[k] };
    ((face - p.eye[k]) / sk, -dir[k] / sk)
}

/// ℓ at distance t along the view ray, computed from the point itself (the lines of
/// [`light_line`] carry terms of order 1/|sun_k| that cancel badly in f32).
pub(super) fn light_exit(p: &ScatterParams, dir: Vec3, t: f32) -> f32 {
    let q = Vec3::from(p.eye) + dir * t;
    let mut ell = 3.0e38f32;
    for k in 0..3 {
        let sk = p.to_sun()[k];
        if sk.abs() >= 1e-12 {
            let face = if sk > 0.0 { p.box_max[k] } else { p.box_min[k] };
            ell = ell.min((face - q[k]) / sk);
        }
    }
    ell.max(0.0)
}

/// `∫_a^b E(t) dt`, E(t) = e^{−σt (t − t0)} · e^{−σt ℓ(t)} (ℓ = 0 with light extinction off):
/// the weight of a stretch of the view ray in the medium (see the shader's comment).
pub fn weight(p: &ScatterParams, dir: Vec3, t0: f32, a: f32, b: f32) -> f32 {
    if b <= a {
        return 0.0;
    }
    let sig = p.sigma_t;
    if p.light_extinction == 0 {
        return (-sig * (a - t0)).exp() * decay_integral(b - a, sig);
    }
    let lines = [0, 1, 2].map(|k| light_line(p, dir, k));
    let mut cuts = vec![a];
    for i in 0..3 {
        for j in i + 1..3 {
            let db = lines[i].1 - lines[j].1;
            if db != 0.0 {
                let tc = (lines[j].0 - lines[i].0) / db;
                if tc > a && tc < b {
                    cuts.push(tc);
                }
            }
        }
    }
    cuts[1..].sort_by(f32::total_cmp);
    cuts.push(b);
    let mut total = 0.0;
    for w in cuts.windows(2) {
        let (p0, p1) = (w[0], w[1]);
        if p1 <= p0 {
            continue;
        }
        let mid = 0.5 * (p0 + p1);
        let line = lines.iter().copied().fold(lines[0], |m, l| {
            if l.0 + l.1 * mid < m.0 + m.1 * mid {
                l
            } else {
                m
            }
        });
        let m = sig * (1.0 + line.1);
        let (integral, at) = if m >= 0.0 {
            (decay_integral(p1 - p0, m), p0)
        } else {
            (decay_integral(p1 - p0, -m), p1)
        };
        let e = (-sig * ((at - t0) + light_exit(p, dir, at))).exp();
        total += e * integral;
    }
    total
}
