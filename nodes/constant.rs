//! `Constant`: a flat one-channel image (`value`) and a flat RGBA image (`colour`).
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `value` | out | Scalar | every texel = `value` |
//! | `colour` | out | Image | every texel = `colour` |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `value` | Float | 0 | ±1e30 | the Scalar output's value |
//! | `colour` | Colour | (1,1,1,1) | ±1e30 | the Image output's colour (linear) |
//! | `width`, `height` | Int | 0 | 0…16384 texels | size; 0 = the evaluation size (`--size`) |
//!
//! Only the outputs some consumer needs are computed.

use std::sync::Arc;

use super::util::size_or_default;
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `Constant` node kind.
pub struct Constant;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        value: f32 = ParamSpec::float("value", 0.0, -1e30, 1e30, "", "Value of the Scalar output."),
        colour: [f32; 4] = ParamSpec::colour("colour", [1.0, 1.0, 1.0, 1.0], -1e30, 1e30, "linear RGBA", "Colour of the Image output."),
        width: i64 = ParamSpec::int("width", 0, 0, 16384, "texels", "Width; 0 uses the evaluation size."),
        height: i64 = ParamSpec::int("height", 0, 0, 16384, "texels", "Height; 0 uses the evaluation size."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Constant",
    category: "Input",
    doc: "A flat Scalar value and a flat RGBA colour, at a given size or the evaluation size.",
    inputs: &[],
    outputs: &[
        PortSpec::output("value", &[PortType::Scalar], "Every texel equals `value`."),
        PortSpec::output("colour", &[PortType::Image], "Every texel equals `colour`."),
    ],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[ConstantParams::LAYOUT]);

const SHADER: Shader = crate::shader("constant", include_str!("../shaders/constant.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/constant.wgsl` (struct `Params`).
    pub struct ConstantParams as "Params" {
        /// Colour of the Image output.
        pub colour: [f32; 4],
        /// Value of the Scalar output.
        pub value: f32,
        /// Padding.
        pub _pad0: f32,
        /// Padding.
        pub _pad1: f32,
        /// Padding.
        pub _pad2: f32,
    }
}

/// CPU reference: the `value` raster (one channel) and the `colour` raster (RGBA).
pub fn reference(width: u32, height: u32, value: f32, colour: [f32; 4]) -> (Raster, Raster) {
    let v = Raster::new(width, height, 1, value);
    let mut c = Raster::new(width, height, 4, 0.0);
    for px in c.data.chunks_mut(4) {
        px.copy_from_slice(&colour);
    }
    (v, c)
}

impl NodeKind for Constant {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let (w, h) = size_or_default(ctx, p.width, p.height);
        let u = ConstantParams {
            colour: p.colour,
            value: p.value,
            _pad0: 0.0,
            _pad1: 0.0,
            _pad2: 0.0,
        };
        if ctx.wants("value") {
            let out = ctx.gpu.texture(w, h, TexFormat::R32F)?;
            ctx.gpu.dispatch(
                SHADER,
                "fill_scalar",
                &[
                    ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                    ("out_scalar", Bind::Storage(&out)),
                ],
                w,
                h,
            )?;
            ctx.set("value", PortValue::Scalar(Arc::new(out)));
        }
        if ctx.wants("colour") {
            let out = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
            ctx.gpu.dispatch(
                SHADER,
                "fill_image",
                &[
                    ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                    ("out_image", Bind::Storage(&out)),
                ],
                w,
                h,
            )?;
            ctx.set("colour", PortValue::Image(Arc::new(out)));
        }
        Ok(())
    }
}
