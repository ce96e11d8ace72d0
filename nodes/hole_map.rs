//! `HoleMap`: where light bursts through — `H(t) = 1` (hole) where `N(t) < h`, else 0 (SPEC §4,
//! seed 000 eq. 4).
//!
//! With `calibrated` off, `h` is used as the threshold directly, so the hole fraction depends on
//! the noise's distribution (Perlin noise clusters around 0.5: h = 0.3 gives far fewer than 30 %
//! holes). With `calibrated` on, the threshold is the h-quantile of the input's values, so the
//! fraction of hole texels is h (up to ties): "hole probability" then means what it says. The
//! quantile is the k-th smallest finite value, k = ⌊h_q·n / 2³²⌋ with h_q = ⌊h·2³²⌋ (n finite
//! values; within one rank of ⌊h·n⌋), found on the GPU by radix select — four histogram passes
//! of 8 bits over order-preserving keys of the values' bits — so nothing is read back and the
//! threshold is the CPU reference's bit for bit.
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

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Gpu, GpuError, GpuTexture, Shader, TexFormat};
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
.shaders(&[SHADER])
.uniforms(&[HoleParams::LAYOUT]);

const SHADER: Shader = crate::shader("hole_map", include_str!("../shaders/hole_map.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/hole_map.wgsl` (struct `Params`).
    pub struct HoleParams as "Params" {
        /// Values below this are holes (the `threshold` pass).
        pub threshold: f32,
        /// h_q = ⌊h·2³²⌋: the rank selected is ⌊h_q·n / 2³²⌋.
        pub hq: u32,
        /// The digit of a `histogram` or `pick` pass: 24, 16, 8, 0.
        pub shift: u32,
        /// Padding.
        pub _pad0: u32,
    }
}

/// h as the 32-bit fraction h_q = ⌊h·2³²⌋ (0 < h < 1).
pub fn fraction_bits(h: f64) -> u32 {
    (h * 4_294_967_296.0).floor().clamp(0.0, u32::MAX as f64) as u32
}

/// The threshold giving a hole fraction of `h` on these values: of the n finite values sorted
/// (`f32::total_cmp`), the k-th smallest, k = ⌊h_q·n / 2³²⌋ ([`fraction_bits`]; so k values lie
/// below it when values are distinct); h = 0 or no finite value gives −∞ (no holes), h = 1
/// gives +∞ (all holes).
pub fn calibrated_threshold(values: &[f32], h: f64) -> f32 {
    if h >= 1.0 {
        return f32::INFINITY;
    }
    let mut v: Vec<f32> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if h <= 0.0 || v.is_empty() {
        return f32::NEG_INFINITY;
    }
    v.sort_by(f32::total_cmp);
    let k = ((fraction_bits(h) as u64 * v.len() as u64) >> 32) as usize;
    v[k.min(v.len() - 1)]
}

/// CPU reference of the thresholding.
pub fn reference(noise: &Raster, threshold: f32) -> Raster {
    let mut out = noise.clone();
    for x in &mut out.data {
        *x = if *x < threshold { 1.0 } else { 0.0 };
    }
    out
}

/// How the calibrated threshold's histograms count (same result, different cost).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Histogram {
    /// Every texel adds to the shared bins: for CPU drivers (2.3× faster than `Workgroup` on
    /// lavapipe, where workgroup memory and barriers cost more than the atomics they save).
    Shared,
    /// Each workgroup counts into its own bins first: for GPUs (a noise map's first digit takes
    /// a few bins per workgroup, so ~30× fewer atomics reach the shared bins).
    Workgroup,
}

impl Histogram {
    /// The form for `gpu`'s adapter.
    pub fn for_adapter(gpu: &Gpu) -> Self {
        if gpu.is_cpu() {
            Self::Shared
        } else {
            Self::Workgroup
        }
    }
}

/// The hole map of `noise` with parameters `p` on the GPU, the calibrated threshold selected
/// with histograms of the form `form`.
pub fn holes(
    gpu: &Gpu,
    noise: &GpuTexture,
    p: &Params,
    form: Histogram,
) -> Result<GpuTexture, GpuError> {
    let h = p.probability;
    let out = gpu.texture(noise.width, noise.height, TexFormat::R32F)?;
    let uniforms = |threshold: f32, shift: u32| HoleParams {
        // ±∞ thresholds as the largest finite values keep the uniform finite.
        threshold: threshold.clamp(f32::MIN, f32::MAX),
        hq: fraction_bits(h),
        shift,
        _pad0: 0,
    };
    let (w, ht) = (noise.width, noise.height);
    if !p.calibrated || h <= 0.0 || h >= 1.0 {
        let threshold = match (p.calibrated, h >= 1.0) {
            (false, _) => h as f32,
            (true, true) => f32::INFINITY,
            (true, false) => f32::NEG_INFINITY,
        };
        let u = uniforms(threshold, 0);
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
    // Radix select: 256 bins, then n, k and the prefix (see the shader).
    let sel = gpu.buffer_zeroed(259)?;
    let entry = match form {
        Histogram::Shared => "histogram",
        Histogram::Workgroup => "histogram_workgroup",
    };
    for shift in [24, 16, 8, 0] {
        let u = uniforms(0.0, shift);
        let binds = [
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("noise", Bind::Texture(noise)),
            ("sel", Bind::Buffer(&sel)),
        ];
        gpu.dispatch(SHADER, entry, &binds, w, ht)?;
        gpu.dispatch(SHADER, "pick", &[binds[0], binds[2]], 1, 1)?;
    }
    let u = uniforms(0.0, 0);
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
