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

use crate::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use crate::gpu::{Bind, Gpu, GpuError, GpuTexture, Shader, TexFormat};
use crate::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use crate::io::Raster;

/// The `Downsample` node kind.
pub struct Downsample;

const TYPES: &[PortType] = &[PortType::Depth, PortType::Scalar, PortType::Image];

#[rustfmt::skip]
crate::params! {
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
.shaders(&[SHADER])
.uniforms(&[DownsampleParams::LAYOUT]);

const SHADER: Shader = Shader::new("downsample", include_str!("../shaders/downsample.wgsl"));

crate::uniforms! {
    /// Uniforms of `shaders/downsample.wgsl` (struct `Params`).
    pub struct DownsampleParams as "Params" {
        /// Reduction per axis.
        pub factor: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// CPU reference.
pub fn reference(src: &Raster, factor: u32) -> Raster {
    let (w, h) = (src.width.div_ceil(factor), src.height.div_ceil(factor));
    let c = src.channels as usize;
    let mut out = Raster::new(w, h, src.channels, 0.0);
    for y in 0..h {
        for x in 0..w {
            let sx = (x * factor + factor / 2).min(src.width - 1);
            let sy = (y * factor + factor / 2).min(src.height - 1);
            let s = (sy * src.width + sx) as usize * c;
            let d = (y * w + x) as usize * c;
            out.data[d..d + c].copy_from_slice(&src.data[s..s + c]);
        }
    }
    out
}

/// Point-sample `src` on the GPU.
pub fn downsample(gpu: &Gpu, src: &GpuTexture, factor: u32) -> Result<GpuTexture, GpuError> {
    let (w, h) = (src.width.div_ceil(factor), src.height.div_ceil(factor));
    let out = gpu.texture(w, h, src.format)?;
    let u = DownsampleParams {
        factor,
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
    };
    let (entry, slot) = if src.format == TexFormat::R32F {
        ("downsample_scalar", 2)
    } else {
        ("downsample_image", 3)
    };
    gpu.dispatch(
        SHADER,
        entry,
        &[
            (0, Bind::Uniform(bytemuck::bytes_of(&u))),
            (1, Bind::Texture(src)),
            (slot, Bind::Storage(&out)),
        ],
        w,
        h,
    )?;
    Ok(out)
}

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
        let out = Arc::new(downsample(ctx.gpu, &src, p.factor as u32)?);
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
