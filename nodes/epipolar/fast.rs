//! The fast path of `EpipolarDilation` / `EpipolarClosure` (see the parent module's docs):
//! the rectified grid of epipolar rays, its 1D van Herk / Gil–Werman filter and the exact ends.

use tyndall_engine::gpu::Recorder;
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, TexFormat};

use super::{pass, EpiParams, SHADER};

tyndall_engine::uniforms! {
    /// Uniforms of the fast path (struct `Rect` of `shaders/epipolar.wgsl`).
    pub struct RectParams as "Rect" {
        /// Unit direction from the epipole towards the map's centre; angles are measured from it.
        pub u_c: [f32; 2],
        /// Angle of row 0.
        pub phi0: f32,
        /// Angle step between rows.
        pub dphi: f32,
        /// Epipole, texels.
        pub epipole: [f32; 2],
        /// Distance of column 0 from the epipole.
        pub d0: f32,
        /// z_l.
        pub z_l: f32,
        /// The grid window reaches this many samples towards the epipole…
        pub lo: i32,
        /// …and this many away from it.
        pub hi: i32,
        /// 0 min, 1 max.
        pub op: u32,
        /// Grid rows (angles).
        pub rows: u32,
        /// Grid columns (distances, one per texel).
        pub cols: u32,
        /// Samples taken exactly at each end of a texel's window ([`ENDS`]).
        pub ends: i32,
        /// Kernel length k.
        pub length: i32,
        /// Padding.
        pub _pad0: u32,
    }
}

/// The fast path's grid and its row table (per row: direction and the point at distance d0,
/// computed in f64 so far epipoles keep map-local precision).
pub struct Rectified {
    /// Uniforms.
    pub params: RectParams,
    /// `rows × 4` floats: dir.x, dir.y, base.x, base.y.
    pub table: Vec<f32>,
}

/// Samples at each end of a window that the fast path always takes exactly: on smooth
/// stretches of a map the extreme lies at an end, where the grid's bound would be too loose.
pub const ENDS: i32 = 3;

/// The rectified grid covering a `w × h` map seen from `l`, for a window of `k` samples
/// (dilation: towards l; erosion: away from it): one row per texel of arc at the map's far
/// edge, one column per texel of distance, each capped at `limit`. `None` when the fast path has
/// nothing to gain (k ≤ 2·[`ENDS`]: every sample is taken exactly) or the device cannot hold a
/// grid fine enough for a 3×3 block to cover the samples.
///
/// (Finer grids — 2×2 blocks on an oversampled grid — give tighter bounds and fewer fall-backs
/// but cost 4× the cells, which measured slower overall on lavapipe; that variant was removed.)
pub fn rect_params(
    w: u32,
    h: u32,
    l: [f32; 2],
    z_l: f32,
    k: i32,
    erode: bool,
    limit: u32,
) -> Option<Rectified> {
    if k <= 2 * ENDS {
        return None;
    }
    let (lx, ly) = (l[0] as f64, l[1] as f64);
    let (wf, hf) = (w as f64, h as f64);
    let (cx, cy) = (wf / 2.0 - lx, hf / 2.0 - ly);
    let dist = cx.hypot(cy);
    // The shader measures angles from the f32 u_c; use the same rounded vector here.
    let (ux, uy) = if dist > 0.0 {
        ((cx / dist) as f32 as f64, (cy / dist) as f32 as f64)
    } else {
        (1.0, 0.0)
    };
    let corners = [(0.0, 0.0), (wf, 0.0), (0.0, hf), (wf, hf)];
    let d_hi = corners
        .iter()
        .map(|(x, y)| (x - lx).hypot(y - ly))
        .fold(0.0, f64::max);
    let inside = (0.0..=wf).contains(&lx) && (0.0..=hf).contains(&ly);
    let d_lo = if inside {
        0.0
    } else {
        (lx.clamp(0.0, wf) - lx).hypot(ly.clamp(0.0, hf) - ly)
    };
    let (phi0, span) = if inside {
        (-std::f64::consts::PI, 2.0 * std::f64::consts::PI)
    } else {
        let phis: Vec<f64> = corners
            .iter()
            .map(|(x, y)| {
                let (vx, vy) = (x - lx, y - ly);
                (ux * vy - uy * vx).atan2(ux * vx + uy * vy)
            })
            .collect();
        let lo = phis.iter().cloned().fold(f64::MAX, f64::min);
        let hi = phis.iter().cloned().fold(f64::MIN, f64::max);
        (lo, hi - lo)
    };
    let d0 = (d_lo.floor() - 1.0).max(0.0);
    let rows = ((span * d_hi).ceil().max(0.0) as u64 + 1).clamp(2, limit as u64) as u32;
    let cols = ((d_hi - d0).ceil().max(0.0) as u64 + 2).clamp(1, limit as u64) as u32;
    let phi0 = phi0 as f32 as f64;
    let dphi = (span / (rows - 1) as f64) as f32 as f64;
    // A texel's samples lie within half a row spacing (at the far edge) and half a column of
    // the grid points it reads; the 3×3 block covers one texel, with room for rounding.
    if (0.5 * dphi * d_hi).hypot(0.5) > 0.9 {
        return None;
    }
    let n = k - 2 * ENDS;
    let (lo, hi) = if erode { (0, n - 1) } else { (n - 1, 0) };
    let table = (0..rows)
        .flat_map(|j| {
            let phi = phi0 + j as f64 * dphi;
            let (s, c) = phi.sin_cos();
            let (dx, dy) = (ux * c - uy * s, ux * s + uy * c);
            [
                dx as f32,
                dy as f32,
                (lx + dx * d0) as f32,
                (ly + dy * d0) as f32,
            ]
        })
        .collect();
    Some(Rectified {
        params: RectParams {
            u_c: [ux as f32, uy as f32],
            phi0: phi0 as f32,
            dphi: dphi as f32,
            epipole: l,
            d0: d0 as f32,
            z_l,
            lo,
            hi,
            op: erode as u32,
            rows,
            cols,
            ends: ENDS,
            length: k,
            _pad0: 0,
        },
        table,
    })
}

pub(super) fn fast_pass(
    gpu: &Recorder,
    src: &GpuTexture,
    p: EpiParams,
) -> Result<GpuTexture, GpuError> {
    let limit = gpu.limits.max_texture_dimension_2d;
    let Some(rect) = rect_params(
        src.width,
        src.height,
        p.epipole,
        p.z_l,
        p.length,
        p.op == 1,
        limit,
    ) else {
        return pass(gpu, src, p);
    };
    let r = rect.params;
    let rb = bytemuck::bytes_of(&r);
    let table = gpu.upload(r.rows, 1, 4, &rect.table)?;
    let kappa = gpu.texture(src.width, src.height, TexFormat::R32F)?;
    gpu.dispatch(
        SHADER,
        "kappa",
        &[
            ("src", Bind::Texture(src)),
            ("R", Bind::Uniform(rb)),
            ("grid_out", Bind::Storage(&kappa)),
        ],
        src.width,
        src.height,
    )?;
    let grid = gpu.texture(r.cols, r.rows, TexFormat::R32F)?;
    gpu.dispatch(
        SHADER,
        "rectify",
        &[
            ("R", Bind::Uniform(rb)),
            ("grid_out", Bind::Storage(&grid)),
            ("kappa_in", Bind::Texture(&kappa)),
            ("rows_in", Bind::Texture(&table)),
        ],
        r.cols,
        r.rows,
    )?;
    let prefix = gpu.texture(r.cols, r.rows, TexFormat::R32F)?;
    let suffix = gpu.texture(r.cols, r.rows, TexFormat::R32F)?;
    let n = (r.lo + r.hi + 1) as u32;
    gpu.dispatch(
        SHADER,
        "grid_blocks",
        &[
            ("R", Bind::Uniform(rb)),
            ("grid", Bind::Texture(&grid)),
            ("prefix_out", Bind::Storage(&prefix)),
            ("suffix_out", Bind::Storage(&suffix)),
        ],
        r.cols.div_ceil(n),
        r.rows,
    )?;
    // The window texture reuses the grid's cells: the grid is not read after the blocks.
    drop(grid);
    let window = gpu.texture(r.cols, r.rows, TexFormat::R32F)?;
    gpu.dispatch(
        SHADER,
        "grid_combine",
        &[
            ("R", Bind::Uniform(rb)),
            ("prefix_in", Bind::Texture(&prefix)),
            ("suffix_in", Bind::Texture(&suffix)),
            ("grid_out", Bind::Storage(&window)),
        ],
        r.cols,
        r.rows,
    )?;
    let out = gpu.texture(src.width, src.height, TexFormat::R32F)?;
    gpu.dispatch(
        SHADER,
        "project_back",
        &[
            ("src", Bind::Texture(src)),
            ("out_map", Bind::Storage(&out)),
            ("R", Bind::Uniform(rb)),
            ("grid", Bind::Texture(&window)),
            ("kappa_in", Bind::Texture(&kappa)),
            ("rows_in", Bind::Texture(&table)),
        ],
        src.width,
        src.height,
    )?;
    Ok(out)
}
