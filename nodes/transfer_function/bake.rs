//! Baking the layer stack into the TF texture, and looking the TF up per pixel (CPU
//! reference and GPU passes).

use crate::algorithms::multigrid::Rgba;
use crate::algorithms::quantile::{self, Histogram, Rank};
use tyndall_engine::gpu::Recorder;

use super::data::lerp_n;
use super::diffusion::mg_pass;
use super::{
    diffuse_gpu, diffuse_reference, Bind, Blend, GpuTexture, Layer, LayerEntry, Matrices,
    NodeError, Path, Raster, TexFormat, IDENTITY,
};

/// The colour of a gradient at p.
pub fn gradient_colour(from: [f32; 2], to: [f32; 2], c0: Rgba, c1: Rgba, p: [f32; 2]) -> Rgba {
    let d = [to[0] - from[0], to[1] - from[1]];
    let len2 = d[0] * d[0] + d[1] * d[1];
    let t = if len2 > 0.0 {
        (((p[0] - from[0]) * d[0] + (p[1] - from[1]) * d[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    lerp_n(c0, c1, t)
}

/// `dst` with `src` composited by `blend` at opacity `opacity`.
pub fn blend(dst: Rgba, src: Rgba, blend: Blend, opacity: f32) -> Rgba {
    let a = opacity * src[3];
    let rgb: [f32; 3] = std::array::from_fn(|c| match blend {
        Blend::Alpha => dst[c] * (1.0 - a) + src[c] * a,
        Blend::Multiply => dst[c] * (1.0 - a) + dst[c] * src[c] * a,
        Blend::Add => dst[c] + src[c] * a,
    });
    [rgb[0], rgb[1], rgb[2], dst[3] * (1.0 - a) + a]
}

/// Bilinear sample of an RGBA raster at (u, v): texel centres at (i + 0.5)/size, clamp to edge.
pub fn bilinear(r: &Raster, u: f32, v: f32) -> Rgba {
    let (w, h) = (r.width as i64, r.height as i64);
    let (x, y) = (u * w as f32 - 0.5, v * h as f32 - 0.5);
    let (fx, fy) = (x - x.floor(), y - y.floor());
    let (x0, y0) = (x.floor() as i64, y.floor() as i64);
    let at = |i: i64, j: i64| -> Rgba {
        let (i, j) = (i.clamp(0, w - 1), j.clamp(0, h - 1));
        let k = ((j * w + i) * 4) as usize;
        [r.data[k], r.data[k + 1], r.data[k + 2], r.data[k + 3]]
    };
    let top = lerp_n(at(x0, y0), at(x0 + 1, y0), fx);
    let bottom = lerp_n(at(x0, y0 + 1), at(x0 + 1, y0 + 1), fx);
    lerp_n(top, bottom, fy)
}

/// CPU reference of the baked table. `images[i]` is layer i's picture (image layers only).
pub fn bake_reference(
    stack: &[LayerEntry],
    n: u32,
    cycles: u32,
    images: &[Option<Raster>],
) -> Raster {
    let mut acc = Raster::new(n, n, 4, 0.0);
    for (li, e) in stack.iter().enumerate() {
        let solved = match &e.layer {
            Layer::Diffusion { constraints } => Some(diffuse_reference(constraints, n, cycles)),
            Layer::Image { .. } => images.get(li).cloned().flatten(),
            _ => None,
        };
        for j in 0..n {
            for i in 0..n {
                let p = [(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32];
                let src = match &e.layer {
                    Layer::Solid { colour } => *colour,
                    Layer::Gradient {
                        from,
                        to,
                        from_colour,
                        to_colour,
                    } => gradient_colour(*from, *to, *from_colour, *to_colour, p),
                    _ => solved
                        .as_ref()
                        .map_or([0.0; 4], |r| bilinear(r, p[0], p[1])),
                };
                let k = ((j * n + i) * 4) as usize;
                let dst = [
                    acc.data[k],
                    acc.data[k + 1],
                    acc.data[k + 2],
                    acc.data[k + 3],
                ];
                acc.data[k..k + 4].copy_from_slice(&blend(dst, src, e.blend, e.opacity));
            }
        }
    }
    acc
}

/// The TF coordinate v of depth `d`.
pub fn depth_coordinate(d: f32, depth_min: f32, depth_max: f32) -> f32 {
    let span = depth_max - depth_min;
    let v = if span > 0.0 {
        (d - depth_min) / span
    } else if d > depth_min {
        1.0
    } else {
        0.0
    };
    if v.is_nan() {
        0.0
    } else {
        v.clamp(0.0, 1.0)
    }
}

/// `depth_range = auto`: the 1st and 99th percentiles (nearest rank, `quantile::Rank::Round`)
/// of the finite surface depths — below the camera's far distance when the depth comes from a
/// camera (sky pixels sit at the far distance), all finite values when it comes from a file
/// (identity matrices). `(0, 1)` when no pixel qualifies. [`auto_range_gpu`] is the same on the
/// GPU, bit for bit.
pub fn auto_range(depth: &[f32], m: &Matrices) -> (f32, f32) {
    let limit = depth_limit(m);
    let at = |q| quantile::reference(depth, q, Rank::Round, limit);
    match (at(0.01), at(0.99)) {
        (Some(lo), Some(hi)) => (lo, hi),
        _ => (0.0, 1.0),
    }
}

/// The depths that count for the automatic range: below the far distance of a camera's depth.
fn depth_limit(m: &Matrices) -> Option<f32> {
    (m.view != IDENTITY || m.proj != IDENTITY).then_some(m.far)
}

/// The selections of [`auto_range`]'s two percentiles of a depth map, made on the GPU and
/// kept there (`quantile::select`'s buffers): the node's `lookup_selected` pass reads them, so
/// `depth_range = auto` reads nothing back.
pub fn auto_range_select(
    gpu: &tyndall_engine::gpu::Recorder,
    depth: &tyndall_engine::gpu::GpuTexture,
    m: &Matrices,
) -> Result<[tyndall_engine::gpu::GpuBuffer; 2], tyndall_engine::gpu::GpuError> {
    let (limit, form) = (depth_limit(m), Histogram::for_adapter(gpu));
    let at = |q| quantile::select(gpu, depth, q, Rank::Round, limit, form);
    Ok([at(0.01)?, at(0.99)?])
}

/// [`auto_range`] of a depth map on the GPU ([`auto_range_select`]), its two selections read
/// back (2 × 1,036 bytes, not the map): the numbers, for tests and tools.
pub fn auto_range_gpu(
    gpu: &tyndall_engine::gpu::Recorder,
    depth: &tyndall_engine::gpu::GpuTexture,
    m: &Matrices,
) -> Result<(f32, f32), tyndall_engine::gpu::GpuError> {
    let [lo, hi] = auto_range_select(gpu, depth, m)?;
    Ok(
        match (
            quantile::read_value(gpu, &lo)?,
            quantile::read_value(gpu, &hi)?,
        ) {
            (Some(lo), Some(hi)) => (lo, hi),
            _ => (0.0, 1.0),
        },
    )
}

// ---------------------------------------------------------------------------------------------
// GPU.

tyndall_engine::uniforms! {
    /// Uniforms of `bake_layer` (struct `Layer`).
    pub struct LayerParams as "Layer" {
        /// 0 solid, 1 gradient, 2 sampled from the bound texture.
        pub kind: u32,
        /// 0 alpha, 1 multiply, 2 add.
        pub blend: u32,
        /// Opacity.
        pub opacity: f32,
        /// Padding.
        pub _pad0: u32,
        /// Solid colour / gradient start colour.
        pub colour0: [f32; 4],
        /// Gradient end colour.
        pub colour1: [f32; 4],
        /// Gradient start point.
        pub from_uv: [f32; 2],
        /// Gradient end point.
        pub to_uv: [f32; 2],
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of `lookup` (struct `Lookup`).
    pub struct LookupParams as "Lookup" {
        /// Depth at v = 0.
        pub depth_min: f32,
        /// Depth at v = 1.
        pub depth_max: f32,
        /// Output scale.
        pub intensity: f32,
        /// 1 for Modulate.
        pub modulate: u32,
    }
}

/// Bake a layer stack into an N×N table on the GPU.
pub fn bake_gpu(
    gpu: &Recorder,
    stack: &[LayerEntry],
    n: u32,
    cycles: u32,
) -> Result<GpuTexture, NodeError> {
    let mut acc = gpu.zeroed(n, n, TexFormat::Rgba32F)?;
    let dummy = gpu.zeroed(1, 1, TexFormat::Rgba32F)?;
    for e in stack {
        let mut p = LayerParams {
            kind: 0,
            blend: match e.blend {
                Blend::Alpha => 0,
                Blend::Multiply => 1,
                Blend::Add => 2,
            },
            opacity: e.opacity,
            _pad0: 0,
            colour0: [0.0; 4],
            colour1: [0.0; 4],
            from_uv: [0.0; 2],
            to_uv: [0.0; 2],
        };
        let src = match &e.layer {
            Layer::Solid { colour } => {
                p.colour0 = *colour;
                None
            }
            Layer::Gradient {
                from,
                to,
                from_colour,
                to_colour,
            } => {
                (p.kind, p.colour0, p.colour1, p.from_uv, p.to_uv) =
                    (1, *from_colour, *to_colour, *from, *to);
                None
            }
            Layer::Diffusion { constraints } => {
                p.kind = 2;
                Some(diffuse_gpu(gpu, constraints, n, cycles)?)
            }
            Layer::Image { path } => {
                p.kind = 2;
                let r = tyndall_engine::io::read_image(Path::new(path), true)?.into_rgba();
                Some(gpu.upload(r.width, r.height, 4, &r.data)?)
            }
        };
        acc = mg_pass(
            gpu,
            "bake_layer",
            (n, n),
            &[
                ("L", Bind::Uniform(bytemuck::bytes_of(&p))),
                ("a_tex", Bind::Texture(&acc)),
                ("b_tex", Bind::Texture(src.as_ref().unwrap_or(&dummy))),
            ],
        )?;
    }
    Ok(acc)
}
