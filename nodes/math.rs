//! `Math`: element-wise arithmetic on Scalar or Image inputs.
//!
//! `out = op(a, b)` per texel and channel, with `a`/`b` read from the connected inputs or, when
//! an input is unconnected, from the parameters of the same name. The output is an Image when
//! either input is an Image (a Scalar then broadcasts to all four channels), else a Scalar.
//! Inputs of different sizes are refused unless one is 1×1 (it broadcasts).
//!
//! | op | result |
//! |---|---|
//! | `add`, `sub`, `mul` | a + b, a − b, a · b |
//! | `div` | a / b, and 0 where b = 0 (safe division: never Inf/NaN from a zero divisor) |
//! | `min`, `max` | min(a, b), max(a, b) |
//! | `mix` | a + (b − a) · `factor` |
//! | `clamp` | min(max(a, `lo`), `hi`) (b unused) |
//! | `pow` | sign(a) · \|a\|^b; 0^b = 1 for b = 0, else 0 (no NaN for negative a or 0^−b) |
//!
//! | port | dir | type |
//! |---|---|---|
//! | `a`, `b` | in | Scalar \| Image (optional) |
//! | `out` | out | Scalar \| Image |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `op` | Enum | add | see above | the operation |
//! | `a`, `b` | Float | 0 | ±1e30 | operand values used when the input is unconnected |
//! | `factor` | Float | 0.5 | −1e6…1e6 | `mix` weight of b |
//! | `lo`, `hi` | Float | 0, 1 | ±1e30 | `clamp` bounds |

use std::sync::Arc;

use super::util::{image_like, placeholder};
use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `Math` node kind.
pub struct Math;

tyndall_engine::choice_enum! {
    /// Operations, in the order of the shader's `op` codes.
    pub enum Op {
        Add = "add", Sub = "sub", Mul = "mul", Div = "div", Min = "min", Max = "max",
        Mix = "mix", Clamp = "clamp", Pow = "pow",
    }
}

/// Operation names (`Op::NAMES`).
pub const OPS: &[&str] = Op::NAMES;

const IMG: &[PortType] = &[PortType::Scalar, PortType::Image];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        op: Op = ParamSpec::choice("op", Op::NAMES, "add", "Operation: add, sub, mul, div (0 where b = 0), min, max, mix, clamp, pow (signed, no NaN)."),
        a: f32 = ParamSpec::float("a", 0.0, -1e30, 1e30, "", "Value of a when input a is unconnected."),
        b: f32 = ParamSpec::float("b", 0.0, -1e30, 1e30, "", "Value of b when input b is unconnected."),
        factor: f32 = ParamSpec::float("factor", 0.5, -1e6, 1e6, "", "Weight of b for mix (0 = a, 1 = b)."),
        lo: f32 = ParamSpec::float("lo", 0.0, -1e30, 1e30, "", "Lower bound for clamp."),
        hi: f32 = ParamSpec::float("hi", 1.0, -1e30, 1e30, "", "Upper bound for clamp (wins when lo > hi)."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Math",
    category: "Image",
    doc: "Element-wise add, sub, mul, safe div, min, max, mix, clamp or pow of two Scalar/Image inputs or constants.",
    inputs: &[
        PortSpec::input("a", IMG, "First operand (the `a` parameter when unconnected)."),
        PortSpec::input("b", IMG, "Second operand (the `b` parameter when unconnected)."),
    ],
    outputs: &[PortSpec::output("out", IMG, "Image if either input is an Image, else Scalar.")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[MathParams::LAYOUT]);

const SHADER: Shader = crate::shader("math", include_str!("../shaders/math.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/math.wgsl` (struct `Params`). Modes: 0 constant, 1 Scalar texture
    /// (broadcast), 2 Image texture.
    pub struct MathParams as "Params" {
        /// [`Op`] code.
        pub op: u32,
        /// How a is read.
        pub a_mode: u32,
        /// How b is read.
        pub b_mode: u32,
        /// Padding.
        pub _pad0: u32,
        /// Constant a.
        pub a_const: f32,
        /// Constant b.
        pub b_const: f32,
        /// Mix weight.
        pub factor: f32,
        /// Clamp low.
        pub lo: f32,
        /// Clamp high.
        pub hi: f32,
        /// Padding.
        pub _pad1: f32,
        /// Padding.
        pub _pad2: f32,
        /// Padding.
        pub _pad3: f32,
    }
}

/// CPU reference of one operation on one channel value (f32, same formulas as the shader).
pub fn apply(op: Op, a: f32, b: f32, factor: f32, lo: f32, hi: f32) -> f32 {
    match op {
        Op::Add => a + b,
        Op::Sub => a - b,
        Op::Mul => a * b,
        Op::Div => {
            if b == 0.0 {
                0.0
            } else {
                a / b
            }
        }
        Op::Min => a.min(b),
        Op::Max => a.max(b),
        Op::Mix => a + (b - a) * factor,
        Op::Clamp => a.max(lo).min(hi),
        Op::Pow => {
            let m = a.abs();
            if m == 0.0 {
                if b == 0.0 {
                    1.0
                } else {
                    0.0
                }
            } else {
                a.signum() * m.powf(b)
            }
        }
    }
}

/// An operand for the CPU reference: a raster or a constant.
pub enum Operand<'a> {
    /// A constant value.
    Const(f32),
    /// A raster (1 channel broadcasts; 1×1 broadcasts over the other operand's size).
    Raster(&'a Raster),
}

/// CPU reference of the whole node. `None` when neither operand is a raster or the sizes clash.
pub fn reference(op: Op, a: Operand, b: Operand, factor: f32, lo: f32, hi: f32) -> Option<Raster> {
    let size = |o: &Operand| match o {
        Operand::Raster(r) => Some((r.width, r.height, r.channels)),
        Operand::Const(_) => None,
    };
    let (sa, sb) = (size(&a), size(&b));
    let (w, h) = match (sa, sb) {
        (Some((wa, ha, _)), Some((wb, hb, _))) if (wa, ha) == (wb, hb) || (wb, hb) == (1, 1) => {
            (wa, ha)
        }
        (Some((1, 1, _)), Some((wb, hb, _))) => (wb, hb),
        (Some(_), Some(_)) => return None,
        (Some((w, h, _)), None) | (None, Some((w, h, _))) => (w, h),
        (None, None) => return None,
    };
    let channels = if sa.map(|s| s.2) == Some(4) || sb.map(|s| s.2) == Some(4) {
        4
    } else {
        1
    };
    let read = |o: &Operand, x: u32, y: u32, c: usize| -> f32 {
        match o {
            Operand::Const(v) => *v,
            Operand::Raster(r) => {
                let p = r.pixel(x.min(r.width - 1), y.min(r.height - 1));
                if r.channels == 1 {
                    p[0]
                } else {
                    p[c]
                }
            }
        }
    };
    let mut out = Raster::new(w, h, channels, 0.0);
    for y in 0..h {
        for x in 0..w {
            for c in 0..channels as usize {
                let i = (y as usize * w as usize + x as usize) * channels as usize + c;
                out.data[i] = apply(op, read(&a, x, y, c), read(&b, x, y, c), factor, lo, hi);
            }
        }
    }
    Some(out)
}

fn operand<'a>(ctx: &'a RunCtx, port: &str) -> (u32, Option<&'a Arc<GpuTexture>>) {
    match ctx.input(port) {
        Some(PortValue::Image(t)) => (2, Some(t)),
        Some(v) => (1, v.texture()),
        None => (0, None),
    }
}

impl NodeKind for Math {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let op_code = p.op as u32;
        let (a_mode, ta) = operand(ctx, "a");
        let (b_mode, tb) = operand(ctx, "b");
        let (w, h) = match (ta, tb) {
            (Some(a), Some(b)) => {
                if (a.width, a.height) == (b.width, b.height) || (b.width, b.height) == (1, 1) {
                    (a.width, a.height)
                } else if (a.width, a.height) == (1, 1) {
                    (b.width, b.height)
                } else {
                    return Err(NodeError::Input {
                        port: "b".into(),
                        message: format!(
                            "size {}x{} differs from input a's {}x{} (only 1×1 broadcasts)",
                            b.width, b.height, a.width, a.height
                        ),
                    });
                }
            }
            (Some(t), None) | (None, Some(t)) => (t.width, t.height),
            (None, None) => {
                return Err(NodeError::Input {
                    port: "a".into(),
                    message: "connect a or b: Math needs at least one image input".into(),
                })
            }
        };
        let u = MathParams {
            op: op_code,
            a_mode,
            b_mode,
            _pad0: 0,
            a_const: p.a,
            b_const: p.b,
            factor: p.factor,
            lo: p.lo,
            hi: p.hi,
            _pad1: 0.0,
            _pad2: 0.0,
            _pad3: 0.0,
        };
        let dummy = placeholder(ctx)?;
        let ta = ta.cloned().unwrap_or_else(|| dummy.clone());
        let tb = tb.cloned().unwrap_or(dummy);
        let image = a_mode == 2 || b_mode == 2;
        let (format, entry, slot) = if image {
            (TexFormat::Rgba32F, "math_image", "out_image")
        } else {
            (TexFormat::R32F, "math_scalar", "out_scalar")
        };
        let out = ctx.gpu.texture(w, h, format)?;
        ctx.gpu.dispatch(
            SHADER,
            entry,
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("tex_a", Bind::Texture(&ta)),
                ("tex_b", Bind::Texture(&tb)),
                (slot, Bind::Storage(&out)),
            ],
            w,
            h,
        )?;
        ctx.set("out", image_like(Arc::new(out)));
        Ok(())
    }
}
