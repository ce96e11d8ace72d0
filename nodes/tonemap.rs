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

use bytemuck::{Pod, Zeroable};
use std::sync::Arc;

use crate::eval::{NodeError, NodeKind, PortValue, RunCtx};
use crate::gpu::{Bind, Shader, TexFormat, UniformLayout};
use crate::graph::{DefaultValue, NodeSchema, ParamKind, ParamSpec, PortSpec, PortType};

/// The `Tonemap` node kind.
pub struct Tonemap;

/// Tone curves, in the shader's order.
pub const OPERATORS: &[&str] = &["filmic", "reinhard", "linear"];

static SCHEMA: NodeSchema = NodeSchema {
    kind: "Tonemap",
    category: "Image",
    doc: "Exposure (stops) and a filmic (ACES fit), Reinhard or clamped linear tone curve.",
    inputs: &[PortSpec {
        name: "image",
        types: &[PortType::Image],
        required: true,
        doc: "Linear radiance.",
    }],
    outputs: &[PortSpec {
        name: "out",
        types: &[PortType::Image],
        required: false,
        doc: "Display-referred values in [0, 1].",
    }],
    params: &[
        ParamSpec {
            name: "exposure",
            kind: ParamKind::Float,
            default: DefaultValue::Float(0.0),
            min: -20.0,
            max: 20.0,
            unit: "stops",
            doc: "Multiplies the input by 2^exposure.",
        },
        ParamSpec {
            name: "operator",
            kind: ParamKind::Enum(OPERATORS),
            default: DefaultValue::Enum("filmic"),
            min: 0.0,
            max: 0.0,
            unit: "",
            doc: "Tone curve: filmic (ACES fit), reinhard, linear (clamp).",
        },
    ],
};

static SHADER: Shader = Shader {
    stem: "tonemap",
    source: include_str!("../shaders/tonemap.wgsl"),
};

/// Uniforms of `shaders/tonemap.wgsl` (struct `Params`).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct TonemapParams {
    /// 2^exposure.
    pub scale: f32,
    /// Index into [`OPERATORS`].
    pub op: u32,
    /// Padding.
    pub _pad0: u32,
    /// Padding.
    pub _pad1: u32,
}

/// CPU reference for one channel value.
pub fn curve(op: &str, x: f32) -> f32 {
    // Clamp first: beyond 65504 every curve is at its ceiling, and x² must not overflow.
    let x = x.clamp(0.0, 65504.0);
    match op {
        "filmic" => ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0),
        "reinhard" => x / (1.0 + x),
        _ => x.min(1.0),
    }
}

impl NodeKind for Tonemap {
    fn schema(&self) -> &'static NodeSchema {
        &SCHEMA
    }

    fn shader(&self) -> Option<Shader> {
        Some(SHADER)
    }

    fn uniform_layouts(&self) -> Vec<UniformLayout> {
        vec![crate::uniform_layout!(
            TonemapParams,
            "Params",
            scale,
            op,
            _pad0,
            _pad1
        )]
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let tex = ctx.require_texture("image")?;
        let op = ctx.text("operator")?;
        let u = TonemapParams {
            scale: 2f32.powf(ctx.f32("exposure")?),
            op: OPERATORS.iter().position(|o| *o == op).unwrap_or(0) as u32,
            _pad0: 0,
            _pad1: 0,
        };
        let out = ctx.gpu.texture(tex.width, tex.height, TexFormat::Rgba32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "tonemap",
            &[
                (0, Bind::Uniform(bytemuck::bytes_of(&u))),
                (1, Bind::Texture(&tex)),
                (2, Bind::Storage(&out)),
            ],
            tex.width,
            tex.height,
        )?;
        ctx.set("out", PortValue::Image(Arc::new(out)));
        Ok(())
    }
}
