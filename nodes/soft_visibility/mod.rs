//! `SoftVisibility`: soft shadows of a sun of finite size by iterative convolution (SPEC §7,
//! seed 004 §3), as a light-space volume `SingleScattering` reads instead of its hard
//! shadow-map test (its `soft` input), so shafts get penumbrae.
//!
//! The light's box (the shadow map's orthographic frustum) is cut into `slices` planes of
//! equal light depth, spacing e. Slice k's occlusion o_k(p) is the part of light texel p's
//! footprint in the shadow map whose first occluder (map depth + `bias`) lies in slice k. An
//! accumulated occlusion buffer is carried from slice to slice,
//!
//! A_0 = o_0,  A_k = min(1, (A_{k−1} ∗ κ_k) + o_k),
//!
//! and A_k is stored as slice k of the output (the occlusion at the slice's far end). The
//! kernel κ has mean −e μ_l = 0 (the light direction is the sun's centre) and variance
//! σ_κ² = d1 e σ_l² (seed 004 eq. 7), with σ_l = tan(`sun_radius`)/2 the per-axis standard
//! deviation of directions over a uniform disk, so the penumbra is exact at distance `d1`
//! behind an occluder; elsewhere it grows as √d (seed 004 App. A.4), and the half-shadow line
//! lies where the exact shadow puts it at every distance (eq. 10). Any kernel of that mean and
//! variance converges to the same result; the `kernel` choices differ in cost and artefacts:
//!
//! - `TopHat`: an N×N box (N = ⌈√12 σ⌉, at least 2), `Dirac2`: the four corners (±σ, ±σ),
//! - `StochasticDirac`: the corners at ±r with r = σ √(2u), u uniform per slice (E r² = σ²),
//! - `Ellipse2`: two opposite points on an ellipse at a random angle per slice,
//! - `Poisson`: `samples` points of a Poisson disk (centred), randomly rotated per slice,
//! - `Gaussian`: a `size` × `size` grid of Gaussian weights.
//!
//! The light's shape scales the variance by `ellipse_x`, `ellipse_y` along light-space x and y
//! and turns it by `rotation`. Each slice's kernel is splatted bilinearly onto integer texel
//! offsets (the stencil the GPU applies), its spread scaled so the stencil's variance equals
//! the target exactly — bilinear reads at sub-texel offsets would add their own variance.
//! With zero variance (`sun_radius` 0) the stencil is the identity and A_k is the hard test
//! within one slice.
//!
//! `growth = linear` (beyond the seed) makes the penumbra exact at every distance behind a
//! single occluder plane instead of only at d1: a second buffer Z carries the occlusion-weighted
//! slice index of the occluders (Z_k = Z_{k−1} ∗ κ + k o_k), so n̄ = k − Z/A is their mean age
//! in slices (probed over two standard deviations of the widest possible spread around each
//! texel, so lit texels beside a shadow see it too), and the slice adds the variance
//! max(2 n̄ − 1, 1) e² σ_l² — summing to n² e² σ_l², the exact (d σ_l)² at d = n e — with four
//! bilinear Dirac taps at ±s, s = m + (v − m²)/(2m + 1), m = ⌊√v⌋ (the offset whose bilinear
//! pair has variance v). The kernel choice and `rotation` do not apply to it; several
//! occluders at different depths share one mean age (as PCSS shares one blocker distance).
//!
//! A spot of radius `light_radius` (issue #44): its perspective map is sliced in equal steps of
//! q = 1 − s / w (w the distance along its axis, s its nearest occluder's: the map's smallest
//! depth, selected on the GPU — nothing nearer casts a shadow, and a map's near is a thousandth
//! of its far, so slices from there would be wasted), in which a sphere of light's penumbra grows
//! linearly behind an occluder (map offset L (1/w_o − 1/w_r), L on the light's disc), so
//! `growth = linear` with one slice's variance ((R/2) Δq / s)² (tangent units, then texels)
//! is exact at every distance behind one occluder plane ([`spot_step_variance`]); a spot always
//! grows so. A point light's cube atlas is six such 90° maps: each face is padded with a gutter
//! (`algorithms::cube_atlas`: its neighbours' occluders re-measured along its axis) as wide as
//! its penumbrae spread ([`cube_gutter`]), convolved within itself, and its inner part kept, so a
//! penumbra crosses the cube's seams; `resolution` is then per face (the volume 3 × 2 faces).
//! Off a lamp's axis, at map tangent m, a sphere of light spreads an edge by (1 + m²) the
//! variance on the axis ([`off_axis`]: twice at a face's edge), and each tap takes the offset
//! of the occluder it gathers from, so the half shadow stays put where the spread changes.
//! An occluder nearer to a lamp than `light_radius` lies inside its sphere of light: the
//! slices start there and every penumbra grows as 1 / that distance, so such a scene blurs
//! its shadows away (keep the lamp clear of geometry by more than its radius).
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `shadow` | in | ShadowMap (required) | the occluders and the light's box |
//! | `soft` | out | SoftShadow | `resolution`² × `slices` occlusion, the light's matrices |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `slices` | Int | 64 | 0…1024 | depth slices (quality knob; 0 acts as 1) |
//! | `resolution` | Int | 256 | 16…2048 | light texels per side |
//! | `kernel` | Enum | TopHat | TopHat, Dirac2, StochasticDirac, Ellipse2, Poisson, Gaussian | |
//! | `sun_radius` | Float | 1 | 0…10 ° | angular radius of the sun |
//! | `d1` | Float | 4 | 0.01…1e4 m | distance behind an occluder where the penumbra is exact |
//! | `ellipse_x`, `ellipse_y` | Float | 1 | 0…10 | relative variance along light x, y |
//! | `rotation` | Float | 0 | ±180 ° | turn of the light's shape |
//! | `samples` | Int | 8 | 2…64 | Poisson samples |
//! | `size` | Int | 5 | 2…15 | Gaussian taps per axis |
//! | `seed` | Int | 1 | 0…2³¹ | stochastic kernels |
//! | `bias` | Float | 0.002 | 0…0.1 | added to the map depth |
//! | `growth` | Enum | seed | seed, linear | penumbra ∝ √d (seed 004) or ∝ d (a spot: always ∝ d) |
//! | `light_radius` | Float | 0.1 | 0…100 m | a spot's or point light's sphere of light |

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::algorithms::quantile;
use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

mod kernel;
mod lamp;
pub use kernel::{poisson_disk, stencil, stencil_variance, KernelSpec, Stencil};
use lamp::tiles_of;
pub use lamp::{cube_gutter, off_axis, slice_coord, spot_start, spot_step_variance, LampSlices};

/// The `SoftVisibility` node kind.
pub struct SoftVisibility;

tyndall_engine::choice_enum! {
    /// How the penumbra grows with the distance behind an occluder.
    pub enum Growth { Seed = "seed", Linear = "linear" }
}

tyndall_engine::choice_enum! {
    /// Convolution kernels (seed 004 §3.3–3.4).
    pub enum Kernel {
        TopHat = "TopHat", Dirac2 = "Dirac2", StochasticDirac = "StochasticDirac",
        Ellipse2 = "Ellipse2", Poisson = "Poisson", Gaussian = "Gaussian",
    }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        slices: i64 = ParamSpec::int("slices", 64, 0, 1024, "slices", "Depth slices of the light's box (quality knob; 0 acts as 1)."),
        resolution: i64 = ParamSpec::int("resolution", 256, 16, 2048, "texels", "Light texels per side of the buffer (per cube face for a point light's map).").light_texels(),
        kernel: Kernel = ParamSpec::choice("kernel", Kernel::NAMES, "TopHat", "Convolution kernel; all share the mean and variance of seed 004 eq. 7."),
        sun_radius: f64 = ParamSpec::float("sun_radius", 1.0, 0.0, 10.0, "°", "Angular radius of the sun (the real sun: 0.27°)."),
        d1: f64 = ParamSpec::float("d1", 4.0, 0.01, 1e4, "m", "Distance behind an occluder where the penumbra is exact (seed 004's optimal distance)."),
        ellipse_x: f64 = ParamSpec::float("ellipse_x", 1.0, 0.0, 10.0, "", "Relative variance of the light along light-space x."),
        ellipse_y: f64 = ParamSpec::float("ellipse_y", 1.0, 0.0, 10.0, "", "Relative variance of the light along light-space y."),
        rotation: f64 = ParamSpec::float("rotation", 0.0, -180.0, 180.0, "°", "Turn of the light's shape."),
        samples: i64 = ParamSpec::int("samples", 8, 2, 64, "samples", "Poisson disk samples."),
        size: i64 = ParamSpec::int("size", 5, 2, 15, "taps", "Gaussian taps per axis."),
        seed: i64 = ParamSpec::int("seed", 1, 0, 2147483647, "", "Seed of the stochastic kernels."),
        bias: f32 = ParamSpec::float("bias", 0.002, 0.0, 0.1, "depth", "Added to the map depth before binning occluders."),
        growth: Growth = ParamSpec::choice("growth", Growth::NAMES, "seed", "seed: the kernel of eq. 7 every slice (penumbra exact at d1, ∝ √d); linear: distance-aware Dirac pairs (penumbra ∝ d, exact at every distance behind one occluder plane). A lamp's map (spot or point) always grows linearly."),
        light_radius: f64 = ParamSpec::float("light_radius", 0.1, 0.0, 100.0, "m", "Radius of a spot or point light's sphere of light, m (a lamp's map; the sun's size is sun_radius)."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "SoftVisibility",
    category: "Scattering",
    doc: "Soft shadows of a sun, spot or point light of finite size by iterative convolution of light-space slices (seed 004), for SingleScattering's `soft` input.",
    inputs: &[PortSpec::required("shadow", &[PortType::ShadowMap], "The occluders and the light's box.")],
    outputs: &[PortSpec::output("soft", &[PortType::SoftShadow], "Occlusion per light texel and depth slice.")],
    params: Params::SPECS,
})
.shaders(&[SHADER, quantile::SHADER])
.uniforms(&[SoftParams::LAYOUT, quantile::QuantileParams::LAYOUT]);

const SHADER: Shader = crate::shader(
    "soft_visibility",
    include_str!("../../shaders/soft_visibility.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/soft_visibility.wgsl` (struct `Params`).
    pub struct SoftParams as "Params" {
        /// Buffer side.
        pub res: u32,
        /// The slice written.
        pub slice: u32,
        /// Number of slices.
        pub slices: u32,
        /// Stencil entries per slice.
        pub taps: u32,
        /// One tile of the shadow map (the whole map but for a cube atlas), texels.
        pub map_tile: [u32; 2],
        /// Footprint samples per axis.
        pub footprint: u32,
        /// Depth bias.
        pub bias: f32,
        /// growth = linear: per-axis variance e² σ_l² of one slice, texels².
        pub step_var: [f32; 2],
        /// 1 for growth = linear.
        pub linear: u32,
        /// 1 for a spot's perspective map (slices in q = 1 − near / w).
        pub persp: u32,
        /// A spot map's depth-0 distance, m.
        pub near: f32,
        /// A spot map's depth-1 distance, m.
        pub far: f32,
        /// Where a spot's slices start, m: its nearest occluder.
        pub start: f32,
        /// Each tile's gutter, buffer texels (a cube atlas's faces; 0 otherwise).
        pub gutter: u32,
        /// Tiles across and down: (1, 1), or (3, 2) for a cube atlas.
        pub tiles: [u32; 2],
        /// Each map tile's gutter, map texels.
        pub map_gutter: u32,
        /// Tangent of a lamp map's half-angle (1 on a cube face): the texels' off-axis spread.
        pub tan_half: f32,
    }
}

/// The light box's width, height and depth in metres (from its orthographic projection).
fn box_metres(light: &Matrices) -> [f64; 3] {
    let p = light.proj;
    [
        2.0 / (p[0][0] as f64).abs().max(1e-12),
        2.0 / (p[1][1] as f64).abs().max(1e-12),
        1.0 / (p[2][2] as f64).abs().max(1e-12),
    ]
}

/// Kernel variance per axis in texels² for a light box (`light` matrices), `res` texels and
/// `slices`: σ_κ² = d1 e σ_l², σ_l = tan(radius)/2, scaled by the light's shape — the
/// [`step_variance`] e² σ_l² times d1/e.
pub fn variance_texels(
    light: &Matrices,
    res: u32,
    slices: u32,
    sun_radius_deg: f64,
    d1: f64,
    shape: [f64; 2],
) -> [f64; 2] {
    let e = box_metres(light)[2] / slices.max(1) as f64;
    step_variance(light, res, slices, sun_radius_deg, shape).map(|v| v * d1 / e)
}

/// Footprint samples per axis of a buffer texel in a `map`-texel shadow map.
pub fn footprint(map: u32, res: u32) -> u32 {
    map.div_ceil(res).clamp(1, 4)
}

/// The offset s ≥ 0 whose symmetric pair ±s read bilinearly has variance `v` (texels²).
pub fn pair_offset(v: f32) -> f32 {
    let v = v.max(0.0);
    let m = v.sqrt().floor();
    m + (v - m * m) / (2.0 * m + 1.0)
}

/// One slice's per-axis variance e² σ_l² in texels² (`growth = linear`), scaled by the
/// light's shape.
pub fn step_variance(
    light: &Matrices,
    res: u32,
    slices: u32,
    sun_radius_deg: f64,
    shape: [f64; 2],
) -> [f64; 2] {
    let [width, height, depth] = box_metres(light);
    let e = depth / slices.max(1) as f64;
    let sigma_l = (sun_radius_deg.to_radians()).tan() / 2.0;
    let (tx, ty) = (width / res as f64, height / res as f64);
    [
        (e * sigma_l / tx).powi(2) * shape[0],
        (e * sigma_l / ty).powi(2) * shape[1],
    ]
}

/// CPU reference: the occlusion volume (x fastest, then y, then slice) for a shadow map; with
/// `linear` = Some(per-axis step variance), the distance-aware Dirac pairs instead of `spec`;
/// `lamp`: a spot's slicing, its slices in [`slice_coord`] and its variance [`off_axis`].
pub fn reference(
    map: &Raster,
    res: u32,
    slices: u32,
    spec: &KernelSpec,
    bias: f32,
    linear: Option<[f32; 2]>,
    lamp: Option<LampSlices>,
) -> Vec<f32> {
    let slices = slices.max(1);
    let n = footprint(map.width.max(map.height), res);
    let r = res as usize;
    let mut prev = vec![[0.0f32; 2]; r * r];
    let mut out = Vec::with_capacity(r * r * slices as usize);
    let load = |buf: &[[f32; 2]], x: i32, y: i32| -> [f32; 2] {
        if x < 0 || y < 0 || x >= res as i32 || y >= res as i32 {
            [0.0; 2]
        } else {
            buf[y as usize * r + x as usize]
        }
    };
    let bilinear = |buf: &[[f32; 2]], x: i32, y: i32, o: [f32; 2]| -> [f32; 2] {
        let (fx, fy) = (o[0].floor(), o[1].floor());
        let (ax, ay) = (o[0] - fx, o[1] - fy);
        let (qx, qy) = (x + fx as i32, y + fy as i32);
        let mix =
            |a: [f32; 2], b: [f32; 2], t: f32| [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];
        mix(
            mix(load(buf, qx, qy), load(buf, qx + 1, qy), ax),
            mix(load(buf, qx, qy + 1), load(buf, qx + 1, qy + 1), ax),
            ay,
        )
    };
    for k in 0..slices {
        let st = stencil(spec, k);
        let (lo, hi) = (k as f32 / slices as f32, (k + 1) as f32 / slices as f32);
        let mut next = vec![[0.0f32; 2]; r * r];
        for y in 0..res as i32 {
            for x in 0..res as i32 {
                let mut acc = [0.0f32; 2];
                if k > 0 {
                    match linear {
                        Some(step) => {
                            let factor = |px: f32, py: f32| match lamp {
                                Some(l) => off_axis(px, py, res, l.tan_half),
                                None => [1.0, 1.0],
                            };
                            let (px, py) = (x as f32, y as f32);
                            let here = factor(px, py);
                            let sv = [step[0] * here[0], step[1] * here[1]];
                            let rad = [
                                2.0 * k as f32 * sv[0].sqrt() + 1.0,
                                2.0 * k as f32 * sv[1].sqrt() + 1.0,
                            ];
                            let mut c = load(&prev, x, y);
                            for (sx, sy) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                                let b = bilinear(&prev, x, y, [sx * rad[0], sy * rad[1]]);
                                c = [c[0] + b[0], c[1] + b[1]];
                            }
                            let age = if c[0] > 0.0 {
                                k as f32 - c[1] / c[0]
                            } else {
                                0.0
                            };
                            let base = step.map(|v| (2.0 * age - 1.0).max(1.0) * v);
                            let offsets = |f: [f32; 2]| [0, 1].map(|a| pair_offset(base[a] * f[a]));
                            let mut lo = offsets(here);
                            let mut hi = lo;
                            if lamp.is_some() {
                                // Each tap's offset is the one at its source (the shader's note).
                                let l0 = lo;
                                lo = offsets(factor(px - l0[0], py - l0[1]));
                                hi = offsets(factor(px + l0[0], py + l0[1]));
                            }
                            for (ox, oy) in [
                                (-lo[0], -lo[1]),
                                (hi[0], -lo[1]),
                                (-lo[0], hi[1]),
                                (hi[0], hi[1]),
                            ] {
                                let b = bilinear(&prev, x, y, [ox, oy]);
                                acc = [acc[0] + 0.25 * b[0], acc[1] + 0.25 * b[1]];
                            }
                        }
                        None => {
                            for (dx, dy, w) in &st {
                                let b = load(&prev, x + dx, y + dy);
                                acc = [acc[0] + *w as f32 * b[0], acc[1] + *w as f32 * b[1]];
                            }
                        }
                    }
                }
                let mut hit = 0.0f32;
                for j in 0..n {
                    for i in 0..n {
                        let u = (x as f32 + (i as f32 + 0.5) / n as f32) / res as f32;
                        let v = (y as f32 + (j as f32 + 0.5) / n as f32) / res as f32;
                        let tx = ((u * map.width as f32) as u32).min(map.width - 1);
                        let ty = ((v * map.height as f32) as u32).min(map.height - 1);
                        let d = slice_coord(map.pixel(tx, ty)[0] + bias, lamp).max(0.0);
                        if d >= lo && d < hi {
                            hit += 1.0;
                        }
                    }
                }
                let o = hit / (n * n) as f32;
                next[y as usize * r + x as usize] = [(acc[0] + o).min(1.0), acc[1] + o * k as f32];
            }
        }
        out.extend(next.iter().map(|v| v[0]));
        prev = next;
    }
    out
}

/// The kernel settings of a run.
fn spec_of(ctx: &RunCtx, light: &Matrices, res: u32, slices: u32) -> Result<KernelSpec, NodeError> {
    let p = Params::from_ctx(ctx)?;
    Ok(KernelSpec {
        kernel: p.kernel,
        variance: variance_texels(
            light,
            res,
            slices,
            p.sun_radius,
            p.d1,
            [p.ellipse_x, p.ellipse_y],
        ),
        rotation: p.rotation.to_radians(),
        samples: p.samples.clamp(2, 64) as u32,
        size: p.size.clamp(2, 15) as u32,
        seed: p.seed.max(0) as u32,
    })
}

impl NodeKind for SoftVisibility {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let (map, light) = ctx.shadow_map("shadow")?;
        let res = ctx.side("resolution", p.resolution, 3)?;
        let slices = p.slices.clamp(1, 1024) as u32;
        tyndall_engine::eval::check_side(
            "slices",
            slices as i64,
            ctx.gpu.limits.max_texture_dimension_3d,
            3,
        )?;
        let tiles = tiles_of(ctx, &map, &light, res, slices, p.light_radius)?;
        let [tx, ty] = tiles.count;
        let side = res + 2 * tiles.gutter;
        // The R32F volume (the tiles' inner res² × slices) and the two Rg32F buffers.
        ctx.check_bytes(
            "resolution, slices",
            u64::from(tx * ty)
                * (u64::from(res).pow(2) * u64::from(slices) * 4 + u64::from(side).pow(2) * 16),
        )?;
        let lamp = tiles.lamp;
        let map = tiles.map;
        let spec = spec_of(ctx, &light, res, slices)?;
        let stencils: Vec<Stencil> = (0..slices).map(|k| stencil(&spec, k)).collect();
        let taps = stencils.iter().map(Vec::len).max().unwrap_or(1).max(1);
        if taps as u32 > ctx.gpu.limits.max_texture_dimension_2d {
            return Err(NodeError::Param {
                param: "sun_radius".into(),
                message: format!("the kernel needs {taps} taps per slice, more than the GPU allows: use more slices or a smaller d1"),
            });
        }
        let mut texels = vec![0.0f32; taps * slices as usize * 4];
        for (k, st) in stencils.iter().enumerate() {
            for (i, (dx, dy, w)) in st.iter().enumerate() {
                let o = (k * taps + i) * 4;
                texels[o..o + 3].copy_from_slice(&[*dx as f32, *dy as f32, *w as f32]);
            }
        }
        let stencil_tex = ctx.gpu.upload(taps as u32, slices, 4, &texels)?;
        let volume = ctx.gpu.volume([tx * res, ty * res, slices])?;
        let a = ctx.gpu.texture(tx * side, ty * side, TexFormat::Rg32F)?;
        let b = ctx.gpu.texture(tx * side, ty * side, TexFormat::Rg32F)?;
        let bias = p.bias;
        let shape = [p.ellipse_x, p.ellipse_y];
        let (linear, step_var) = match lamp {
            Some(l) => (
                true,
                spot_step_variance(&light, res, slices, p.light_radius, l.start as f64, shape),
            ),
            None => (
                p.growth == Growth::Linear,
                step_variance(&light, res, slices, p.sun_radius, shape),
            ),
        };
        let step_var = step_var.map(|v| v as f32);
        let l = lamp.unwrap_or(LampSlices {
            near: 0.0,
            far: 1.0,
            start: 0.0,
            tan_half: 0.0,
        });
        for k in 0..slices {
            let (prev, next) = if k % 2 == 0 { (&a, &b) } else { (&b, &a) };
            let u = SoftParams {
                res,
                slice: k,
                slices,
                taps: taps as u32,
                map_tile: [map.width / tx, map.height / ty],
                footprint: footprint(tiles.map_face, res),
                bias,
                step_var,
                linear: linear as u32,
                persp: lamp.is_some() as u32,
                near: l.near,
                far: l.far,
                start: l.start,
                gutter: tiles.gutter,
                tiles: tiles.count,
                map_gutter: tiles.map_gutter,
                tan_half: l.tan_half,
            };
            ctx.gpu.dispatch(
                SHADER,
                "propagate",
                &[
                    ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                    ("prev", Bind::Texture(prev)),
                    ("stencil", Bind::Texture(&stencil_tex)),
                    ("shadow", Bind::Texture(&map)),
                    ("next", Bind::Storage(next)),
                    ("volume", Bind::VolumeLevel(&volume, 0)),
                ],
                tx * side,
                ty * side,
            )?;
            if k % 16 == 15 {
                ctx.report(k as u64 + 1, slices as u64, "slices");
            }
        }
        // A lamp's volume carries its light with `near` = where its slices start, which is
        // what a lookup needs (q = 1 − near / w; the map's own near played no other part).
        let mut carried = light;
        if let (Some(c), Some(l)) = (carried.local.as_mut(), lamp) {
            c.near = l.start;
        }
        ctx.set("soft", PortValue::SoftShadow(Arc::new(volume), carried));
        Ok(())
    }
}
