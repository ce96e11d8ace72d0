//! `TemporalAccumulate`: the mean of the current frame and the `frames − 1` frames before it,
//! each reprojected into the current camera through the depth (the temporal accumulation of
//! TAA, over a fixed window so that every frame is computed the same way whether it is rendered
//! alone or in a sequence). What it is for: few-step marching shimmers under camera motion
//! (sample positions slide through thin shafts from frame to frame); the camera's motion puts
//! each frame's samples elsewhere along the rays, and the window averages `frames` of them for
//! the cost of one march per frame (`tyndall bench temporal`, the forest walk: 24 steps' flicker
//! 71 % → 36 % of the picture's real change with 4 frames). For a still camera,
//! `SingleScattering`'s `jitter_pattern = frame` gives each frame other samples. Reprojection
//! through the surface depth does not follow shafts in front of the surface (parallax), so the
//! window adds a flicker of its own (14 % on the exact picture, 4 frames): it does not help a
//! method that is already steadier than that.
//!
//! The evaluator evaluates the node's inputs again at time − k·`frame_step`, k = 1…`frames` − 1
//! (`NodeKind::history`; in a sequential render these are cache hits). For pixel p of the
//! current frame, with view ray d through its centre and depth D (distance from the eye), the
//! surface point is X = eye + d·D. In earlier frame k, X projects to the continuous pixel
//! position q_k of that frame's camera; each of the four texels t around q_k (texel centres)
//! counts with its bilinear weight b_t when it lies on the image, X is in front of that camera,
//! and |D_k(t) − |X − eye_k|| ≤ `depth_tolerance` · |X − eye_k| (the earlier frame saw the same
//! surface: disocclusions and moving occluders are rejected). The output is
//!
//! ```text
//! out(p) = (I₀(p) + Σ_k Σ_t b_t I_k(t)) / (1 + Σ_k Σ_t b_t)
//! ```
//!
//! where, with `clamp = neighbourhood` (the default), each frame's reprojected value
//! Σ_t b_t I_k(t) / Σ_t b_t is first clamped, per channel, to the range of the current frame over
//! the 3×3 pixels around p (TAA's neighbourhood clamp, Karis 2014): reprojection through the
//! surface depth follows the surface, not the shafts in front of it, and a value the current
//! neighbourhood does not span is such a lagging change rather than noise. The current frame
//! always counts fully, and a pixel no earlier frame saw is the current frame's own value. `accepted` is that denominator over `frames` (1: every frame was
//! reprojected; 1/`frames`: only the current one). Sky pixels carry the camera's far distance as
//! depth and reproject as points at that distance. With `frames` = 1 the input passes through.
//! The window lags a moving picture by (`frames` − 1)/2 · `frame_step` frames on average.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `image` | in | Image \| Scalar (required) | what to accumulate (in-scatter) |
//! | `depth` | in | Depth (required) | the camera depth `image` was computed with |
//! | `image` | out | same type as the input | the accumulated picture |
//! | `accepted` | out | Scalar | frames' weight that reprojected, over `frames` (0…1) |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `frames` | Int | 4 | 1…16 frames | frames averaged, the current one included (quality knob) |
//! | `frame_step` | Float | 1 | 0.01…100 frames | spacing of the earlier frames |
//! | `clamp` | Enum | neighbourhood | neighbourhood, off | clamp earlier frames to the current 3×3 range |
//! | `depth_tolerance` | Float | 0.05 | 0…1 relative | rejection: depth mismatch as a share of the distance |

use std::collections::BTreeMap;
use std::sync::Arc;

use glam::{Mat4, Vec3, Vec4};

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, GpuTexture, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, ParamValue, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `TemporalAccumulate` node kind.
pub struct TemporalAccumulate;

tyndall_engine::choice_enum! {
    /// Whether earlier frames are clamped to the current neighbourhood's range.
    pub enum Clamp { Neighbourhood = "neighbourhood", Off = "off" }
}

const IMG: &[PortType] = &[PortType::Scalar, PortType::Image];

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        frames: i64 = ParamSpec::int("frames", 4, 1, 16, "frames", "Frames averaged, the current one included (quality knob: more frames, less shimmer, more lag)."),
        frame_step: f64 = ParamSpec::float("frame_step", 1.0, 0.01, 100.0, "frames", "Spacing of the earlier frames."),
        clamp: Clamp = ParamSpec::choice("clamp", Clamp::NAMES, "neighbourhood", "neighbourhood: each earlier frame's reprojected value is clamped to the current frame's range over the 3×3 pixels around (what the current frame does not span is a change the earlier frame lags: shafts in front of the surface, which reprojection by depth cannot follow); off: used as it is."),
        depth_tolerance: f32 = ParamSpec::float("depth_tolerance", 0.05, 0.0, 1.0, "relative", "An earlier texel whose depth differs from the reprojected point's distance by more than this share of it is rejected."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "TemporalAccumulate",
    category: "Image",
    doc: "Mean of the current frame and the frames before it, reprojected through the depth with depth rejection (a fixed window: every frame renders the same alone or in a sequence). Steadies few-step or jittered marching in motion.",
    inputs: &[
        PortSpec::required("image", IMG, "What to accumulate (in-scatter)."),
        PortSpec::required("depth", &[PortType::Depth], "The camera depth the image was computed with."),
    ],
    outputs: &[
        PortSpec::output("image", IMG, "The accumulated picture, same type as the input."),
        PortSpec::output("accepted", &[PortType::Scalar], "Weight of the frames that reprojected, over `frames` (1: all of them)."),
    ],
    params: Params::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[AccumulateParams::LAYOUT]);

const SHADER: Shader = crate::shader(
    "temporal_accumulate",
    include_str!("../shaders/temporal_accumulate.wgsl"),
);

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/temporal_accumulate.wgsl` (struct `Params`).
    pub struct AccumulateParams as "Params" {
        /// World → clip of the earlier frame's camera.
        pub prev_view_proj: [[f32; 4]; 4],
        /// Clip → world of the current camera.
        pub inv_view_proj: [[f32; 4]; 4],
        /// Current eye.
        pub eye: [f32; 3],
        /// Relative depth tolerance.
        pub tolerance: f32,
        /// Earlier eye.
        pub prev_eye: [f32; 3],
        /// Padding.
        pub _pad0: u32,
        /// Frames asked for.
        pub frames: f32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
        /// Padding.
        pub _pad3: u32,
    }
}

/// One frame for the CPU reference: its picture (any channel count), depth and camera.
pub struct Frame<'a> {
    /// The picture.
    pub image: &'a Raster,
    /// Its camera depth.
    pub depth: &'a Raster,
    /// Its camera.
    pub camera: Matrices,
}

/// The reprojected sum (per channel) and weight of pixel (x, y) of the current frame from
/// earlier frame `prev`.
fn reproject(cur: &Frame, prev: &Frame, x: u32, y: u32, tolerance: f32) -> (Vec<f32>, f32) {
    let (w, h) = (cur.depth.width, cur.depth.height);
    let c = prev.image.channels as usize;
    let mut sum = vec![0.0f32; c];
    let mut weight = 0.0f32;
    let eye = cur.camera.eye();
    let dir = cur.camera.pixel_ray(x, y, w, h);
    let p = eye + dir * cur.depth.data[(y * w + x) as usize];
    let clip = prev.camera.view_proj() * Vec4::from((p, 1.0));
    if clip.w.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return (sum, weight);
    }
    let (pw, ph) = (prev.image.width as i64, prev.image.height as i64);
    let ndc = [clip.x / clip.w, clip.y / clip.w];
    let q = [
        (ndc[0] + 1.0) * 0.5 * pw as f32 - 0.5,
        (1.0 - ndc[1]) * 0.5 * ph as f32 - 0.5,
    ];
    let base = [q[0].floor(), q[1].floor()];
    let f = [q[0] - base[0], q[1] - base[1]];
    let dist = (p - prev.camera.eye()).length();
    for k in 0..4 {
        let o = [k & 1, k >> 1];
        let t = [base[0] as i64 + o[0], base[1] as i64 + o[1]];
        if t[0] < 0 || t[1] < 0 || t[0] >= pw || t[1] >= ph {
            continue;
        }
        let wb = (if o[0] == 1 { f[0] } else { 1.0 - f[0] })
            * (if o[1] == 1 { f[1] } else { 1.0 - f[1] });
        let ti = (t[1] * pw + t[0]) as usize;
        if (prev.depth.data[ti] - dist).abs() <= tolerance * dist && wb > 0.0 {
            for (i, s) in sum.iter_mut().enumerate() {
                *s += wb * prev.image.data[ti * c + i];
            }
            weight += wb;
        }
    }
    (sum, weight)
}

/// The per-channel range of `image` over the 3×3 pixels around (x, y), clamped at the edges.
fn neighbourhood(image: &Raster, x: u32, y: u32) -> (Vec<f32>, Vec<f32>) {
    let c = image.channels as usize;
    let (mut lo, mut hi) = (vec![f32::MAX; c], vec![f32::MIN; c]);
    for j in -1i64..=1 {
        for i in -1i64..=1 {
            let tx = (x as i64 + i).clamp(0, image.width as i64 - 1);
            let ty = (y as i64 + j).clamp(0, image.height as i64 - 1);
            let t = (ty * image.width as i64 + tx) as usize * c;
            for k in 0..c {
                lo[k] = lo[k].min(image.data[t + k]);
                hi[k] = hi[k].max(image.data[t + k]);
            }
        }
    }
    (lo, hi)
}

/// CPU reference: `current` accumulated with the `earlier` frames (any order), each clamped to
/// the current neighbourhood when `clamp`, and the `accepted` share for a window of `frames`.
pub fn reference(
    current: &Frame,
    earlier: &[Frame],
    tolerance: f32,
    clamp: bool,
    frames: u32,
) -> (Raster, Raster) {
    let (w, h, c) = (
        current.image.width,
        current.image.height,
        current.image.channels,
    );
    let mut out = Raster::new(w, h, c, 0.0);
    let mut accepted = Raster::new(w, h, 1, 0.0);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let mut sum: Vec<f32> = current.image.data[i * c as usize..][..c as usize].to_vec();
            let mut weight = 1.0f32;
            for prev in earlier {
                let (mut s, wt) = reproject(current, prev, x, y, tolerance);
                if clamp && wt > 0.0 {
                    let (lo, hi) = neighbourhood(current.image, x, y);
                    for (k, v) in s.iter_mut().enumerate() {
                        *v = (*v / wt).clamp(lo[k], hi[k]) * wt;
                    }
                }
                sum.iter_mut().zip(s).for_each(|(a, b)| *a += b);
                weight += wt;
            }
            for (k, s) in sum.iter().enumerate() {
                out.data[i * c as usize + k] = s / weight;
            }
            accepted.data[i] = weight / frames as f32;
        }
    }
    (out, accepted)
}

impl NodeKind for TemporalAccumulate {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn history(&self, params: &BTreeMap<String, ParamValue>) -> Result<Vec<f64>, NodeError> {
        let p = Params::from_params(params)?;
        Ok((1..p.frames).map(|k| k as f64 * p.frame_step).collect())
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let (image, depth, camera) = current_frame(ctx)?;
        let (w, h) = (image.width, image.height);
        let inv = camera.view_proj().inverse();
        let mut u = AccumulateParams {
            prev_view_proj: Mat4::IDENTITY.to_cols_array_2d(),
            inv_view_proj: inv.to_cols_array_2d(),
            eye: camera.eye().to_array(),
            tolerance: p.depth_tolerance,
            prev_eye: Vec3::ZERO.to_array(),
            _pad0: 0,
            frames: p.frames as f32,
            _pad1: 0,
            _pad2: 0,
            _pad3: 0,
        };
        let on = |b: bool| if b { 1.0 } else { 0.0 };
        let clamp = on(p.clamp == Clamp::Neighbourhood);
        let Some(last) = ctx.earlier.len().checked_sub(1) else {
            let ones = vec![1.0f32; (w * h) as usize];
            let accepted = ctx.gpu.upload(w, h, 1, &ones)?;
            ctx.set("accepted", PortValue::Scalar(Arc::new(accepted)));
            ctx.set("image", ctx.require("image")?.clone());
            ctx.pass_through();
            return Ok(());
        };
        let out = ctx.gpu.texture(w, h, image.format)?;
        let accepted = ctx.gpu.texture(w, h, TexFormat::R32F)?;
        let mut sum: Option<(GpuTexture, GpuTexture)> = None;
        for (i, earlier) in ctx.earlier.iter().enumerate() {
            let prev = earlier
                .require("image")?
                .texture()
                .ok_or_else(|| NodeError::Input {
                    port: "image".into(),
                    message: format!("is no image {} frames earlier", earlier.offset),
                })?;
            let (prev_depth, prev_camera) = earlier.depth("depth")?;
            u.prev_view_proj = prev_camera.view_proj().to_cols_array_2d();
            u.prev_eye = prev_camera.eye().to_array();
            let (sum_in, weight_in) = match &sum {
                Some((s, wt)) => (s, wt),
                None => (&*image, &*image),
            };
            let mut binds = vec![
                ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("sum_in", Bind::Texture(sum_in)),
                ("weight_in", Bind::Texture(weight_in)),
                ("prev", Bind::Texture(prev)),
                ("prev_depth", Bind::Texture(&prev_depth)),
                ("depth", Bind::Texture(&depth)),
                ("current", Bind::Texture(&image)),
            ];
            if i < last {
                // Running sums for the next frame's pass.
                let sum_out = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
                let weight_out = ctx.gpu.texture(w, h, TexFormat::R32F)?;
                binds.push(("sum_out", Bind::Storage(&sum_out)));
                binds.push(("weight_out", Bind::Storage(&weight_out)));
                let constants = [("FIRST", on(i == 0)), ("CLAMP", clamp)];
                ctx.gpu
                    .dispatch_with(SHADER, "accumulate", &binds, (w, h), &constants)?;
                drop(binds);
                sum = Some((sum_out, weight_out));
            } else {
                // The last earlier frame: its pass divides.
                let (entry, slot) = if image.format == TexFormat::R32F {
                    ("resolve_scalar", "out_scalar")
                } else {
                    ("resolve_image", "out_image")
                };
                binds.push((slot, Bind::Storage(&out)));
                binds.push(("out_accepted", Bind::Storage(&accepted)));
                let constants = [("FIRST", on(i == 0)), ("CLAMP", clamp)];
                ctx.gpu
                    .dispatch_with(SHADER, entry, &binds, (w, h), &constants)?;
            }
        }
        ctx.set("image", super::util::image_like(Arc::new(out)));
        ctx.set("accepted", PortValue::Scalar(Arc::new(accepted)));
        Ok(())
    }
}

/// This frame's picture, its depth and camera: the picture in a one- or four-channel format,
/// the depth of the same size.
#[allow(clippy::type_complexity)]
fn current_frame(ctx: &RunCtx) -> Result<(Arc<GpuTexture>, Arc<GpuTexture>, Matrices), NodeError> {
    let image = ctx.require_texture("image")?;
    if image.format == TexFormat::Rg32F {
        return Err(NodeError::Input {
            port: "image".into(),
            message: "has an internal two-channel format".into(),
        });
    }
    let (depth, camera) = ctx.depth("depth")?;
    if (depth.width, depth.height) != (image.width, image.height) {
        return Err(NodeError::Input {
            port: "depth".into(),
            message: format!(
                "is {}×{} but image is {}×{}",
                depth.width, depth.height, image.width, image.height
            ),
        });
    }
    Ok((image, depth, camera))
}
