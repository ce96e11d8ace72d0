//! `DepthUpsample`: joint bilateral upsampling of a low-resolution result guided by the
//! full-resolution depth (SPEC §6, seed 000 §5.2: march at ¼ resolution, upsample, edges stay
//! crisp).
//!
//! High-res pixel p takes the four low-res texels of its bilinear footprint (texel centres, edges
//! clamped), each weighted by its bilinear weight times `exp(−½((d_q − d_p)/(σ·d_p))²)` — d_p the
//! full-resolution depth at p, d_q the low-res depth at q, σ = `sigma_depth` relative to the
//! depth — normalised by the sum; where every weight vanishes (a surface none of the four saw,
//! e.g. a sliver thinner than the factor) it takes the texel of nearest depth among the 6×6
//! around the footprint. The low-res depth is the `low_depth` input, or the
//! full-res depth point-sampled as `Downsample` does. Any ratio of sizes works (factors 2, 4, 8,
//! 16 in the bench).
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `image` | in | Image \| Scalar (required) | the low-resolution result |
//! | `depth` | in | Depth (required) | full-resolution depth: the output size |
//! | `low_depth` | in | Depth | the depth `image` was computed with |
//! | `image` | out | same type as the input, at `depth`'s size | |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `sigma_depth` | Float | 0.05 | 0…10 | depth tolerance, relative to the depth |

use std::sync::Arc;

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

use crate::algorithms::point_sample;

/// The `DepthUpsample` node kind.
pub struct DepthUpsample;

const IMG: &[PortType] = &[PortType::Scalar, PortType::Image];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        sigma_depth: f32 = ParamSpec::float("sigma_depth", 0.05, 0.0, 10.0, "relative", "Depth tolerance as a fraction of the depth."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "DepthUpsample",
    category: "Image",
    doc: "Joint bilateral upsampling of a low-resolution result guided by full-resolution depth (march at reduced resolution, keep edges crisp).",
    inputs: &[
        PortSpec::required("image", IMG, "The low-resolution result."),
        PortSpec::required("depth", &[PortType::Depth], "Full-resolution depth; sets the output size."),
        PortSpec::input("low_depth", &[PortType::Depth], "The depth the low-resolution result was computed with (unconnected: `depth` point-sampled)."),
    ],
    outputs: &[PortSpec::output("image", IMG, "The upsampled result, same type, at the depth's size.")],
    params: Params::SPECS,
})
.shaders(&[SHADER, point_sample::SHADER])
.uniforms(&[UpsampleParams::LAYOUT, point_sample::PointSampleParams::LAYOUT]);

const SHADER: Shader = crate::shader(
    "depth_upsample",
    include_str!("../shaders/depth_upsample.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/depth_upsample.wgsl` (struct `Params`).
    pub struct UpsampleParams as "Params" {
        /// Relative depth tolerance.
        pub sigma_depth: f32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

/// CPU reference: `low` (with its depth `low_depth`) upsampled to `high_depth`'s size.
pub fn reference(low: &Raster, low_depth: &Raster, high_depth: &Raster, sigma: f32) -> Raster {
    let (hw, hh) = (high_depth.width, high_depth.height);
    let (lw, lh) = (low.width as i64, low.height as i64);
    let c = low.channels as usize;
    let mut out = Raster::new(hw, hh, low.channels, 0.0);
    for y in 0..hh {
        for x in 0..hw {
            let uv = [(x as f32 + 0.5) / hw as f32, (y as f32 + 0.5) / hh as f32];
            let q = [uv[0] * lw as f32 - 0.5, uv[1] * lh as f32 - 0.5];
            let f = [q[0] - q[0].floor(), q[1] - q[1].floor()];
            let base = [q[0].floor() as i64, q[1].floor() as i64];
            let dp = high_depth.data[(y * hw + x) as usize];
            let mut num = vec![0.0f32; c];
            let mut den = 0.0f32;
            for k in 0..4 {
                let o = [k & 1, k >> 1];
                let t = [
                    (base[0] + o[0]).clamp(0, lw - 1),
                    (base[1] + o[1]).clamp(0, lh - 1),
                ];
                let wb = (if o[0] == 1 { f[0] } else { 1.0 - f[0] })
                    * (if o[1] == 1 { f[1] } else { 1.0 - f[1] });
                let ti = (t[1] * lw + t[0]) as usize;
                let dq = low_depth.data[ti];
                let r = (dq - dp) / (sigma * dp.abs()).max(1e-6);
                let mut w = wb * (-0.5 * r * r).exp();
                if w.is_nan() {
                    w = 0.0;
                }
                for (i, n) in num.iter_mut().enumerate() {
                    *n += w * low.data[ti * c + i];
                }
                den += w;
            }
            let (mut best, mut gap) = (0usize, f32::MAX);
            if den <= 1e-8 {
                let first = [base[0].clamp(0, lw - 1), base[1].clamp(0, lh - 1)];
                best = (first[1] * lw + first[0]) as usize;
                for j in -2..=3 {
                    for i in -2..=3 {
                        let t = [
                            (base[0] + i).clamp(0, lw - 1),
                            (base[1] + j).clamp(0, lh - 1),
                        ];
                        let ti = (t[1] * lw + t[0]) as usize;
                        let g = (low_depth.data[ti] - dp).abs();
                        if g < gap {
                            gap = g;
                            best = ti;
                        }
                    }
                }
            }
            let o = (y * hw + x) as usize * c;
            for (i, n) in num.iter().enumerate() {
                out.data[o + i] = if den > 1e-8 {
                    n / den
                } else {
                    low.data[best * c + i]
                };
            }
        }
    }
    out
}

fn depth_of(
    ctx: &RunCtx,
    port: &str,
) -> Result<Option<Arc<tyndall_engine::gpu::GpuTexture>>, NodeError> {
    Ok(ctx.depth_opt(port)?.map(|(t, _)| t))
}

impl NodeKind for DepthUpsample {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let low = ctx.require_texture("image")?;
        if low.format == TexFormat::Rg32F {
            return Err(NodeError::Input {
                port: "image".into(),
                message: "has an internal two-channel format".into(),
            });
        }
        let high = depth_of(ctx, "depth")?.ok_or_else(|| NodeError::Input {
            port: "depth".into(),
            message: "must be connected".into(),
        })?;
        let low_depth = match depth_of(ctx, "low_depth")? {
            Some(t) => t,
            None => {
                let f = (high.width as f32 / low.width as f32).round().max(1.0) as u32;
                Arc::new(point_sample::downsample(ctx.gpu, &high, f)?)
            }
        };
        if (low_depth.width, low_depth.height) != (low.width, low.height) {
            return Err(NodeError::Input {
                port: "low_depth".into(),
                message: format!(
                    "is {}×{} but image is {}×{}",
                    low_depth.width, low_depth.height, low.width, low.height
                ),
            });
        }
        let u = UpsampleParams {
            sigma_depth: p.sigma_depth,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        };
        let out = ctx.gpu.texture(high.width, high.height, low.format)?;
        let (entry, slot) = if low.format == TexFormat::R32F {
            ("upsample_scalar", "out_scalar")
        } else {
            ("upsample_image", "out_image")
        };
        ctx.gpu.dispatch(
            SHADER,
            entry,
            &[
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("low", Bind::Texture(&low)),
                ("low_depth", Bind::Texture(&low_depth)),
                ("high_depth", Bind::Texture(&high)),
                (slot, Bind::Storage(&out)),
            ],
            high.width,
            high.height,
        )?;
        ctx.set("image", super::util::image_like(Arc::new(out)));
        Ok(())
    }
}
