//! `Downsample`: reduce an image by an integer factor with point sampling, so that costly nodes
//! (`SingleScattering`) can march at reduced resolution and `DepthUpsample` bring the result
//! back (SPEC §6, seed 000 §5.2).
//!
//! Low-res texel q takes the input texel at `q·factor + ⌊factor/2⌋` (clamped): no averaging, so
//! a `Depth` keeps depths of real surfaces (an average across a silhouette would be a depth no
//! surface has) and its camera matrices (the rays through low-res pixel centres are those of the
//! same camera). Output size ⌈w/factor⌉ × ⌈h/factor⌉. For even factors the sampled texel sits half
//! an input texel from the low-res centre.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `in` | in | Depth \| Scalar \| Image (required) | |
//! | `out` | out | same type as `in` | |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `factor` | Int | 4 | 1…16 | reduction per axis |

use std::sync::Arc;

use crate::algorithms::point_sample;
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::TexFormat;
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};

/// The `Downsample` node kind.
pub struct Downsample;

const TYPES: &[PortType] = &[PortType::Depth, PortType::Scalar, PortType::Image];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        factor: i64 = ParamSpec::int("factor", 4, 1, 16, "×", "Reduction per axis."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Downsample",
    category: "Image",
    doc: "Reduce by an integer factor with point sampling (depths stay depths of real surfaces): march at reduced resolution, then DepthUpsample.",
    inputs: &[PortSpec::required("in", TYPES, "Depth, Scalar or Image to reduce.")],
    outputs: &[PortSpec::output("out", TYPES, "The reduced image, same type (a Depth keeps its camera).")],
    params: Params::SPECS,
})
.shaders(&[point_sample::SHADER])
.uniforms(&[point_sample::PointSampleParams::LAYOUT]);

impl NodeKind for Downsample {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let v = ctx.require("in")?.clone();
        let src = ctx.require_texture("in")?;
        if src.format == TexFormat::Rg32F {
            return Err(NodeError::Input {
                port: "in".into(),
                message: "has an internal two-channel format".into(),
            });
        }
        let out = Arc::new(point_sample::downsample(ctx.gpu, &src, p.factor as u32)?);
        ctx.set(
            "out",
            match v {
                PortValue::Depth(_, m) => PortValue::Depth(out, m),
                _ => super::util::image_like(out),
            },
        );
        Ok(())
    }
}
