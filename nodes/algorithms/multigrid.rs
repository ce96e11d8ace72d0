//! A multigrid solver (V-cycles of weighted Jacobi) for Laplace's equation on a square grid of
//! RGBA texels with some texels fixed (Dirichlet constraints anywhere in the grid): the
//! diffusion behind `TransferFunction`'s diffusion layers, usable by any node that fills a
//! grid smoothly between known values.

/// One RGBA texel.
pub type Rgba = [f32; 4];

/// A grid level of the diffusion solve: size and which texels are constrained.
#[derive(Debug, Clone)]
pub struct Level {
    /// Width.
    pub w: u32,
    /// Height.
    pub h: u32,
    /// 1 where a constraint fixes the texel (at coarse levels: where any finer texel below it
    /// is fixed), else 0.
    pub mask: Vec<f32>,
}

/// The multigrid hierarchy: the finest level first, halving (rounding up) while both sides are
/// above 4.
pub fn levels(n: u32, finest_mask: Vec<f32>) -> Vec<Level> {
    let mut out = vec![Level {
        w: n,
        h: n,
        mask: finest_mask,
    }];
    loop {
        let prev = &out[out.len() - 1];
        if prev.w <= 4 || prev.h <= 4 {
            break;
        }
        let (w, h) = (prev.w.div_ceil(2), prev.h.div_ceil(2));
        let mut mask = vec![0.0f32; (w * h) as usize];
        for y in 0..prev.h {
            for x in 0..prev.w {
                let m = prev.mask[(y * prev.w + x) as usize];
                let k = ((y / 2) * w + x / 2) as usize;
                mask[k] = mask[k].max(m);
            }
        }
        out.push(Level { w, h, mask });
    }
    out
}

/// Weighted-Jacobi factor of the smoother.
pub const OMEGA: f32 = 0.8;
/// Smoothing sweeps before and after each coarse-grid correction.
pub const SWEEPS: u32 = 2;
/// Sweeps on the coarsest grid.
pub const COARSE_SWEEPS: u32 = 40;

/// One grid level's texels, row-major.
pub type Grid = Vec<Rgba>;

/// The sum of texel (x, y)'s four neighbours inside the `w × h` grid and their number.
pub fn nbr(u: &Grid, w: u32, h: u32, x: u32, y: u32) -> (Rgba, f32) {
    let mut s = [0.0f32; 4];
    let mut c = 0.0f32;
    let mut add = |q: &Rgba| {
        for ch in 0..4 {
            s[ch] += q[ch];
        }
        c += 1.0;
    };
    if x + 1 < w {
        add(&u[(y * w + x + 1) as usize]);
    }
    if x > 0 {
        add(&u[(y * w + x - 1) as usize]);
    }
    if y + 1 < h {
        add(&u[((y + 1) * w + x) as usize]);
    }
    if y > 0 {
        add(&u[((y - 1) * w + x) as usize]);
    }
    (s, c)
}

/// The pin of a constrained coarse texel at level `i` ≥ 1: a conductance to zero of
/// 2π/(i ln 2) instead of a hard zero. In 2D a pinned cell's pull on its surroundings grows
/// with its size (the resistance from a disc of radius r to a far circle R is ln(R/r)/2π), and a
/// coarse texel is 2^i times the constrained fine one; the conductance adds back the
/// resistance i·ln 2/2π that the larger cell lacks, so coarse corrections near constraints
/// are not pinned too hard (with hard zeros the V-cycle converges ~4× slower).
pub fn pin(i: usize) -> f32 {
    if i == 0 {
        f32::INFINITY
    } else {
        std::f32::consts::TAU / (i as f32 * std::f32::consts::LN_2)
    }
}

/// One weighted-Jacobi sweep ([`OMEGA`]) of level `i` on L u = f, L the grid's graph
/// Laplacian (degree minus neighbours): on the finest level constrained texels take `fixed`
/// (0 when `None`), on coarser ones they are pinned towards 0 with conductance [`pin`].
pub fn smooth(l: &Level, i: usize, u: &Grid, f: &Grid, fixed: Option<&Grid>) -> Grid {
    let mut out = u.clone();
    for y in 0..l.h {
        for x in 0..l.w {
            let k = (y * l.w + x) as usize;
            let pinned = l.mask[k] > 0.5;
            if pinned && i == 0 {
                out[k] = fixed.map_or([0.0; 4], |v| v[k]);
                continue;
            }
            let (s, c) = nbr(u, l.w, l.h, x, y);
            let diag = c + if pinned { pin(i) } else { 0.0 };
            if diag == 0.0 {
                continue;
            }
            out[k] = std::array::from_fn(|ch| {
                let jacobi = (f[k][ch] + s[ch]) / diag;
                u[k][ch] + OMEGA * (jacobi - u[k][ch])
            });
        }
    }
    out
}

/// The residual f − L u of level `i` (see [`smooth`]); zero on constrained finest texels.
pub fn residual(l: &Level, i: usize, u: &Grid, f: &Grid) -> Grid {
    let mut r = vec![[0.0f32; 4]; u.len()];
    for y in 0..l.h {
        for x in 0..l.w {
            let k = (y * l.w + x) as usize;
            let pinned = l.mask[k] > 0.5;
            if pinned && i == 0 {
                continue;
            }
            let (s, c) = nbr(u, l.w, l.h, x, y);
            let diag = c + if pinned { pin(i) } else { 0.0 };
            r[k] = std::array::from_fn(|ch| f[k][ch] - (diag * u[k][ch] - s[ch]));
        }
    }
    r
}

/// Full-weighting restriction: each coarse texel sums the 2 × 2 fine texels below it.
pub fn restrict(fine: &Level, coarse: &Level, r: &Grid) -> Grid {
    let mut out = vec![[0.0f32; 4]; (coarse.w * coarse.h) as usize];
    for y in 0..coarse.h {
        for x in 0..coarse.w {
            let mut s = [0.0f32; 4];
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (qx, qy) = (2 * x + dx, 2 * y + dy);
                if qx < fine.w && qy < fine.h {
                    let q = r[(qy * fine.w + qx) as usize];
                    for ch in 0..4 {
                        s[ch] += q[ch];
                    }
                }
            }
            out[(y * coarse.w + x) as usize] = s;
        }
    }
    out
}

/// Add the coarse correction `e`, interpolated bilinearly, to the free fine texels of `u`.
pub fn prolong(fine: &Level, coarse: &Level, u: &Grid, e: &Grid) -> Grid {
    let raster = tyndall_engine::io::Raster {
        width: coarse.w,
        height: coarse.h,
        channels: 4,
        data: e.iter().flatten().copied().collect(),
    };
    let mut out = u.clone();
    for y in 0..fine.h {
        for x in 0..fine.w {
            let k = (y * fine.w + x) as usize;
            if fine.mask[k] > 0.5 {
                continue;
            }
            // Texel coordinates of the fine texel's centre on the coarse grid (as uv × size).
            let c = super::shader_lib::bilinear_texels(
                &raster,
                [
                    (x as f32 + 0.5) / (2.0 * coarse.w as f32) * coarse.w as f32,
                    (y as f32 + 0.5) / (2.0 * coarse.h as f32) * coarse.h as f32,
                ],
            );
            out[k] = std::array::from_fn(|ch| u[k][ch] + c[ch]);
        }
    }
    out
}

/// One V-cycle from level `i` down: [`SWEEPS`] sweeps, the coarse correction, [`SWEEPS`]
/// sweeps; [`COARSE_SWEEPS`] on the coarsest level.
pub fn vcycle(ls: &[Level], i: usize, u: Grid, f: &Grid, fixed: Option<&Grid>) -> Grid {
    let l = &ls[i];
    if i + 1 == ls.len() {
        return (0..COARSE_SWEEPS).fold(u, |u, _| smooth(l, i, &u, f, fixed));
    }
    let mut u = (0..SWEEPS).fold(u, |u, _| smooth(l, i, &u, f, fixed));
    let fc = restrict(l, &ls[i + 1], &residual(l, i, &u, f));
    let zero = vec![[0.0f32; 4]; fc.len()];
    let e = vcycle(ls, i + 1, zero, &fc, None);
    u = prolong(l, &ls[i + 1], &u, &e);
    (0..SWEEPS).fold(u, |u, _| smooth(l, i, &u, f, fixed))
}
