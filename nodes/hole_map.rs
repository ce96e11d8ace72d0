//! `HoleMap`: where light bursts through — `H(t) = 1` (hole) where `N(t) < h`, else 0 (SPEC §4,
//! seed 000 eq. 4).
//!
//! With `calibrated` off, `h` is used as the threshold directly, so the hole fraction depends on
//! the noise's distribution (Perlin noise clusters around 0.5: h = 0.3 gives far fewer than 30 %
//! holes). With `calibrated` on, the threshold is the h-quantile of the input's values, so the
//! fraction of hole texels is h (up to ties): "hole probability" then means what it says. To
//! find the quantile the node reads its input back once (a one-channel map, sorted on the CPU);
//! the thresholding itself runs on the GPU.
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

use tyndall_engine::eval::{download, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
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
        /// Values below this are holes.
        pub threshold: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// The threshold giving a hole fraction of `h` on these values: with values sorted, the
/// ⌊h·n⌋-th smallest (so exactly ⌊h·n⌋ values lie below it when values are distinct); h = 0
/// gives −∞ (no holes), h = 1 gives +∞ (all holes).
pub fn calibrated_threshold(values: &[f32], h: f64) -> f32 {
    if h <= 0.0 || values.is_empty() {
        return f32::NEG_INFINITY;
    }
    if h >= 1.0 {
        return f32::INFINITY;
    }
    let mut v: Vec<f32> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f32::total_cmp);
    let k = ((h * v.len() as f64).floor() as usize).min(v.len() - 1);
    v[k]
}

/// CPU reference of the thresholding.
pub fn reference(noise: &Raster, threshold: f32) -> Raster {
    let mut out = noise.clone();
    for x in &mut out.data {
        *x = if *x < threshold { 1.0 } else { 0.0 };
    }
    out
}

impl NodeKind for HoleMap {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let input = ctx.require("noise")?.clone();
        let tex = ctx.require_texture("noise")?;
        let h = p.probability;
        let threshold = if p.calibrated {
            calibrated_threshold(&download(ctx.gpu, &input)?.data, h)
        } else {
            h as f32
        };
        // ±∞ thresholds as the largest finite values keep the uniform finite.
        let u = HoleParams {
            threshold: threshold.clamp(f32::MIN, f32::MAX),
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        };
        let out = ctx.gpu.texture(tex.width, tex.height, TexFormat::R32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "threshold",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("noise", Bind::Texture(&tex)),
                ("out_holes", Bind::Storage(&out)),
            ],
            tex.width,
            tex.height,
        )?;
        ctx.set("holes", PortValue::Scalar(Arc::new(out)));
        Ok(())
    }
}
