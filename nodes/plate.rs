//! Plate mode: shafts over a render from another renderer (a "plate": Cycles, Arnold, a
//! photograph with a matched camera). Two kinds, one pass file (`shaders/plate.wgsl`).
//!
//! `PlateDepth` bounds Tyndall's view rays by the plate's own depth, where the plate has
//! geometry Tyndall's scene lacks (set dressing not exported, a matte painting):
//! `s(x) = s_plate(x)` where `s_plate < (1 − tolerance) · s_scene`, else `s_scene(x)`, both as
//! distances along the view ray (metres): where the two agree (the same surface, within
//! `tolerance`) the scene's own depth is kept. Cycles
//! and Blender write `Depth.Z` as the distance along the camera's view axis (`convention =
//! planar`, checked with a Cycles render of a wall facing the camera: Z is the same at its
//! centre and corners), which is converted with the ray's angle to the axis:
//! `s_plate = z_plate · scale / cos θ`, `cos θ = −(view ray in camera space).z`; `distance`
//! takes the plate's value as the ray distance already. Non-finite values and values at or
//! beyond `1e9` (Blender's background Z is 1e10) bound nothing. The plate depth is read at the
//! nearest texel to the pixel's centre, so it may have another size than the scene's depth
//! (depth is not interpolated across silhouettes). The camera is the scene's (`depth`'s
//! matrices): the plate must be rendered from the same camera — Blender's glTF export of the
//! shot, or the EXR header's `worldToCamera` on `ImageInput.depth`.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `depth` | in | Depth (required) | the scene's depth and camera (GBuffer) |
//! | `plate_depth` | in | Scalar \| Depth (required) | the plate's depth (`ImageInput` with `layer = ViewLayer.Depth`) |
//! | `depth` | out | Depth | min of the two, the scene's camera, for `SingleScattering` |
//! | `mask` | out | Scalar | 1 where the plate's depth bounds the ray (plate-only geometry), else 0 |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `convention` | Enum | planar | planar, distance | what the plate's values measure |
//! | `scale` | Float | 1 | 1e-6…1e6 | plate depth units → metres |
//! | `tolerance` | Float | 0.01 | 0…1 | relative difference under which both depths are one surface |
//!
//! `PlateOver`: `out = plate · T + L_scat`, the plate attenuated by the medium's transmittance
//! and the in-scatter added: the plate's colour is radiance behind the medium (for Cycles,
//! scene-linear radiance in the same units as Tyndall's W/(m²·sr) when the sun strengths
//! match). The output has the plate's size; `inscatter` and `transmittance` are read at each
//! plate pixel's position — their own texel when the sizes agree, else bilinearly (so shafts
//! computed at a lower resolution, a quality knob, lie over a full-resolution plate). Alpha is the plate's. Where the medium is
//! absent (T = 1, L = 0) the output is the plate exactly.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `plate` | in | Image (required) | the beauty render (`ImageInput` with `layer = ViewLayer.Combined`) |
//! | `inscatter` | in | Image (optional) | L_scat; unconnected: 0 |
//! | `transmittance` | in | Scalar (optional) | T; unconnected: 1 |
//! | `image` | out | Image | linear RGB, the plate's alpha |

use std::sync::Arc;

use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `PlateDepth` node kind.
pub struct PlateDepth;

/// The `PlateOver` node kind.
pub struct PlateOver;

/// Plate depth values at or beyond this bound nothing (Blender's background Z is 1e10).
pub const NO_DEPTH: f32 = 1e9;

tyndall_engine::choice_enum! {
    /// What the plate's depth values measure.
    pub enum Convention { Planar = "planar", Distance = "distance" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// `PlateDepth`'s parameters (the table above), read once per run.
    pub struct DepthParams {
        convention: Convention = ParamSpec::choice("convention", Convention::NAMES, "planar", "planar: distance along the camera's view axis (Cycles/Blender Z); distance: along the view ray (Tyndall's depth)."),
        scale: f32 = ParamSpec::float("scale", 1.0, 1e-6, 1e6, "m/unit", "Plate depth units → metres (Blender: the scene's unit scale)."),
        tolerance: f32 = ParamSpec::float("tolerance", 0.01, 0.0, 1.0, "relative", "Depths closer than this fraction are one surface: the scene's depth is kept and the mask is 0."),
    }
}

#[rustfmt::skip]
static DEPTH_DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "PlateDepth",
    category: "Input/Output",
    doc: "Bounds the scene's view rays by a plate's depth (another renderer's Z): min of the two distances, the scene's camera.",
    inputs: &[
        PortSpec::required("depth", &[PortType::Depth], "The scene's depth and camera (GBuffer)."),
        PortSpec::required("plate_depth", &[PortType::Scalar, PortType::Depth], "The plate's depth (ImageInput, layer ViewLayer.Depth)."),
    ],
    outputs: &[
        PortSpec::output("depth", &[PortType::Depth], "The nearer of the two, as ray distance, with the scene's camera."),
        PortSpec::output("mask", &[PortType::Scalar], "1 where the plate is nearer (geometry only the plate has)."),
    ],
    params: DepthParams::SPECS,
})
.shaders(&[SHADER])
.uniforms(&[PlateDepthParams::LAYOUT]);

#[rustfmt::skip]
static OVER_DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "PlateOver",
    category: "Input/Output",
    doc: "Shafts over a plate: plate × transmittance + inscatter, at the plate's size.",
    inputs: &[
        PortSpec::required("plate", &[PortType::Image], "The beauty render (ImageInput, layer ViewLayer.Combined)."),
        PortSpec::input("inscatter", &[PortType::Image], "In-scatter added on top (SingleScattering)."),
        PortSpec::input("transmittance", &[PortType::Scalar], "Attenuation of the plate by the medium."),
    ],
    outputs: &[PortSpec::output("image", &[PortType::Image], "Linear radiance, the plate's alpha.")],
    params: &[],
})
.shaders(&[SHADER])
.uniforms(&[PlateDepthParams::LAYOUT, PlateOverParams::LAYOUT]);

const SHADER: Shader = crate::shader("plate", include_str!("../shaders/plate.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `plate_depth` in `shaders/plate.wgsl` (struct `DepthParams`).
    pub struct PlateDepthParams as "DepthParams" {
        /// Camera clip → world.
        pub inv_view_proj: [[f32; 4]; 4],
        /// World → view (for the angle to the view axis).
        pub view: [[f32; 4]; 4],
        /// Camera position.
        pub eye: [f32; 3],
        /// 1: the plate is planar depth.
        pub planar: u32,
        /// Units → metres.
        pub scale: f32,
        /// Relative tolerance.
        pub tolerance: f32,
        /// Padding.
        pub _pad1: u32,
        /// Padding.
        pub _pad2: u32,
    }
}

tyndall_engine::uniforms! {
    /// Uniforms of `plate_over` in `shaders/plate.wgsl` (struct `OverParams`).
    pub struct PlateOverParams as "OverParams" {
        /// 1 when inscatter is connected.
        pub has_inscatter: u32,
        /// 1 when transmittance is connected.
        pub has_transmittance: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

/// The plate's value as a distance along the ray through pixel (x, y) of a `w × h` image of
/// camera `cam`, or `None` when it bounds nothing.
pub fn plate_distance(
    value: f32,
    cam: &Matrices,
    (x, y, w, h): (u32, u32, u32, u32),
    convention: Convention,
    scale: f32,
) -> Option<f32> {
    if !value.is_finite() || value >= NO_DEPTH || value <= 0.0 {
        return None;
    }
    let v = value * scale;
    match convention {
        Convention::Distance => Some(v),
        Convention::Planar => {
            let ray = cam.pixel_ray(x, y, w, h);
            let view = glam::Mat4::from_cols_array_2d(&cam.view);
            let cos = -(view.transform_vector3(ray).normalize_or(glam::Vec3::NEG_Z)).z;
            (cos > 1e-6).then(|| v / cos)
        }
    }
}

/// CPU reference of `PlateDepth`: (depth, mask) for the scene's `depth` (camera `cam`) and the
/// plate's one-channel `plate` (read at the nearest texel), `tolerance` relative.
pub fn depth_reference(
    depth: &Raster,
    cam: &Matrices,
    plate: &Raster,
    convention: Convention,
    scale: f32,
    tolerance: f32,
) -> (Raster, Raster) {
    let (w, h) = (depth.width, depth.height);
    let mut out = depth.clone();
    let mut mask = Raster::new(w, h, 1, 0.0);
    for y in 0..h {
        for x in 0..w {
            let px =
                (((x as f32 + 0.5) / w as f32 * plate.width as f32) as u32).min(plate.width - 1);
            let py =
                (((y as f32 + 0.5) / h as f32 * plate.height as f32) as u32).min(plate.height - 1);
            let value = plate.pixel(px, py)[0];
            let i = (y * w + x) as usize;
            if let Some(d) = plate_distance(value, cam, (x, y, w, h), convention, scale) {
                if d < depth.data[i] * (1.0 - tolerance) {
                    out.data[i] = d;
                    mask.data[i] = 1.0;
                }
            }
        }
    }
    (out, mask)
}

/// CPU reference of `PlateOver` (`inscatter`, `transmittance` read bilinearly at each plate
/// pixel's position; `None`: unconnected).
pub fn over_reference(
    plate: &Raster,
    inscatter: Option<&Raster>,
    transmittance: Option<&Raster>,
) -> Raster {
    use super::algorithms::shader_lib::bilinear_texels;
    let (w, h) = (plate.width, plate.height);
    let mut out = plate.clone();
    for y in 0..h {
        for x in 0..w {
            let at = |r: &Raster| {
                if (r.width, r.height) == (w, h) {
                    return r.pixel(x, y).to_vec();
                }
                let p = [
                    (x as f32 + 0.5) / w as f32 * r.width as f32,
                    (y as f32 + 0.5) / h as f32 * r.height as f32,
                ];
                bilinear_texels(r, p)
            };
            let t = transmittance.map_or(1.0, |r| at(r)[0]);
            let l = inscatter.map_or(vec![0.0; 4], at);
            let i = (y * w + x) as usize * 4;
            for (c, l) in l.iter().take(3).enumerate() {
                out.data[i + c] = plate.data[i + c] * t + l;
            }
        }
    }
    out
}

impl NodeKind for PlateDepth {
    fn decl(&self) -> &'static NodeDecl {
        &DEPTH_DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = DepthParams::from_ctx(ctx)?;
        let (depth, cam) = ctx.depth("depth")?;
        let plate = ctx.require_texture("plate_depth")?;
        if plate.format != TexFormat::R32F {
            return Err(NodeError::Input {
                port: "plate_depth".into(),
                message: "is not one channel".into(),
            });
        }
        let u = PlateDepthParams {
            inv_view_proj: cam.view_proj().inverse().to_cols_array_2d(),
            view: cam.view,
            eye: cam.eye().to_array(),
            planar: (p.convention == Convention::Planar) as u32,
            scale: p.scale,
            tolerance: p.tolerance,
            _pad1: 0,
            _pad2: 0,
        };
        let (w, h) = (depth.width, depth.height);
        let out = ctx.gpu.texture(w, h, TexFormat::R32F)?;
        let mask = ctx.gpu.texture(w, h, TexFormat::R32F)?;
        ctx.gpu.dispatch(
            SHADER,
            "plate_depth",
            &[
                ("D", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("scene_depth", Bind::Texture(&depth)),
                ("plate_depth_in", Bind::Texture(&plate)),
                ("out_depth", Bind::Storage(&out)),
                ("out_mask", Bind::Storage(&mask)),
            ],
            w,
            h,
        )?;
        ctx.set("depth", PortValue::Depth(Arc::new(out), cam));
        ctx.set("mask", PortValue::Scalar(Arc::new(mask)));
        Ok(())
    }
}

impl NodeKind for PlateOver {
    fn decl(&self) -> &'static NodeDecl {
        &OVER_DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let plate = ctx.image("plate")?;
        let inscatter = ctx.image_opt("inscatter")?;
        let transmittance = ctx.scalar_opt("transmittance")?;
        let u = PlateOverParams {
            has_inscatter: inscatter.is_some() as u32,
            has_transmittance: transmittance.is_some() as u32,
            _pad0: 0,
            _pad1: 0,
        };
        let dummy = super::util::placeholder(ctx)?;
        let dummy_rgba = Arc::new(ctx.gpu.texture(1, 1, TexFormat::Rgba32F)?);
        let (w, h) = (plate.width, plate.height);
        let out = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
        let ins = inscatter.unwrap_or(dummy_rgba);
        let tr = transmittance.unwrap_or(dummy);
        ctx.gpu.dispatch(
            SHADER,
            "plate_over",
            &[
                ("O", Bind::Uniform(bytemuck::bytes_of(&u))),
                ("plate", Bind::Texture(&plate)),
                ("inscatter", Bind::Texture(&ins)),
                ("transmittance", Bind::Texture(&tr)),
                ("out_image", Bind::Storage(&out)),
            ],
            w,
            h,
        )?;
        ctx.set("image", PortValue::Image(Arc::new(out)));
        Ok(())
    }
}
