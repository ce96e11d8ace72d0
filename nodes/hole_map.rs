//! `HoleMap`: where light bursts through — `H(t) = 1` (hole) where `N(t) < h`, else 0 (SPEC §4,
//! seed 000 eq. 4).
//!
//! With `calibrated` off, `h` is used as the threshold directly, so the hole fraction depends on
//! the noise's distribution (Perlin noise clusters around 0.5: h = 0.3 gives far fewer than 30 %
//! holes). With `calibrated` on, the threshold is the h-quantile of the input's values, so the
//! fraction of hole texels is h (up to ties): "hole probability" then means what it says. The
//! quantile is the k-th smallest finite value, k = ⌊h_b·n / 2³²⌋ with h_b = ⌊h·2³²⌋ (n finite
//! values; within one rank of ⌊h·n⌋), selected on the GPU (`algorithms::quantile`, radix
//! select) and kept there for the threshold pass: nothing is read back, and the threshold is the
//! CPU reference's bit for bit.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `noise` | in | Scalar (required) |
//! | `holes` | out | Scalar (1 = hole, 0 = keep) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `probability` | Float | 0.3 | 0…1 | h |
//! | `calibrated` | Bool | true | | h is the hole fraction (threshold = h-quantile of the input) |

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use crate::algorithms::quantile::{self, Histogram, Rank};
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `HoleMap` node kind.
pub struct HoleMap;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        probability: f64 = ParamSpec::float("probability", 0.3, 0.0, 1.0, "", "Hole probability h."),
        calibrated: bool = ParamSpec::flag("calibrated", true, "Make the fraction of hole texels equal h (threshold at the h-quantile)."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "HoleMap",
    category: "Occluders",
    doc: "Holes where noise < h; calibrated: h is the fraction of hole texels.",
    inputs: &[PortSpec::required("noise", &[PortType::Scalar], "Noise in [0, 1] (PerlinNoise2D).")],
    outputs: &[PortSpec::output("holes", &[PortType::Scalar], "1 where a hole is punched, else 0.")],
    params: Params::SPECS,
})
.shaders(&[SHADER, quantile::SHADER])
.uniforms(&[HoleParams::LAYOUT, quantile::QuantileParams::LAYOUT]);

const SHADER: Shader = crate::shader("hole_map", include_str!("../shaders/hole_map.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/hole_map.wgsl` (struct `Params`).
    pub struct HoleParams as "Params" {
        /// Values below this are holes (the `threshold` pass).
        pub threshold: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// The threshold giving a hole fraction of `h` on these values: of the n finite values sorted
/// (`f32::total_cmp`), the one at rank ⌊h_b·n / 2³²⌋ (`quantile::rank_of`, `Rank::Floor`; so
/// that many values lie below it when values are distinct); h = 0 or no finite value gives −∞
/// (no holes), h = 1 gives +∞ (all holes).
pub fn calibrated_threshold(values: &[f32], h: f64) -> f32 {
    if h >= 1.0 {
        return f32::INFINITY;
    }
    if h <= 0.0 {
        return f32::NEG_INFINITY;
    }
    quantile::reference(values, h, Rank::Floor, None).unwrap_or(f32::NEG_INFINITY)
}

/// CPU reference of the thresholding.
pub fn reference(noise: &Raster, threshold: f32) -> Raster {
    let mut out = noise.clone();
    for x in &mut out.data {
        *x = if *x < threshold { 1.0 } else { 0.0 };
    }
    out
}

/// The hole map of `noise` with parameters `p` on the GPU, the calibrated threshold selected
/// with histograms of the form `form`.
pub fn holes(
    gpu: &Recorder,
    noise: &GpuTexture,
    p: &Params,
    form: Histogram,
) -> Result<GpuTexture, GpuError> {
    let h = p.probability;
    let out = gpu.texture(noise.width, noise.height, TexFormat::R32F)?;
    let uniforms = |threshold: f32| HoleParams {
        // ±∞ thresholds as the largest finite values keep the uniform finite.
        threshold: threshold.clamp(f32::MIN, f32::MAX),
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
    };
    let (w, ht) = (noise.width, noise.height);
    if !p.calibrated || h <= 0.0 || h >= 1.0 {
        let threshold = match (p.calibrated, h >= 1.0) {
            (false, _) => h as f32,
            (true, true) => f32::INFINITY,
            (true, false) => f32::NEG_INFINITY,
        };
        let u = uniforms(threshold);
        gpu.dispatch(
            SHADER,
            "threshold",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("noise", Bind::Texture(noise)),
                ("out_holes", Bind::Storage(&out)),
            ],
            w,
            ht,
        )?;
        return Ok(out);
    }
    // The h-quantile's key stays on the GPU, in `sel`, for the threshold pass.
    let sel = quantile::select(gpu, noise, h, Rank::Floor, None, form)?;
    let u = uniforms(0.0);
    gpu.dispatch(
        SHADER,
        "threshold_selected",
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("noise", Bind::Texture(noise)),
            ("out_holes", Bind::Storage(&out)),
            ("sel", Bind::Buffer(&sel)),
        ],
        w,
        ht,
    )?;
    Ok(out)
}

impl NodeKind for HoleMap {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let tex = ctx.require_texture("noise")?;
        let out = holes(ctx.gpu, &tex, &p, Histogram::for_adapter(ctx.gpu))?;
        ctx.set("holes", PortValue::Scalar(Arc::new(out)));
        Ok(())
    }
}
