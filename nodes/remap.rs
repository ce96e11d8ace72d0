//! `Remap`: linear map of values from one range to another, optionally clamped.
//!
//! `out = to_min + (x − from_min) · (to_max − to_min) / (from_max − from_min)`; with a zero-width
//! source range (`from_min = from_max`) the map is a step: `to_min` below `from_min`, `to_max`
//! at or above it (never a division by zero). With `clamp`, the result is clamped to the target
//! range (either order). Images remap R, G, B and keep alpha.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `in` | in | Scalar \| Image (required) |
//! | `out` | out | same as `in` |
//!
//! | param | type | default | range |
//! |---|---|---|---|
//! | `from_min`, `from_max` | Float | 0, 1 | ±1e30 |
//! | `to_min`, `to_max` | Float | 0, 1 | ±1e30 |
//! | `clamp` | Bool | false | |

use std::sync::Arc;

use super::util::image_like;
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `Remap` node kind.
pub struct Remap;

const IMG: &[PortType] = &[PortType::Scalar, PortType::Image];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        from_min: f32 = ParamSpec::float("from_min", 0.0, -1e30, 1e30, "", "Source value mapped to to_min."),
        from_max: f32 = ParamSpec::float("from_max", 1.0, -1e30, 1e30, "", "Source value mapped to to_max (equal to from_min: a step)."),
        to_min: f32 = ParamSpec::float("to_min", 0.0, -1e30, 1e30, "", "Target of from_min."),
        to_max: f32 = ParamSpec::float("to_max", 1.0, -1e30, 1e30, "", "Target of from_max."),
        clamp: bool = ParamSpec::flag("clamp", false, "Clamp the result to the target range."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Remap",
    category: "Image",
    doc: "Linearly maps values from [from_min, from_max] to [to_min, to_max], optionally clamped; alpha is kept.",
    inputs: &[PortSpec::required("in", IMG, "Values to remap.")],
    outputs: &[PortSpec::output("out", IMG, "Remapped values, same type and size as `in`.")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[RemapParams::LAYOUT]);

const SHADER: Shader = crate::shader("remap", include_str!("../shaders/remap.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/remap.wgsl` (struct `Params`).
    pub struct RemapParams as "Params" {
        /// Source low.
        pub from_min: f32,
        /// Source high.
        pub from_max: f32,
        /// Target low.
        pub to_min: f32,
        /// Target high.
        pub to_max: f32,
        /// 1 to clamp.
        pub clamp: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// CPU reference for one value (same f32 formula as the shader).
pub fn remap_value(x: f32, p: &RemapParams) -> f32 {
    let span = p.from_max - p.from_min;
    let mut y = if span == 0.0 {
        if x < p.from_min {
            p.to_min
        } else {
            p.to_max
        }
    } else {
        p.to_min + (x - p.from_min) * ((p.to_max - p.to_min) / span)
    };
    if p.clamp != 0 {
        y = y.max(p.to_min.min(p.to_max)).min(p.to_min.max(p.to_max));
    }
    y
}

/// CPU reference of the node (RGB remapped, alpha kept for four-channel rasters).
pub fn reference(input: &Raster, p: &RemapParams) -> Raster {
    let mut out = input.clone();
    let c = input.channels as usize;
    for (i, v) in out.data.iter_mut().enumerate() {
        if c == 1 || i % c != 3 {
            *v = remap_value(*v, p);
        }
    }
    out
}

impl NodeKind for Remap {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let tex = ctx.require_texture("in")?;
        let u = RemapParams {
            from_min: p.from_min,
            from_max: p.from_max,
            to_min: p.to_min,
            to_max: p.to_max,
            clamp: p.clamp as u32,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        };
        let (entry, slot) = match tex.format {
            TexFormat::R32F => ("remap_scalar", "out_scalar"),
            TexFormat::Rgba32F => ("remap_image", "out_image"),
            TexFormat::Rg32F => {
                return Err(NodeError::Input {
                    port: "in".into(),
                    message: "has an internal two-channel format".into(),
                })
            }
        };
        let out = ctx.gpu.texture(tex.width, tex.height, tex.format)?;
        ctx.gpu.dispatch(
            SHADER,
            entry,
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("src", Bind::Texture(&tex)),
                (slot, Bind::Storage(&out)),
            ],
            tex.width,
            tex.height,
        )?;
        ctx.set("out", image_like(Arc::new(out)));
        Ok(())
    }
}
