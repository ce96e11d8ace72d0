//! `Blur`: separable Gaussian blur of a Scalar or Image (the medium comparisons' low-pass, and a
//! soft-glow look on in-scatter).
//!
//! `out(p) = Σ_{i,j = −r…r} w_i w_j · in(clamp(p + (i, j)))`, with
//! `w_i = e^{−i²/(2σ²)} / Σ_{k=−r…r} e^{−k²/(2σ²)}` and `r = ⌈truncate · σ⌉`: a horizontal pass
//! then a vertical one, texels beyond the border repeating the edge texel (so a constant image
//! stays constant and the weights sum to 1 everywhere). All four channels of an Image blur
//! (straight, not premultiplied, alpha). `sigma = 0` is the identity. Cost per texel is
//! 2(2r + 1) reads: `truncate` is the quality knob (3 keeps 99.7 % of the kernel's mass).
//!
//! | port | dir | type |
//! |---|---|---|
//! | `in` | in | Scalar \| Image (required) |
//! | `out` | out | same type and size as `in` |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `sigma` | Float | 2 | 0…256 texels | standard deviation σ in texels of `in`; 0 is the identity (a proxy evaluation divides it with the picture or map) |
//! | `truncate` | Float | 3 | 1…6 σ | kernel radius r = ⌈truncate · σ⌉ (quality knob) |

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, RunCtx};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `Blur` node kind.
pub struct Blur;

const IMG: &[PortType] = &[PortType::Scalar, PortType::Image];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        sigma: f64 = ParamSpec::float("sigma", 2.0, 0.0, 256.0, "texels", "Standard deviation σ of the Gaussian; 0 is the identity.").input_texels(),
        truncate: f64 = ParamSpec::float("truncate", 3.0, 1.0, 6.0, "σ", "Kernel radius r = ⌈truncate · σ⌉ texels: cost 2(2r + 1) reads per texel."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Blur",
    category: "Image",
    doc: "Separable Gaussian blur of a Scalar or Image (σ in texels, edges clamped); truncate is the quality knob.",
    inputs: &[PortSpec::required("in", IMG, "Values to blur.")],
    outputs: &[PortSpec::output("out", IMG, "Blurred values, same type and size as `in`.")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[BlurParams::LAYOUT]);

const SHADER: Shader = crate::shader("blur", include_str!("../shaders/blur.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/blur.wgsl` (struct `Params`).
    pub struct BlurParams as "Params" {
        /// Kernel radius r in texels.
        pub radius: i32,
        /// 0 horizontal pass, 1 vertical pass.
        pub axis: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

/// Kernel radius r = ⌈truncate · σ⌉ (0 for σ = 0).
pub fn radius(sigma: f64, truncate: f64) -> i32 {
    (truncate * sigma).ceil().clamp(0.0, 1e6) as i32
}

/// The normalised half-kernel `w_0 … w_r` (the kernel is symmetric), computed in f64 and
/// rounded once to f32; the GPU reads these same values.
pub fn weights(sigma: f64, r: i32) -> Vec<f32> {
    if r == 0 || sigma <= 0.0 {
        return vec![1.0];
    }
    let g: Vec<f64> = (0..=r)
        .map(|i| (-(i as f64).powi(2) / (2.0 * sigma * sigma)).exp())
        .collect();
    let total = g[0] + 2.0 * g[1..].iter().sum::<f64>();
    g.iter().map(|v| (v / total) as f32).collect()
}

/// One pass of the CPU reference along x (`axis = 0`) or y, in the shader's f32 order.
fn pass(input: &Raster, w: &[f32], axis: u32) -> Raster {
    let r = w.len() as i32 - 1;
    let (wd, ht, c) = (
        input.width as i32,
        input.height as i32,
        input.channels as usize,
    );
    let mut out = Raster::new(input.width, input.height, input.channels, 0.0);
    for y in 0..ht {
        for x in 0..wd {
            for ch in 0..c {
                let mut acc = 0.0f32;
                for i in -r..=r {
                    let (qx, qy) = if axis == 0 {
                        ((x + i).clamp(0, wd - 1), y)
                    } else {
                        (x, (y + i).clamp(0, ht - 1))
                    };
                    acc +=
                        w[i.unsigned_abs() as usize] * input.data[(qy * wd + qx) as usize * c + ch];
                }
                out.data[(y * wd + x) as usize * c + ch] = acc;
            }
        }
    }
    out
}

/// CPU reference of the node: the horizontal pass, then the vertical one.
pub fn reference(input: &Raster, sigma: f64, truncate: f64) -> Raster {
    let r = radius(sigma, truncate);
    if r == 0 {
        return input.clone();
    }
    let w = weights(sigma, r);
    pass(&pass(input, &w, 0), &w, 1)
}

fn gpu_pass(
    gpu: &Recorder,
    src: &GpuTexture,
    w: &GpuTexture,
    radius: i32,
    axis: u32,
) -> Result<GpuTexture, GpuError> {
    let u = BlurParams {
        radius,
        axis,
        _pad0: 0,
        _pad1: 0,
    };
    let (entry, slot) = match src.format {
        TexFormat::R32F => ("blur_scalar", "out_scalar"),
        _ => ("blur_image", "out_image"),
    };
    let out = gpu.texture(src.width, src.height, src.format)?;
    gpu.dispatch(
        SHADER,
        entry,
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(src)),
            ("weights", Bind::Texture(w)),
            (slot, Bind::Storage(&out)),
        ],
        src.width,
        src.height,
    )?;
    Ok(out)
}

impl NodeKind for Blur {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let value = ctx.require("in")?.clone();
        let tex = ctx.require_texture("in")?;
        if tex.format == TexFormat::Rg32F {
            return Err(NodeError::Input {
                port: "in".into(),
                message: "has an internal two-channel format".into(),
            });
        }
        let sigma = p.sigma;
        let r = radius(sigma, p.truncate);
        if r == 0 {
            ctx.set("out", value);
            return Ok(());
        }
        let w = weights(sigma, r);
        let wt = ctx.gpu.upload(w.len() as u32, 1, 1, &w)?;
        let rows = gpu_pass(ctx.gpu, &tex, &wt, r, 0)?;
        let out = gpu_pass(ctx.gpu, &rows, &wt, r, 1)?;
        ctx.set("out", super::util::image_like(Arc::new(out)));
        Ok(())
    }
}
