//! A view ray in the shadow map's texel units, walked texel by texel: the exact MinMax limit
//! (CPU twin of `shaders/single_scattering/map_ray.wgsl`), shared with `Epipolar`.

use super::epipolar::{map_depth, sign};
use super::{medium_segment, weight, Mat4, Raster, ScatterParams, Vec3};

/// A view ray in the map's texel units and light depth, `a + d·t`, and the part `[tin, tout]`
/// of its medium segment `[t0, t1]` over the map's footprint, at any light depth (the CPU twin
/// of the shader's `map_ray`).
pub(super) struct MapRay {
    pub(super) a: Vec3,
    pub(super) d: Vec3,
    pub(super) t0: f32,
    pub(super) t1: f32,
    pub(super) tin: f32,
    pub(super) tout: f32,
}

pub(super) fn map_ray(p: &ScatterParams, msize: glam::Vec2, dir: Vec3, s: f32) -> MapRay {
    let (t0, t1) = medium_segment(p, dir, s);
    let t1 = t1.max(t0);
    let lvp = Mat4::from_cols_array_2d(&p.light.view_proj);
    let eye = Vec3::from(p.eye);
    let c0 = lvp * eye.extend(1.0);
    let c1 = lvp * (eye + dir).extend(1.0);
    let a = Vec3::new(
        (c0.x * 0.5 + 0.5) * msize.x,
        (0.5 - c0.y * 0.5) * msize.y,
        c0.z,
    );
    let d = Vec3::new(
        (c1.x - c0.x) * 0.5 * msize.x,
        -(c1.y - c0.y) * 0.5 * msize.y,
        c1.z - c0.z,
    );
    let (mut tin, mut tout) = (t0, t1);
    let hi = msize;
    for k in 0..2 {
        if d[k].abs() < 1e-12 {
            if a[k] < 0.0 || a[k] > hi[k] {
                tout = -1.0;
            }
        } else {
            let ta = (0.0 - a[k]) / d[k];
            let tb = (hi[k] - a[k]) / d[k];
            tin = tin.max(ta.min(tb));
            tout = tout.min(ta.max(tb));
        }
    }
    MapRay {
        a,
        d,
        t0,
        t1,
        tin,
        tout,
    }
}

/// Lit length and lit weight of the stretch `[from, to]` of a ray, texel by texel (at most
/// `max_cells` texels; the last one taken takes the rest of the stretch).
pub(super) fn texel_walk(
    p: &ScatterParams,
    shadow: &Raster,
    r: &MapRay,
    dir: Vec3,
    (from, to): (f32, f32),
    max_cells: u32,
) -> (f32, f32) {
    let nudge = sign(r.d.truncate()) * 1e-3;
    let (mut lit, mut weighted) = (0.0f32, 0.0f32);
    let mut t = from;
    let ext = p.light_extinction != 0;
    for i in 0..max_cells {
        if t >= to {
            break;
        }
        let q = r.a + r.d * t;
        let cell = (q.truncate() + nudge).floor();
        let mut te = to;
        if i + 1 < max_cells {
            for k in 0..2 {
                if r.d[k] > 1e-12 {
                    te = te.min((cell[k] + 1.0 - r.a[k]) / r.d[k]);
                } else if r.d[k] < -1e-12 {
                    te = te.min((cell[k] - r.a[k]) / r.d[k]);
                }
            }
        }
        let te = te.max(t);
        let c = map_depth(shadow, cell.as_ivec2()) + p.bias;
        let (z0, z1) = (r.a.z + r.d.z * t, r.a.z + r.d.z * te);
        let part = lit_part(t, te, z0, z1, c);
        lit += part;
        if ext {
            weighted += if z0 <= c {
                weight(p, dir, r.t0, t, t + part)
            } else {
                weight(p, dir, r.t0, te - part, te)
            };
        }
        t = if te > t { te } else { to };
    }
    (lit, weighted)
}

/// Length of `[t0, t1]` where the depth, linear from z0 to z1, is at most c.
pub(super) fn lit_part(t0: f32, t1: f32, z0: f32, z1: f32, c: f32) -> f32 {
    if z0 <= c && z1 <= c {
        return t1 - t0;
    }
    if z0 > c && z1 > c {
        return 0.0;
    }
    let u = ((c - z0) / (z1 - z0)).clamp(0.0, 1.0);
    if z0 <= c {
        (t1 - t0) * u
    } else {
        (t1 - t0) * (1.0 - u)
    }
}

/// `(V̄, medium length, lit weight)` from the lit length and weight inside the map.
pub(super) fn ray_result(
    p: &ScatterParams,
    r: &MapRay,
    dir: Vec3,
    inner: (f32, f32),
) -> (f32, f32, f32) {
    let len = r.t1 - r.t0;
    let ext = p.light_extinction != 0;
    let (mut lit, mut weighted) = (
        len,
        if ext {
            weight(p, dir, r.t0, r.t0, r.t1)
        } else {
            0.0
        },
    );
    if r.tout > r.tin {
        lit = len - (r.tout - r.tin) + inner.0;
        if ext {
            weighted =
                weight(p, dir, r.t0, r.t0, r.tin) + weight(p, dir, r.t0, r.tout, r.t1) + inner.1;
        }
    }
    let vbar = if len > 0.0 {
        (lit / len).clamp(0.0, 1.0)
    } else {
        1.0
    };
    (vbar, len, weighted)
}

/// The exact visibility of one view ray (every texel it crosses, no tree): the limit that
/// `MinMax` and `Epipolar` at `tree_level` 0 compute. `(V̄, medium length, lit weight)`.
pub fn exact_ray(p: &ScatterParams, shadow: &Raster, dir: Vec3, s: f32) -> (f32, f32, f32) {
    let msize = glam::Vec2::new(shadow.width as f32, shadow.height as f32);
    let r = map_ray(p, msize, dir, s);
    let inner = if r.tout > r.tin {
        texel_walk(p, shadow, &r, dir, (r.tin, r.tout), u32::MAX)
    } else {
        (0.0, 0.0)
    };
    ray_result(p, &r, dir, inner)
}
