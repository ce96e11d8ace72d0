//! `EpipolarDilation`, `EpipolarClosure`: silhouette enhancement by 1D morphology along
//! epipolar lines (SPEC §4, seed 000 eq. 3, seed 001 §4.1, Fig. 8).
//!
//! The epipole `l` is the camera position projected into the shadow map (texel units, may lie
//! far outside the map) with light-space depth `z_l` (may lie outside [0, 1]). For texel t at
//! distance d_t > 0 from l, samples s are taken at i = 1…`length` texels along the unit
//! direction from t towards l (nearest texel, stopping at the map border and before reaching
//! l), each giving `d_t/d_s · (z_s − z_l) + z_l`; the dilation is the minimum of these and z_t
//! (eq. 3). In slope space κ = (z − z_l)/d this is a plain 1D minimum of κ along the ray. The
//! closure follows with the dual erosion (maximum, samples on the far side from l). A texel at
//! the epipole is unchanged; samples at the epipole are skipped.
//!
//! The epipole comes from the `camera` input (a Depth's camera, projected with the map's light
//! matrices) when connected, else from the parameters.
//!
//! Any light's map: on a spot's perspective map eq. 3 holds for q = 1 − near / w (w the
//! distance along the spot's axis; 1/w, not the linear depth, is affine across a perspective
//! map), so the passes run on q and convert back ([`Perspective`]); a camera behind the spot's
//! plane swaps the sides each operation samples. `method = Fast` runs the definition there. A
//! point light's cube atlas is refused (its epipolar lines cross the faces). Test:
//! `cargo test --test filters -- spot`: every filled texel lies on the view ray through the
//! occluder, within its footprint (129 texels off without the conversion).
//!
//! | port | dir | type |
//! |---|---|---|
//! | `map` | in | ShadowMap (required) |
//! | `camera` | in | Depth (optional): camera whose position is the epipole |
//! | `map` | out | ShadowMap (same matrices) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `length` | Int | 15 | 0…4096 texels | kernel length k; 0 is the identity |
//! | `epipole_x`, `epipole_y` | Float | 0, 0 | ±1e9 texels | epipole when `camera` is unconnected |
//! | `epipole_depth` | Float | 0 | ±1e9 | z_l when `camera` is unconnected |
//! | `method` | Enum | Reference | Reference, Fast | algorithm |
//!
//! `method = Reference` runs the definition above on the GPU, O(length) per texel. `Fast`
//! gives the same result on every texel with a cost that does not grow with `length` on shadow
//! maps: each texel takes its first and last [`ENDS`] samples exactly and bounds the samples in
//! between with a rectified grid of epipolar rays (rows one texel of arc apart at the far edge,
//! columns one texel of distance apart; each cell holds the min, or max, of κ over the 3×3
//! texels around its point, then a van Herk / Gil–Werman 1D filter runs along each row). When
//! the ends already beat the bound, they are the definition's answer; otherwise, or when the
//! texel's samples stray further from the grid points than a block covers (epipoles ~1e7
//! texels away, where f32 angles are too coarse), that texel runs the exact loop. How many
//! texels fall back depends on the map (a small share on the built-in scenes' shadow maps,
//! growing with `length`; most texels on noise); only their share of the work grows with
//! `length`. The grid costs several texels' worth of
//! work per texel (its disc around the epipole is larger than the map), so on lavapipe `Fast`
//! is slower than `Reference` at lengths up to 60 (BENCHMARKS.md), which is why `Reference`
//! stays the default.

use std::sync::Arc;

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Gpu, GpuError, GpuTexture, Shader, TexFormat, UniformLayout};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// Which epipolar operation a kind performs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EpiOp {
    /// Minimum towards the epipole.
    Dilation,
    /// Dilation then the dual erosion.
    Closure,
}

/// An epipolar morphology node kind.
pub struct Epipolar(pub EpiOp);

tyndall_engine::choice_enum! {
    /// Algorithms (same result).
    pub enum Method { Reference = "Reference", Fast = "Fast" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The family's parameters, read once per run.
    pub struct Params {
        method: Method = ParamSpec::choice("method", Method::NAMES, "Reference", "Reference (the definition, O(length) per texel) or Fast (same result; exact end samples proven against a rectified-grid van Herk bound, cost flat in length on shadow maps; faster on CPU drivers, but 20× slower than Reference on an NVIDIA H200 at 2048²: keep Reference on a GPU)."),
        length: i64 = ParamSpec::int("length", 15, 0, 4096, "texels", "Kernel length k along the epipolar line; 0 is the identity.").light_texels(),
        epipole_x: f32 = ParamSpec::float("epipole_x", 0.0, -1e9, 1e9, "texels", "Epipole x (when `camera` is unconnected); may lie outside the map.").light_texels(),
        epipole_y: f32 = ParamSpec::float("epipole_y", 0.0, -1e9, 1e9, "texels", "Epipole y (when `camera` is unconnected); may lie outside the map.").light_texels(),
        epipole_depth: f32 = ParamSpec::float("epipole_depth", 0.0, -1e9, 1e9, "depth", "Epipole light-space depth z_l (when `camera` is unconnected); may lie outside [0, 1]."),
    }
}

#[rustfmt::skip]
const IN: &[PortSpec] = &[
    PortSpec::required("map", &[PortType::ShadowMap], "Shadow map to sharpen."),
    PortSpec::input("camera", &[PortType::Depth], "Camera whose position gives the epipole."),
];
#[rustfmt::skip]
const OUT: &[PortSpec] = &[PortSpec::output("map", &[PortType::ShadowMap], "The filtered map.")];

const SHADER: Shader = crate::shader("epipolar", include_str!("../shaders/epipolar.wgsl"));

const fn decl(kind: &'static str, doc: &'static str) -> NodeDecl {
    let schema = NodeSchema {
        kind,
        category: "Occluders",
        doc,
        inputs: IN,
        outputs: OUT,
        params: Params::SPECS,
    };
    NodeDecl::new(schema).shaders(&[SHADER]).uniforms(UNIFORMS)
}
const UNIFORMS: &[UniformLayout] = &[EpiParams::LAYOUT, RectParams::LAYOUT, PerspParams::LAYOUT];

static DILATION: NodeDecl = decl(
    "EpipolarDilation",
    "1D dilation along epipolar lines (seed eq. 3): silhouettes extrude towards the camera, shafts sharpen.",
);
static CLOSURE: NodeDecl = decl(
    "EpipolarClosure",
    "Epipolar dilation then the dual erosion: occlusion stays behind objects, shaft edges sharpen.",
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/epipolar.wgsl` (struct `Params`).
    pub struct EpiParams as "Params" {
        /// Epipole, texel units.
        pub epipole: [f32; 2],
        /// z_l.
        pub z_l: f32,
        /// k.
        pub length: i32,
        /// 0 dilation (min towards l), 1 erosion (max away from l).
        pub op: u32,
        /// 1: each operation samples the other side of the texel (see [`Perspective`]).
        pub reverse: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// CPU reference of one pass (`erode = false`: the dilation of eq. 3), in the same f32 steps as
/// the shader.
pub fn reference(map: &Raster, l: [f32; 2], z_l: f32, length: i32, erode: bool) -> Raster {
    reference_sides(map, l, z_l, length, erode, false)
}

/// [`reference()`] with the sides swapped when `reverse` (the `reverse` uniform).
pub fn reference_sides(
    map: &Raster,
    l: [f32; 2],
    z_l: f32,
    length: i32,
    erode: bool,
    reverse: bool,
) -> Raster {
    let (w, h) = (map.width as i32, map.height as i32);
    let mut out = map.clone();
    for y in 0..h {
        for x in 0..w {
            let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
            let z = map.data[(y * w + x) as usize];
            let (tx, ty) = (l[0] - cx, l[1] - cy);
            let d_t = (tx * tx + ty * ty).sqrt();
            if d_t <= 0.0 {
                continue;
            }
            let towards = erode == reverse;
            let (dx, dy) = if towards {
                (tx / d_t, ty / d_t)
            } else {
                (-tx / d_t, -ty / d_t)
            };
            let mut k = (z - z_l) / d_t;
            for i in 1..=length {
                if towards && i as f32 >= d_t {
                    break;
                }
                let (sx, sy) = (
                    (cx + dx * i as f32).floor() as i32,
                    (cy + dy * i as f32).floor() as i32,
                );
                if sx < 0 || sy < 0 || sx >= w || sy >= h {
                    break;
                }
                let (ex, ey) = (l[0] - (sx as f32 + 0.5), l[1] - (sy as f32 + 0.5));
                let d_s = (ex * ex + ey * ey).sqrt();
                if d_s <= 0.0 {
                    continue;
                }
                let ks = (map.data[(sy * w + sx) as usize] - z_l) / d_s;
                k = if erode { k.max(ks) } else { k.min(ks) };
            }
            out.data[(y * w + x) as usize] = z_l + d_t * k;
        }
    }
    out
}

/// The epipole (texel units) and its depth: the camera position projected with the light's
/// matrices into a `w × h` map.
pub fn epipole(light: &Matrices, camera: &Matrices, w: u32, h: u32) -> ([f32; 2], f32) {
    let c = light.view_proj().project_point3(camera.eye());
    (
        [(c.x * 0.5 + 0.5) * w as f32, (0.5 - c.y * 0.5) * h as f32],
        c.z,
    )
}

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

fn fast_pass(gpu: &Gpu, src: &GpuTexture, p: EpiParams) -> Result<GpuTexture, GpuError> {
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

/// A spot's perspective map in eq. 3's slope space. Its depth z is linear in the distance
/// w = near + z (far − near) along the spot's axis, and a perspective projection keeps 1/w,
/// not w, affine across the map: along the image of a view ray (a line through the epipole),
/// q = 1 − near / w changes linearly with the distance from the epipole, so the passes run on
/// q with the camera's q_l and the depths are converted back (texels the filter left alone keep
/// their depth bit for bit). A camera behind the spot's plane (distance w_c < 0 along its axis)
/// projects through the light onto the far side: its view rays' images run *towards* the
/// epipole as they leave the camera, so each operation samples the other side (`reverse`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perspective {
    /// Distance along the spot's axis of depth 0, m.
    pub near: f32,
    /// Distance along the spot's axis of depth 1, m.
    pub far: f32,
}

impl Perspective {
    /// q of depth `z`.
    pub fn q(&self, z: f32) -> f32 {
        1.0 - self.near / (self.near + z * (self.far - self.near))
    }

    /// The depth of q (the inverse of [`Perspective::q`]).
    pub fn z(&self, q: f32) -> f32 {
        (self.near / (1.0 - q) - self.near) / (self.far - self.near)
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of the perspective passes (struct `Persp` of `shaders/epipolar.wgsl`).
    pub struct PerspParams as "Persp" {
        /// [`Perspective::near`].
        pub near: f32,
        /// [`Perspective::far`].
        pub far: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

/// The epipole of a spot's `w × h` map seen from `camera`: texel position, q_l and whether the
/// sides are reversed (camera behind the spot's plane); an error when the camera lies in that
/// plane (the epipole is at infinity).
pub fn spot_epipole(
    light: &Matrices,
    camera: &Matrices,
    persp: Perspective,
    w: u32,
    h: u32,
) -> Result<([f32; 2], f32, bool), String> {
    let c = light.view_proj() * camera.eye().extend(1.0);
    if c.w.abs() < 1e-4 {
        return Err(format!(
            "the camera lies in the spot's plane ({} m along its axis): the epipole is at infinity",
            c.w
        ));
    }
    let (x, y) = (c.x / c.w, c.y / c.w);
    Ok((
        [(x * 0.5 + 0.5) * w as f32, (0.5 - y * 0.5) * h as f32],
        1.0 - persp.near / c.w,
        c.w < 0.0,
    ))
}

/// CPU reference of the node on a spot's map: [`reference_sides`] on q, converted back;
/// `closure`: the dilation then the erosion.
pub fn reference_spot(
    map: &Raster,
    persp: Perspective,
    (l, q_l, reverse): ([f32; 2], f32, bool),
    length: i32,
    closure: bool,
) -> Raster {
    let mut q = map.clone();
    for v in &mut q.data {
        *v = persp.q(*v);
    }
    let mut r = reference_sides(&q, l, q_l, length, false, reverse);
    if closure {
        r = reference_sides(&r, l, q_l, length, true, reverse);
    }
    let mut out = map.clone();
    for ((o, before), after) in out.data.iter_mut().zip(&q.data).zip(&r.data) {
        if after != before {
            *o = persp.z(*after);
        }
    }
    out
}

fn to_q(gpu: &Gpu, src: &GpuTexture, persp: Perspective) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(src.width, src.height, TexFormat::R32F)?;
    let u = persp_params(persp);
    gpu.dispatch(
        SHADER,
        "to_q",
        &[
            ("Q", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(src)),
            ("out_map", Bind::Storage(&out)),
        ],
        src.width,
        src.height,
    )?;
    Ok(out)
}

fn from_q(
    gpu: &Gpu,
    depth: &GpuTexture,
    before: &GpuTexture,
    after: &GpuTexture,
    persp: Perspective,
) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(depth.width, depth.height, TexFormat::R32F)?;
    let u = persp_params(persp);
    gpu.dispatch(
        SHADER,
        "from_q",
        &[
            ("Q", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(depth)),
            ("q_in", Bind::Texture(before)),
            ("kappa_in", Bind::Texture(after)),
            ("out_map", Bind::Storage(&out)),
        ],
        depth.width,
        depth.height,
    )?;
    Ok(out)
}

fn persp_params(p: Perspective) -> PerspParams {
    PerspParams {
        near: p.near,
        far: p.far,
        _pad0: 0,
        _pad1: 0,
    }
}

fn pass(gpu: &Gpu, src: &GpuTexture, p: EpiParams) -> Result<GpuTexture, GpuError> {
    let out = gpu.texture(src.width, src.height, TexFormat::R32F)?;
    gpu.dispatch(
        SHADER,
        "reference",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&p))),
            ("src", Bind::Texture(src)),
            ("out_map", Bind::Storage(&out)),
        ],
        src.width,
        src.height,
    )?;
    Ok(out)
}

impl NodeKind for Epipolar {
    fn decl(&self) -> &'static NodeDecl {
        match self.0 {
            EpiOp::Dilation => &DILATION,
            EpiOp::Closure => &CLOSURE,
        }
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let prm = Params::from_ctx(ctx)?;
        let (tex, light) = ctx.shadow_map("map")?;
        let persp = match light.local {
            Some(l) if l.point => {
                return Err(NodeError::Input {
                    port: "map".into(),
                    message: "is a point light's cube atlas: its epipolar lines cross the six \
                              faces, which this node does not follow yet (Dilate2D, Erode2D and \
                              Closure2D do)"
                        .into(),
                })
            }
            Some(l) => Some(Perspective {
                near: l.near,
                far: l.far,
            }),
            None => None,
        };
        let (l, z_l, reverse) = match (ctx.depth_opt("camera")?, persp) {
            (Some((_, cam)), Some(p)) => spot_epipole(&light, &cam, p, tex.width, tex.height)
                .map_err(|message| NodeError::Input {
                    port: "camera".into(),
                    message,
                })?,
            (Some((_, cam)), None) => {
                let (l, z) = epipole(&light, &cam, tex.width, tex.height);
                (l, z, false)
            }
            (None, Some(p)) => (
                [prm.epipole_x, prm.epipole_y],
                p.q(prm.epipole_depth),
                false,
            ),
            (None, None) => ([prm.epipole_x, prm.epipole_y], prm.epipole_depth, false),
        };
        let length = prm.length as i32;
        if length == 0 {
            ctx.set("map", PortValue::ShadowMap(tex, light));
            return Ok(());
        }
        let p = EpiParams {
            epipole: l,
            z_l,
            length,
            op: 0,
            reverse: reverse as u32,
            _pad1: 0,
            _pad2: 0,
        };
        // The fast path's grid is built for a sun's map; a spot's runs the definition.
        let run_pass = if prm.method == Method::Fast && persp.is_none() {
            fast_pass
        } else {
            pass
        };
        let src = match persp {
            Some(q) => Arc::new(to_q(ctx.gpu, &tex, q)?),
            None => tex.clone(),
        };
        let mut out = run_pass(ctx.gpu, &src, p)?;
        if self.0 == EpiOp::Closure {
            out = run_pass(ctx.gpu, &out, EpiParams { op: 1, ..p })?;
        }
        if let Some(q) = persp {
            out = from_q(ctx.gpu, &tex, &src, &out, q)?;
        }
        ctx.set("map", PortValue::ShadowMap(Arc::new(out), light));
        Ok(())
    }
}
