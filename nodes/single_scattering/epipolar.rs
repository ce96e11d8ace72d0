//! Method `Epipolar`: slice geometry, 1D min-max trees and the CPU reference (twins of
//! `shaders/single_scattering/epipolar.wgsl`).

use super::epipolar_lines::{border_coordinate, border_point, clip_line, spot_line};
use super::map_ray::{map_ray, ray_result, texel_walk};
use super::{exact_ray, medium_segment, weight, Mat4, Raster, ScatterParams, Vec3};
use tyndall_engine::eval::SHADOW_CLEAR;

// ---- Method Epipolar: epipolar sampling with 1D min-max trees --------------------------------
//
// The sun's screen position (the epipole e: the projection of the direction to the sun, or of
// its opposite when the sun is behind the camera) is where every shaft's screen image
// converges. `epi_slices` lines from e to points spaced equally along the part of the screen's
// border that lines from e leave the screen through (the whole border when e is on screen)
// carry `epi_samples` view rays each, end points included. The view rays of one slice lie in one
// plane through the eye and the sun, whose image in the (orthographic) shadow map is one line:
// that line is rectified into a row of texels, one leaf per texel of length, each leaf holding
// the minimum and maximum depth of the texels the line crosses over it, and a binary min-max
// tree over the row (Chen et al. 2011) gives each sample ray its visibility in O(log n) per
// light/shadow transition; inside a mixed leaf the ray's own texels are solved exactly, so at
// `tree_level` 0 a sample is the exact brute-force limit, like `MinMax`. Each pixel then takes
// the two slices on either side of its own line through e and, on each, the two samples at its
// distance along the line, bilinearly weighted; a sample whose camera depth or medium length
// differs from the pixel's by more than `epi_threshold` (relative) is left out, and a pixel
// left with none (a depth discontinuity: a silhouette, a thin branch) traces its own ray
// through the 2D min-max pyramid of `MinMax`. V̄ varies smoothly along a slice away from depth
// discontinuities (shaft boundaries run along the slices), so few samples per slice suffice.

/// Largest distance of the epipole from the screen's centre, pixels: a sun at right angles to
/// the view axis puts the epipole at infinity; lines through a point 10⁷ px away are parallel
/// to within 2·10⁻⁴ rad over a 2000 px screen.
pub(super) const EPIPOLE_FAR: f64 = 1e7;

/// Quality knobs of method `Epipolar`.
#[derive(Clone, Copy, Debug)]
pub struct EpiKnobs {
    /// Slices (lines through the epipole).
    pub slices: u32,
    /// Samples per slice, end points included (≥ 2).
    pub samples: u32,
    /// Relative difference of camera depth (and medium length) above which a sample is not used
    /// for a pixel.
    pub threshold: f32,
    /// Tree level at and below which mixed nodes are estimated, not refined (0 = exact).
    pub tree_level: u32,
}

/// One epipolar slice: its segment on screen and its line in the shadow map.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EpiSlice {
    /// Where the segment enters the screen (the epipole when it is on screen), pixels.
    pub entry: [f32; 2],
    /// Unit direction of the segment, away from the epipole.
    pub dir: [f32; 2],
    /// Length of the segment, pixels (0: the line only touches the screen).
    pub len: f32,
    /// Length of the line's chord through the shadow map, texels (0: it misses the map).
    pub chord: f32,
    /// Where the line enters the shadow map, texels.
    pub line_o: [f32; 2],
    /// Unit direction of the line in the shadow map, texels.
    pub line_d: [f32; 2],
}

/// The epipolar layout of one view on one shadow map.
#[derive(Clone, Debug)]
pub struct EpiGeometry {
    /// The epipole, pixels (y down; possibly far off screen).
    pub epipole: [f32; 2],
    /// The screen, pixels.
    pub size: [f32; 2],
    /// Whether the epipole is on the screen (slices then go all the way round).
    pub inside: bool,
    /// Border coordinate where the slices' arc starts (0 top-left corner, 1 top-right, 2
    /// bottom-right, 3 bottom-left, clockwise).
    pub u_start: f32,
    /// Length of the arc in border coordinates (4: the whole border).
    pub arc: f32,
    /// The slices, in border order.
    pub slices: Vec<EpiSlice>,
    /// Leaves per rectified row (a power of two ≥ the longest chord + 1).
    pub tree_n: u32,
}

/// The epipolar layout of a `size` view (uniforms `p`) over a `map` (width, height) shadow map
/// with `slices` slices.
pub fn epipolar_geometry(
    p: &ScatterParams,
    (w, h): (u32, u32),
    map: (u32, u32),
    slices: u32,
) -> EpiGeometry {
    use glam::{DVec2, DVec3, DVec4};
    let inv = Mat4::from_cols_array_2d(&p.inv_view_proj).as_dmat4();
    let vp = inv.inverse();
    let lvp = Mat4::from_cols_array_2d(&p.light.view_proj).as_dmat4();
    let sun = p.to_sun().as_dvec3();
    let eye = Vec3::from(p.eye).as_dvec3();
    let size = DVec2::new(w as f64, h as f64);
    let msize = DVec2::new(map.0 as f64, map.1 as f64);
    let centre = size * 0.5;
    // A spot: its light converges on its position, not on a direction.
    let spot = p.light.kind == 1;
    let light_pos = Vec3::from(p.light.position).as_dvec3();
    // The epipole: the image of the point at infinity towards the sun, or of the spot's
    // position (projective, so a light behind the camera gives the point the lines converge to
    // on the other side).
    let c = if spot {
        vp * light_pos.extend(1.0)
    } else {
        vp * sun.extend(0.0)
    };
    let towards = DVec2::new(c.x * size.x * 0.5, -c.y * size.y * 0.5);
    let mut e = centre + towards / c.w;
    if !e.is_finite() || (e - centre).length() > EPIPOLE_FAR {
        e = centre + towards.normalize_or_zero() * EPIPOLE_FAR;
    }
    let inside = e.x >= 0.0 && e.x <= w as f64 && e.y >= 0.0 && e.y <= h as f64;
    // Edges seen from an outside epipole (top, right, bottom, left): lines leave the screen
    // through the others, a contiguous run of the border.
    let (u_start, arc) = if inside {
        (0.0, 4.0)
    } else {
        let seen = [e.y < 0.0, e.x > size.x, e.y > size.y, e.x < 0.0];
        let start = (0..4).find(|&i| !seen[i] && seen[(i + 3) % 4]).unwrap_or(0);
        (start as f64, seen.iter().filter(|s| !**s).count() as f64)
    };
    let light_texel = |x: DVec3| {
        let c = lvp * x.extend(1.0);
        DVec2::new((c.x * 0.5 + 0.5) * msize.x, (0.5 - c.y * 0.5) * msize.y)
    };
    let eye_texel = light_texel(eye);
    let mut longest = 0.0f64;
    let list = (0..slices)
        .map(|k| {
            let b = border_point(
                u_start + (k as f64 + 0.5) / slices as f64 * arc,
                size.x,
                size.y,
            );
            let entry = if inside {
                e
            } else {
                let (s_in, _) = clip_line(e, b - e, size);
                e + (b - e) * s_in.clamp(0.0, 1.0)
            };
            let len = (b - entry).length();
            let dir = if len > 1e-9 {
                (b - entry) / len
            } else {
                (b - e).normalize_or(DVec2::X)
            };
            let q = DVec4::new(b.x / size.x * 2.0 - 1.0, 1.0 - b.y / size.y * 2.0, 1.0, 1.0);
            let far = inv * q;
            let v = far.truncate() / far.w - eye;
            let ((line_o, line_d), chord) = if spot {
                spot_line(&lvp, msize, eye - light_pos, v)
            } else {
                // The slice's plane holds the sun and the view ray through b; its image in the
                // map is the image of the in-plane direction at right angles to the sun.
                let across = sun.cross(v).cross(sun);
                let line_d = (light_texel(eye + across.normalize_or_zero()) - eye_texel)
                    .normalize_or(DVec2::X);
                // Every ray of the slice leaves the eye's texel towards +line_d (its component
                // across the sun points the way `across` does), so the line before the eye's
                // texel is never walked.
                let (s_in, s_out) = clip_line(eye_texel, line_d, msize);
                let s_in = s_in.max(0.0);
                let chord = (s_out - s_in).max(0.0);
                let o = if chord > 0.0 {
                    eye_texel + line_d * s_in
                } else {
                    DVec2::ZERO
                };
                ((o, line_d), chord)
            };
            longest = longest.max(chord);
            EpiSlice {
                entry: entry.as_vec2().to_array(),
                dir: dir.as_vec2().to_array(),
                len: len as f32,
                chord: chord as f32,
                line_o: line_o.as_vec2().to_array(),
                line_d: line_d.as_vec2().to_array(),
            }
        })
        .collect();
    EpiGeometry {
        epipole: e.as_vec2().to_array(),
        size: [w as f32, h as f32],
        inside,
        u_start: u_start as f32,
        arc: arc as f32,
        slices: list,
        tree_n: ((longest.ceil() as u32) + 1).next_power_of_two().max(2),
    }
}

/// WGSL's `sign`: −1, 0 or 1 per component (Rust's `signum` gives 1 for 0).
pub(super) fn sign(v: glam::Vec2) -> glam::Vec2 {
    let s = |x: f32| {
        if x > 0.0 {
            1.0
        } else if x < 0.0 {
            -1.0
        } else {
            0.0
        }
    };
    glam::Vec2::new(s(v.x), s(v.y))
}

/// The texel of the map at integer coordinates `c` (outside: [`SHADOW_CLEAR`], always lit, as
/// leaves past the end of a chord are).
pub(super) fn map_depth(shadow: &Raster, c: glam::IVec2) -> f32 {
    if c.x < 0 || c.y < 0 || c.x >= shadow.width as i32 || c.y >= shadow.height as i32 {
        SHADOW_CLEAR
    } else {
        shadow.pixel(c.x as u32, c.y as u32)[0]
    }
}

/// One slice's rectified row and its min-max tree: `2n` entries, level k (width n/2^k) at
/// offset 2n − 2n/2^k. Leaf i is the (minimum, maximum) depth over the texels the line crosses
/// between distances i and i + 1 from `line_o` (walked texel by texel).
pub fn epi_tree_row(shadow: &Raster, slice: &EpiSlice, n: u32) -> Vec<[f32; 2]> {
    let mut row = vec![[SHADOW_CLEAR; 2]; 2 * n as usize];
    let o = glam::Vec2::from(slice.line_o);
    let d = glam::Vec2::from(slice.line_d);
    for (i, leaf) in row.iter_mut().take(n as usize).enumerate() {
        if i as f32 >= slice.chord {
            continue;
        }
        let start = o + d * i as f32;
        let len = (slice.chord - i as f32).min(1.0);
        *leaf = leaf_range(shadow, start, d, len);
    }
    let mut level_n = n as usize;
    let mut src = 0usize;
    while level_n > 1 {
        let dst = src + level_n;
        for j in 0..level_n / 2 {
            let (a, b) = (row[src + 2 * j], row[src + 2 * j + 1]);
            row[dst + j] = [a[0].min(b[0]), a[1].max(b[1])];
        }
        src = dst;
        level_n /= 2;
    }
    row
}

/// (minimum, maximum) depth over the texels the segment `start + d·t`, t ∈ [0, len] crosses.
pub(super) fn leaf_range(shadow: &Raster, start: glam::Vec2, d: glam::Vec2, len: f32) -> [f32; 2] {
    let nudge = sign(d) * 1e-4;
    let (mut mn, mut mx) = (SHADOW_CLEAR, -SHADOW_CLEAR);
    let mut t = 0.0f32;
    for _ in 0..4 {
        if t >= len {
            break;
        }
        let cell = (start + d * t + nudge).floor();
        let mut te = len;
        for k in 0..2 {
            if d[k] > 1e-9 {
                te = te.min((cell[k] + 1.0 - start[k]) / d[k]);
            } else if d[k] < -1e-9 {
                te = te.min((cell[k] - start[k]) / d[k]);
            }
        }
        let z = map_depth(shadow, cell.as_ivec2());
        (mn, mx) = (mn.min(z), mx.max(z));
        t = te.max(t + 1e-4);
    }
    [mn, mx]
}

/// Visibility of one sample ray of a slice through the slice's min-max tree `row` (CPU twin of
/// the shader's `tree_ray`). `(V̄, medium length, lit weight)`.
pub fn tree_ray(
    p: &ScatterParams,
    shadow: &Raster,
    (row, n, slice): (&[[f32; 2]], u32, &EpiSlice),
    tree_level: u32,
    dir: Vec3,
    s: f32,
) -> (f32, f32, f32) {
    let msize = glam::Vec2::new(shadow.width as f32, shadow.height as f32);
    let r = map_ray(p, msize, dir, s);
    if r.tout <= r.tin {
        return ray_result(p, &r, dir, (0.0, 0.0));
    }
    let o = glam::Vec2::from(slice.line_o);
    let ld = glam::Vec2::from(slice.line_d);
    let b0 = (r.a.truncate() - o).dot(ld);
    let bd = r.d.truncate().dot(ld);
    let nudge = if bd > 0.0 { 1e-3 } else { -1e-3 };
    let top = n.trailing_zeros();
    let (mut level, mut t, mut iter) = (top, r.tin, 0u32);
    let (mut lit, mut weighted) = (0.0f32, 0.0f32);
    let ext = p.light_extinction != 0;
    while t < r.tout && iter < MAX_ITER {
        iter += 1;
        let scale = (1u32 << level) as f32;
        let width = n >> level;
        let idx = (((b0 + bd * t + nudge) / scale).floor().max(0.0) as u32).min(width - 1);
        let (lo, hi) = (idx as f32 * scale, (idx + 1) as f32 * scale);
        let mut t_exit = r.tout;
        if bd > 1e-12 {
            t_exit = t_exit.min((hi - b0) / bd);
        } else if bd < -1e-12 {
            t_exit = t_exit.min((lo - b0) / bd);
        }
        let t_exit = t_exit.max(t);
        let (z0, z1) = (r.a.z + r.d.z * t, r.a.z + r.d.z * t_exit);
        let mm = row[(2 * n - 2 * width) as usize + idx as usize];
        let next = ((b0 + bd * t_exit + nudge) / (2.0 * scale))
            .floor()
            .max(0.0) as u32;
        let up = if next != idx >> 1 {
            (level + 1).min(top)
        } else {
            level
        };
        // What this node settles (the shader's comments say why it is one branch).
        let (mut lit_end, mut share, mut walk) = (t, 0.0f32, false);
        let (mut t_next, mut next_level) = (t_exit, up);
        let lit_all = z0.max(z1) <= mm[0] + p.bias;
        let dark_all = z0.min(z1) > mm[1] + p.bias;
        if lit_all || dark_all || (level > 0 && level <= tree_level && mm[1] < SHADOW_CLEAR) {
            let zm = 0.5 * (z0 + z1);
            let estimate = ((mm[1] + p.bias - zm) / (mm[1] - mm[0]).max(1e-6)).clamp(0.0, 1.0);
            share = if lit_all {
                1.0
            } else if dark_all {
                0.0
            } else {
                estimate
            };
            lit_end = t_exit;
        } else if level == 0 {
            walk = true;
            next_level = level;
        } else {
            (t_next, next_level) = (t, level - 1);
        }
        if walk {
            let (l, wt) = texel_walk(p, shadow, &r, dir, (t, t_exit), LEAF_CELLS);
            lit += l;
            weighted += wt;
        }
        lit += (lit_end - t) * share;
        if ext && lit_end > t && share > 0.0 {
            weighted += weight(p, dir, r.t0, t, lit_end) * share;
        }
        (t, level) = (t_next, next_level);
    }
    if t < r.tout {
        let (l, wt) = texel_walk(p, shadow, &r, dir, (t, r.tout), MAX_ITER);
        lit += l;
        weighted += wt;
    }
    ray_result(p, &r, dir, (lit, weighted))
}

/// Iteration cap of a tree walk (the shader's `MAX_ITER`).
pub(super) const MAX_ITER: u32 = 16384;

/// Texels a leaf's stretch of a ray can cross (a unit stretch crosses at most three; the
/// fourth takes any rounding left-over).
pub(super) const LEAF_CELLS: u32 = 4;

/// One sample of the sample pass: `(V̄, lit fraction of the weight, camera depth, medium
/// length)` — the texel of the shader's `samples` texture.
pub type EpiSample = [f32; 4];

/// The screen point of sample `j` of a slice.
pub(super) fn sample_point(slice: &EpiSlice, j: u32, samples: u32) -> glam::Vec2 {
    let f = j as f32 / (samples - 1).max(1) as f32;
    glam::Vec2::from(slice.entry) + glam::Vec2::from(slice.dir) * (slice.len * f)
}

/// CPU reference of method `Epipolar`: V̄ of every pixel of the `depth` view (row-major),
/// with the per-pixel fall-back traced exactly ([`exact_ray`]).
pub fn epipolar_reference(
    p: &ScatterParams,
    shadow: &Raster,
    depth: &Raster,
    knobs: EpiKnobs,
) -> Vec<f32> {
    let (w, h) = (depth.width, depth.height);
    let g = epipolar_geometry(p, (w, h), (shadow.width, shadow.height), knobs.slices);
    let inv = Mat4::from_cols_array_2d(&p.inv_view_proj);
    let eye = Vec3::from(p.eye);
    let trees: Vec<Vec<[f32; 2]>> = g
        .slices
        .iter()
        .map(|s| epi_tree_row(shadow, s, g.tree_n))
        .collect();
    let samples: Vec<Vec<EpiSample>> = g
        .slices
        .iter()
        .zip(&trees)
        .map(|(slice, row)| {
            (0..knobs.samples)
                .map(|j| {
                    let q = sample_point(slice, j, knobs.samples);
                    let px = (q.x.floor().max(0.0) as u32).min(w - 1);
                    let py = (q.y.floor().max(0.0) as u32).min(h - 1);
                    let s = depth.pixel(px, py)[0];
                    let dir = tyndall_engine::eval::screen_ray(inv, eye, q, w, h);
                    let (vbar, len, wt) =
                        tree_ray(p, shadow, (row, g.tree_n, slice), knobs.tree_level, dir, s);
                    [vbar, lit_fraction(p, dir, len, wt, s), s, len]
                })
                .collect()
        })
        .collect();
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let dir = tyndall_engine::eval::pixel_ray(inv, eye, x, y, w, h);
            let s = depth.pixel(x, y)[0];
            let (t0, t1) = medium_segment(p, dir, s);
            let len = (t1 - t0).max(0.0);
            let pc = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
            let got = epi_interpolate(&g, knobs, pc, s, len, |k, j| {
                samples[k as usize][j as usize]
            });
            out.push(match got {
                Some(v) => v[0],
                None => exact_ray(p, shadow, dir, s).0,
            });
        }
    }
    out
}

/// The lit share of a ray's weight (1 when the weight is 0 or light extinction is off).
pub(super) fn lit_fraction(p: &ScatterParams, dir: Vec3, len: f32, weighted: f32, s: f32) -> f32 {
    if p.light_extinction == 0 {
        return 1.0;
    }
    let (t0, _) = medium_segment(p, dir, s);
    let full = weight(p, dir, t0, t0, t0 + len);
    if full > 0.0 {
        (weighted / full).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// The pixel centred at `pc` (camera depth `s`, medium length `len`) interpolated from the
/// samples (`sample(slice, j)`) of the two slices around its line through the epipole:
/// `Some((V̄, lit fraction))`, or `None` when no neighbouring sample is within the threshold
/// (CPU twin of the shader's `epi_gather`).
pub fn epi_interpolate(
    g: &EpiGeometry,
    knobs: EpiKnobs,
    pc: glam::Vec2,
    s: f32,
    len: f32,
    sample: impl Fn(u32, u32) -> EpiSample,
) -> Option<[f32; 2]> {
    let e = glam::Vec2::from(g.epipole);
    let rv = pc - e;
    if rv.length_squared() < 1e-6 {
        return None;
    }
    let u = border_coordinate(pc, rv.normalize(), glam::Vec2::from(g.size));
    let count = knobs.slices;
    let mut rel = u - g.u_start;
    if rel < 0.0 {
        rel += 4.0;
    }
    let mut f = rel / g.arc * count as f32 - 0.5;
    let (k0, k1, wk);
    if g.inside {
        if f < 0.0 {
            f += count as f32;
        }
        k0 = (f.floor().max(0.0) as u32).min(count - 1);
        wk = (f - k0 as f32).clamp(0.0, 1.0);
        k1 = (k0 + 1) % count;
    } else {
        f = f.clamp(0.0, (count - 1) as f32);
        k0 = (f.floor() as u32).min(count - 1);
        wk = f - k0 as f32;
        k1 = (k0 + 1).min(count - 1);
    }
    let m = knobs.samples;
    let (mut total, mut acc) = (0.0f32, [0.0f32; 2]);
    for (k, wslice) in [(k0, 1.0 - wk), (k1, wk)] {
        let slice = &g.slices[k as usize];
        let along = (pc - glam::Vec2::from(slice.entry)).dot(glam::Vec2::from(slice.dir));
        let j = if slice.len > 1e-6 {
            (along / slice.len * (m - 1) as f32).clamp(0.0, (m - 1) as f32)
        } else {
            0.0
        };
        let j0 = (j.floor() as u32).min(m - 1);
        let j1 = (j0 + 1).min(m - 1);
        let wj = j - j0 as f32;
        for (jj, wsample) in [(j0, 1.0 - wj), (j1, wj)] {
            let v = sample(k, jj);
            let wt = wslice * wsample;
            let near = (v[2] - s).abs() <= knobs.threshold * s.abs()
                && (v[3] - len).abs() <= knobs.threshold * len;
            if near && wt > 0.0 {
                total += wt;
                acc[0] += wt * v[0];
                acc[1] += wt * v[1];
            }
        }
    }
    (total > 1e-6).then(|| [acc[0] / total, acc[1] / total])
}
