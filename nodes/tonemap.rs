//! `Tonemap`: exposure then a tone curve, from linear radiance to display-referred [0, 1].
//!
//! `x = in · 2^exposure`, then per RGB channel: `filmic` — the ACES fit of Narkowicz (2015),
//! `x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)` clamped to [0, 1]; `reinhard` — `x / (1 + x)`;
//! `linear` — `x` clamped to [0, 1]. Inputs are first clamped to [0, 65504] (negative → 0, huge
//! or infinite → the curve's ceiling, never NaN); alpha is kept.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `image` | in | Image (required) |
//! | `out` | out | Image |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `exposure` | Float | 0 | −20…20 stops | multiplies by 2^exposure |
//! | `operator` | Enum | filmic | filmic, reinhard, linear | tone curve |

use std::sync::Arc;

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};

/// The `Tonemap` node kind.
pub struct Tonemap;

tyndall_engine::choice_enum! {
    /// Tone curves, in the shader's order.
    pub enum Operator { Filmic = "filmic", Reinhard = "reinhard", Linear = "linear" }
}

/// Tone curve names (`Operator::NAMES`).
pub const OPERATORS: &[&str] = Operator::NAMES;

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        exposure: f32 = ParamSpec::float("exposure", 0.0, -20.0, 20.0, "stops", "Multiplies the input by 2^exposure."),
        operator: Operator = ParamSpec::choice("operator", Operator::NAMES, "filmic", "Tone curve: filmic (ACES fit), reinhard, linear (clamp)."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Tonemap",
    category: "Image",
    doc: "Exposure (stops) and a filmic (ACES fit), Reinhard or clamped linear tone curve.",
    inputs: &[PortSpec::required("image", &[PortType::Image], "Linear radiance.")],
    outputs: &[PortSpec::output("out", &[PortType::Image], "Display-referred values in [0, 1].")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[TonemapParams::LAYOUT]);

const SHADER: Shader = crate::shader("tonemap", include_str!("../shaders/tonemap.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/tonemap.wgsl` (struct `Params`).
    pub struct TonemapParams as "Params" {
        /// 2^exposure.
        pub scale: f32,
        /// [`Operator`] code.
        pub op: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

/// CPU reference for one channel value.
pub fn curve(op: Operator, x: f32) -> f32 {
    // Clamp first: beyond 65504 every curve is at its ceiling, and x² must not overflow.
    let x = x.clamp(0.0, 65504.0);
    match op {
        Operator::Filmic => {
            ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
        }
        Operator::Reinhard => x / (1.0 + x),
        Operator::Linear => x.min(1.0),
    }
}

impl NodeKind for Tonemap {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let tex = ctx.require_texture("image")?;
        let u = TonemapParams {
            scale: 2f32.powf(p.exposure),
            op: p.operator as u32,
            _pad0: 0,
            _pad1: 0,
        };
        let out = ctx.gpu.texture(tex.width, tex.height, TexFormat::Rgba32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "tonemap",
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("src", Bind::Texture(&tex)),
                ("out_image", Bind::Storage(&out)),
            ],
            tex.width,
            tex.height,
        )?;
        ctx.set("out", PortValue::Image(Arc::new(out)));
        Ok(())
    }
}
