//! Point sampling by an integer factor: low-res texel q takes the high-res texel at
//! `q·f + ⌊f/2⌋` (clamped) — no averaging, so depths stay depths of real surfaces. `Downsample`
//! is this pass as a node; `DepthUpsample` reduces a full-resolution depth with it when no
//! low-resolution depth is connected, and `ImageInput`'s `reduce` is its CPU reference.

use tyndall_engine::gpu::Recorder;
use tyndall_engine::gpu::{Bind, GpuError, GpuTexture, Shader, TexFormat};
use tyndall_engine::io::Raster;

/// The pass (`shaders/algorithms/point_sample.wgsl`); a kind that calls [`downsample`] lists it
/// in its `NodeDecl::shaders`, and [`PointSampleParams::LAYOUT`] in its uniforms.
pub const SHADER: Shader = crate::shader(
    "algorithms/point_sample",
    include_str!("../../shaders/algorithms/point_sample.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/downsample.wgsl` (struct `Params`).
    /// The pass's parameter block.
    pub struct PointSampleParams as "PointSampleParams" {
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
/// CPU reference: texel q of the result is texel `q·factor + ⌊factor/2⌋` of `src` (clamped);
/// the result is ⌈w/factor⌉ × ⌈h/factor⌉.
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
/// [`reference()`] on the GPU, for a one-channel (`R32F`) or RGBA texture.
pub fn downsample(gpu: &Recorder, src: &GpuTexture, factor: u32) -> Result<GpuTexture, GpuError> {
    let (w, h) = (src.width.div_ceil(factor), src.height.div_ceil(factor));
    let out = gpu.texture(w, h, src.format)?;
    let u = PointSampleParams {
        factor,
        _pad0: 0,
        _pad1: 0,
        _pad2: 0,
    };
    let (entry, slot) = if src.format == TexFormat::R32F {
        ("downsample_scalar", "out_scalar")
    } else {
        ("downsample_image", "out_image")
    };
    gpu.dispatch(
        SHADER,
        entry,
        &[
            ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
            ("src", Bind::Texture(src)),
            (slot, Bind::Storage(&out)),
        ],
        w,
        h,
    )?;
    Ok(out)
}
