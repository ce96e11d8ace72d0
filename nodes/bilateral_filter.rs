//! `BilateralFilter`: the separable bilateral filter of seed 003 §3.3 — smooths sparse marching
//! noise while keeping edges where the guide (depth) jumps.
//!
//! Pass 1 along rows, then pass 2 along the columns of pass 1's result, both with weights
//! `w(j) = exp(−j²/(2σs²)) · exp(−(g(p + j) − g(p))²/(2σr²))`, j = −radius…radius, taps outside
//! the image skipped, normalised by Σw. g is the `guide` (unchanged between passes) or, when it
//! is unconnected, the luminance (0.2126, 0.7152, 0.0722) of that pass's own input (a Scalar's
//! value). All four channels of an Image are filtered. σ = 0 is the Gaussian's limit: only the
//! centre tap (σs) or only taps with an equal guide value (σr) count; a huge σr gives a plain
//! separable Gaussian. Cost per texel is 2(2·radius + 1) taps: `radius` is the quality knob.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `image` | in | Image \| Scalar (required) | what to filter |
//! | `guide` | in | Depth \| Scalar | edges to keep (same size as `image`) |
//! | `image` | out | same type as the input | |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `radius` | Int | 4 | 0…64 taps | taps on each side |
//! | `sigma_spatial` | Float | 2 | 0…256 px | spatial σs |
//! | `sigma_range` | Float | 0.5 | 0…1e9 guide units | range σr (metres for a depth guide) |

use std::sync::Arc;
use tyndall_engine::gpu::Recorder;

use tyndall_engine::eval::{NodeDecl, NodeError, NodeKind, RunCtx};
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `BilateralFilter` node kind.
pub struct BilateralFilter;

const IMG: &[PortType] = &[PortType::Scalar, PortType::Image];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        radius: i64 = ParamSpec::int("radius", 4, 0, 64, "taps", "Taps on each side of a pixel, in each pass (quality knob)."),
        sigma_spatial: f32 = ParamSpec::float("sigma_spatial", 2.0, 0.0, 256.0, "px", "Spatial standard deviation σs."),
        sigma_range: f32 = ParamSpec::float("sigma_range", 0.5, 0.0, 1e9, "guide units", "Range standard deviation σr (metres for a depth guide)."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "BilateralFilter",
    category: "Image",
    doc: "Separable bilateral filter (rows, then columns) guided by depth or by the image's luminance: smooths marching noise, keeps edges.",
    inputs: &[
        PortSpec::required("image", IMG, "What to filter."),
        PortSpec::input("guide", &[PortType::Depth, PortType::Scalar], "Edges to keep (same size); unconnected: the luminance of each pass's input."),
    ],
    outputs: &[PortSpec::output("image", IMG, "The filtered image, same type as the input.")],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[BilateralParams::LAYOUT]);

const SHADER: Shader = crate::shader(
    "bilateral_filter",
    include_str!("../shaders/bilateral_filter.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/bilateral_filter.wgsl` (struct `Params`).
    pub struct BilateralParams as "Params" {
        /// Taps on each side.
        pub radius: i32,
        /// 0 rows, 1 columns.
        pub axis: u32,
        /// σs.
        pub sigma_spatial: f32,
        /// σr.
        pub sigma_range: f32,
        /// 1 when a guide is bound.
        pub use_guide: u32,
        /// 1 for a Scalar source.
        pub scalar: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

/// Filter parameters.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// Taps on each side.
    pub radius: i32,
    /// σs.
    pub sigma_spatial: f32,
    /// σr.
    pub sigma_range: f32,
}

fn gauss(d: f32, sigma: f32) -> f32 {
    if sigma <= 0.0 {
        return if d == 0.0 { 1.0 } else { 0.0 };
    }
    (-(d * d) / (2.0 * sigma * sigma)).exp()
}

/// Luminance of every texel (a one-channel raster's value).
pub fn luminance(r: &Raster) -> Vec<f32> {
    match r.channels {
        1 => r.data.clone(),
        _ => r
            .data
            .chunks(r.channels as usize)
            .map(|c| c[0] * 0.2126 + c[1] * 0.7152 + c[2] * 0.0722)
            .collect(),
    }
}

/// One pass of the CPU reference (axis 0 rows, 1 columns), in the shader's f32 order.
pub fn pass(src: &Raster, guide: &[f32], s: Settings, axis: u32) -> Raster {
    let (w, h, c) = (src.width as i64, src.height as i64, src.channels as usize);
    let mut out = src.clone();
    for y in 0..h {
        for x in 0..w {
            let p = (y * w + x) as usize;
            let mut num = vec![0.0f32; c];
            let mut den = 0.0f32;
            for j in -(s.radius as i64)..=s.radius as i64 {
                let (qx, qy) = if axis == 0 { (x + j, y) } else { (x, y + j) };
                if qx < 0 || qy < 0 || qx >= w || qy >= h {
                    continue;
                }
                let q = (qy * w + qx) as usize;
                let wt =
                    gauss(j as f32, s.sigma_spatial) * gauss(guide[q] - guide[p], s.sigma_range);
                for (k, n) in num.iter_mut().enumerate() {
                    *n += wt * src.data[q * c + k];
                }
                den += wt;
            }
            if den > 0.0 {
                for (k, n) in num.iter().enumerate() {
                    out.data[p * c + k] = n / den;
                }
            }
        }
    }
    out
}

/// CPU reference of the node.
pub fn reference(src: &Raster, guide: Option<&[f32]>, s: Settings) -> Raster {
    let g1 = guide.map_or_else(|| luminance(src), <[f32]>::to_vec);
    let rows = pass(src, &g1, s, 0);
    let g2 = guide.map_or_else(|| luminance(&rows), <[f32]>::to_vec);
    pass(&rows, &g2, s, 1)
}

fn gpu_pass(
    gpu: &Recorder,
    src: &GpuTexture,
    guide: Option<&GpuTexture>,
    s: Settings,
    axis: u32,
) -> Result<GpuTexture, GpuError> {
    let scalar = src.format == TexFormat::R32F;
    let u = BilateralParams {
        radius: s.radius,
        axis,
        sigma_spatial: s.sigma_spatial,
        sigma_range: s.sigma_range,
        use_guide: guide.is_some() as u32,
        scalar: scalar as u32,
        _pad0: 0,
        _pad1: 0,
    };
    let out = gpu.texture(src.width, src.height, src.format)?;
    let (entry, slot) = if scalar {
        ("bilateral_scalar", "out_scalar")
    } else {
        ("bilateral_image", "out_image")
    };
    gpu.dispatch(
        SHADER,
        entry,
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(src)),
            ("guide", Bind::Texture(guide.unwrap_or(src))),
            (slot, Bind::Storage(&out)),
        ],
        src.width,
        src.height,
    )?;
    Ok(out)
}

impl NodeKind for BilateralFilter {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let src = ctx.require_texture("image")?;
        if src.format == TexFormat::Rg32F {
            return Err(NodeError::Input {
                port: "image".into(),
                message: "has an internal two-channel format".into(),
            });
        }
        let guide = match ctx.texture_opt("guide")? {
            Some(t) => {
                if (t.width, t.height) != (src.width, src.height) {
                    return Err(NodeError::Input {
                        port: "guide".into(),
                        message: format!(
                            "is {}×{} but image is {}×{}",
                            t.width, t.height, src.width, src.height
                        ),
                    });
                }
                Some(t)
            }
            None => None,
        };
        let s = Settings {
            radius: p.radius as i32,
            sigma_spatial: p.sigma_spatial,
            sigma_range: p.sigma_range,
        };
        let rows = gpu_pass(ctx.gpu, &src, guide.as_deref(), s, 0)?;
        let out = gpu_pass(ctx.gpu, &rows, guide.as_deref(), s, 1)?;
        ctx.set("image", super::util::image_like(Arc::new(out)));
        Ok(())
    }
}
