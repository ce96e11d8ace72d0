//! `ImageInput`: reads an EXR or PNG file and offers it as an Image, a Scalar, a ShadowMap or a
//! Depth (the last two with identity matrices: a painted or exported map fed into a chain).
//!
//! One-channel files give grey images (alpha 1); RGBA files give their colour, and their
//! Scalar is the channel chosen by `channel` (Rec. 709 luminance by default). 8/16-bit PNG colour
//! is decoded from sRGB to linear when `srgb` is on.
//!
//! | port | dir | type | |
//! |---|---|---|---|
//! | `image` | out | Image | RGBA |
//! | `scalar` | out | Scalar | one channel |
//! | `shadow` | out | ShadowMap | the one channel, light matrices identity; a texel ≥ 1e30 (`SHADOW_CLEAR`, as Tyndall's own float EXR maps hold, or +∞) is clear (no occluder), any other value an occluder at that depth: a painted map's 1.0 shadows what lies beyond depth 1 |
//! | `depth` | out | Depth | the one channel, camera matrices identity |
//!
//! | param | type | default | |
//! |---|---|---|---|
//! | `path` | Text | "" | file to read (`.exr`, `.png`) |
//! | `channel` | Enum | luminance | luminance, r, g, b, a: Scalar of an RGBA file |
//! | `srgb` | Bool | true | decode PNG colour from sRGB; off: the file is data (no colour conversion) |
//! | `colourspace` | Text | "" | colour space of the file (a name, alias or role of the config); empty: the config's file rules (see below) |
//! | `layer` | Text | "" | layer of a multi-layer EXR: `ViewLayer.Combined` (its R, G, B, A), `ViewLayer.Depth` (its one channel) or a full channel name `ViewLayer.Depth.Z`; empty: the main image |
//! | `reduce` | Int | 1 | 1…64: read at ⌈w/r⌉ × ⌈h/r⌉ (point sampling, `Downsample`'s rule); a proxy evaluation multiplies it by its factor, so a plate stays the size of the proxied pictures |
//!
//! Multi-layer EXR (Blender/Cycles, Nuke, Tyndall's `AovOutput`): `layer` picks one layer, so
//! one file gives the beauty (`ViewLayer.Combined`) on one `ImageInput` and its depth
//! (`ViewLayer.Depth`) on another — the inputs of plate mode (`PlateDepth`, `PlateOver`). A
//! layer that is not in the file is an error listing those that are. When the header carries
//! `worldToCamera` and `worldToNDC` (as Tyndall and Nuke write them), the `depth` output carries
//! that camera (projection = worldToNDC · worldToCamera⁻¹, far = the largest finite depth)
//! instead of identity matrices.
//!
//! Colour (issue #45): an RGBA file's colour is converted from `colourspace` to the graph's
//! working space on read (an OpenColorIO pass on the GPU). Empty `colourspace`: the config's
//! file rules — with the built-in config, whose rules call every EXR ACES2065-1, Tyndall's own
//! rule instead: an EXR is `Linear Rec.709 (sRGB)` (what Blender and Tyndall's default working
//! space write), a PNG `sRGB Encoded Rec.709 (sRGB)`; in the default working space that is the
//! reading of old (bit-identical). `srgb = false` reads the file as data: no decoding, no
//! conversion. One-channel files are data too (only `srgb` decodes a grey PNG).
//!
//! The cache key includes the file's size and modification time, so editing the file on disk
//! re-runs the node.
//!
//! Image sequences: a `####` run (as many digits as `#`) or a `%04d` in `path` is replaced by
//! the frame being rendered (`render --frames`; the editor's current frame), zero-padded, as
//! sinks name their files — `plate_####.exr` reads `plate_0012.exr` at frame 12.

use std::path::Path;
use std::sync::Arc;

use tyndall_engine::colour::ColourCtx;
use tyndall_engine::eval::{Matrices, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::Raster;

/// The `ImageInput` node kind.
pub struct ImageInput;

/// Names of the `channel` parameter, in the shader's order.
pub const CHANNELS: &[&str] = Channel::NAMES;

tyndall_engine::choice_enum! {
    /// Which channel the one-channel outputs carry, in the shader's order.
    pub enum Channel { Luminance = "luminance", R = "r", G = "g", B = "b", A = "a" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        path: String = ParamSpec::text("path", "", "File to read (.exr or .png)."),
        channel: Channel = ParamSpec::choice("channel", Channel::NAMES, "luminance", "Which channel of an RGBA file the one-channel outputs carry."),
        srgb: bool = ParamSpec::flag("srgb", true, "Decode 8/16-bit PNG colour from sRGB to linear (EXR is always linear)."),
        layer: String = ParamSpec::text("layer", "", "Layer of a multi-layer EXR: `ViewLayer.Combined` (R, G, B, A), `ViewLayer.Depth` (one channel) or a full channel name; empty: the main image."),
        colourspace: String = ParamSpec::text("colourspace", "", "Colour space of the file's colour (a name, alias or role of the OpenColorIO config), converted to the working space on read; empty: the config's file rules (built-in config: EXR = Linear Rec.709 (sRGB), PNG = sRGB Encoded Rec.709 (sRGB))."),
        reduce: i64 = ParamSpec::int("reduce", 1, 1, 64, "×", "Read the file at 1/reduce per axis (point sampling, as Downsample: ⌈w/r⌉ × ⌈h/r⌉); a proxy evaluation multiplies it.").proxy_reduction(),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "ImageInput",
    category: "Input/Output",
    doc: "Reads an EXR or PNG file as Image, Scalar, ShadowMap or Depth.",
    inputs: &[],
    outputs: &[
        PortSpec::output("image", &[PortType::Image], "RGBA (grey files: value in R, G, B, alpha 1)."),
        PortSpec::output("scalar", &[PortType::Scalar], "One channel (see `channel`)."),
        PortSpec::output("shadow", &[PortType::ShadowMap], "The one channel as a shadow map with identity matrices."),
        PortSpec::output("depth", &[PortType::Depth], "The one channel as linear depth with identity matrices."),
    ],
    params: Params::SPECS,
})
.files(&[("path", tyndall_engine::eval::FileRole::Read)])
.shaders(&[SHADER])
.uniforms(&[ImageInputParams::LAYOUT])
.colour();

const SHADER: Shader = crate::shader("image_input", include_str!("../shaders/image_input.wgsl"));

tyndall_engine::uniforms! {
    /// Uniforms of `shaders/image_input.wgsl` (struct `Params`).
    pub struct ImageInputParams as "Params" {
        /// Channels in the uploaded file data (1 or 4).
        pub channels: u32,
        /// [`Channel`] code.
        pub channel: u32,
        /// Padding.
        pub _pad0: u32,
        /// Padding.
        pub _pad1: u32,
    }
}

/// Rec. 709 luminance weights.
pub const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// CPU reference: the (image, scalar) pair produced from a file's raster.
pub fn reference(file: &Raster, channel: Channel) -> (Raster, Raster) {
    let n = (file.width * file.height) as usize;
    let mut image = Raster::new(file.width, file.height, 4, 0.0);
    let mut scalar = Raster::new(file.width, file.height, 1, 0.0);
    let ch = channel as usize;
    for i in 0..n {
        let px: [f32; 4] = if file.channels == 1 {
            let v = file.data[i];
            [v, v, v, 1.0]
        } else {
            let p = &file.data[i * 4..i * 4 + 4];
            [p[0], p[1], p[2], p[3]]
        };
        image.data[i * 4..i * 4 + 4].copy_from_slice(&px);
        scalar.data[i] = if file.channels == 1 {
            file.data[i]
        } else if ch == 0 {
            px[0] * LUMA[0] + px[1] * LUMA[1] + px[2] * LUMA[2]
        } else {
            px[ch - 1]
        };
    }
    (image, scalar)
}

/// The camera of an EXR header (`worldToCamera`, `worldToNDC`: Imath's row-vector layout, which
/// is glam's column-major array), far = the largest finite depth of a one-channel `file`.
fn header_camera(h: &tyndall_engine::io::ExrHeader, file: &Raster) -> Option<Matrices> {
    let view = glam::Mat4::from_cols_array(&h.world_to_camera?);
    let ndc = glam::Mat4::from_cols_array(&h.world_to_ndc?);
    if view.determinant().abs() < 1e-12 {
        return None;
    }
    let far = if file.channels == 1 {
        file.data
            .iter()
            .filter(|v| v.is_finite() && **v < 1e9)
            .fold(0.0f32, |a, b| a.max(*b))
    } else {
        0.0
    };
    Some(Matrices {
        view: view.to_cols_array_2d(),
        proj: (ndc * view.inverse()).to_cols_array_2d(),
        far: if far > 0.0 { far } else { 1000.0 },
        radiance: [0.0; 3],
        local: None,
    })
}

/// The colour space an RGBA file at `path` is in: `named` when set, else the config's file
/// rules (Tyndall's rule with the built-in config: EXR linear Rec.709, PNG sRGB-encoded).
pub fn file_colour_space(
    colour: &ColourCtx,
    named: &str,
    path: &Path,
) -> Result<String, NodeError> {
    let config = colour
        .config("")
        .map_err(crate::algorithms::ocio::param_error("colourspace"))?;
    let name = if !named.trim().is_empty() {
        named.trim().to_string()
    } else if config.source() == tyndall_engine::colour::BUILTIN {
        match tyndall_engine::io::file_kind(path)? {
            tyndall_engine::io::FileKind::Exr => tyndall_engine::colour::WORKING_SPACE,
            tyndall_engine::io::FileKind::Png => SRGB_ENCODED,
        }
        .to_string()
    } else {
        config
            .ocio()
            .color_space_from_filepath(&path.to_string_lossy())
    };
    config
        .colour_space(&name, colour.working_space())
        .map_err(crate::algorithms::ocio::param_error("colourspace"))
}

/// The sRGB-encoded Rec.709 colour space of the built-in config (PNGs' file rule).
pub const SRGB_ENCODED: &str = "sRGB Encoded Rec.709 (sRGB)";

/// Whether reading `path` as `space` into the working space is the reading of old: the sRGB
/// decoding of a PNG (or nothing, for an EXR) in the default working space.
fn plain_reading(colour: &ColourCtx, space: &str, path: &Path) -> bool {
    colour.is_default_space()
        && match tyndall_engine::io::file_kind(path) {
            Ok(tyndall_engine::io::FileKind::Png) => space == SRGB_ENCODED,
            Ok(tyndall_engine::io::FileKind::Exr) => space == tyndall_engine::colour::WORKING_SPACE,
            Err(_) => false,
        }
}

impl NodeKind for ImageInput {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn volatile_key(&self, key: &tyndall_engine::eval::KeyInput) -> u64 {
        // An image sequence: each frame is another file (and that file's stamp).
        match Params::from_params(key.params) {
            Ok(p) if tyndall_engine::eval::with_frame(&p.path, 0).is_some() => {
                let path = super::util::frame_path(&p.path, None, key.time);
                key.time.round().to_bits() ^ tyndall_engine::eval::file_stamp(Path::new(&path))
            }
            _ => 0,
        }
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let prm = Params::from_ctx(ctx)?;
        let path = super::util::frame_path(&prm.path, ctx.frame, ctx.time);
        let path = path.as_str();
        if path.is_empty() {
            return Err(NodeError::Param {
                param: "path".into(),
                message: "is empty: set the file to read".into(),
            });
        }
        // The OpenColorIO conversion to the working space, unless the file is data or read as
        // it always was.
        let convert = if prm.srgb {
            let space = file_colour_space(ctx.colour, &prm.colourspace, Path::new(path))?;
            if plain_reading(ctx.colour, &space, Path::new(path)) {
                None
            } else {
                let to = ctx.colour.working_space().to_string();
                let processor =
                    crate::algorithms::ocio::colour_space_processor(ctx.colour, "", &space, &to)?;
                Some(crate::algorithms::ocio::prepare(&processor, "colourspace")?)
            }
        } else {
            None
        };
        let (file, header) = if prm.layer.trim().is_empty() {
            (
                tyndall_engine::io::read_image(Path::new(path), prm.srgb && convert.is_none())?,
                None,
            )
        } else {
            if tyndall_engine::io::file_kind(Path::new(path))? != tyndall_engine::io::FileKind::Exr
            {
                return Err(NodeError::Param {
                    param: "layer".into(),
                    message: format!(
                        "is '{}', but {path} is not an EXR (only EXR files have layers)",
                        prm.layer
                    ),
                });
            }
            tyndall_engine::io::read_exr_layer(Path::new(path), prm.layer.trim())?
        };
        let mut file = file;
        if convert.is_some()
            && file.channels == 1
            && matches!(
                tyndall_engine::io::file_kind(Path::new(path)),
                Ok(tyndall_engine::io::FileKind::Png)
            )
        {
            // A grey PNG is data, decoded as `srgb` says (read raw above for the conversion).
            file.data
                .iter_mut()
                .for_each(|v| *v = tyndall_engine::io::srgb_to_linear(*v));
        }
        let camera = header.and_then(|h| header_camera(&h, &file));
        let file = if prm.reduce > 1 {
            crate::algorithms::point_sample::reference(&file, prm.reduce as u32)
        } else {
            file
        };
        let channel = prm.channel;
        let src = ctx
            .gpu
            .upload(file.width, file.height, file.channels, &file.data)?;
        let src = match &convert {
            Some(pass) if file.channels == 4 => {
                crate::algorithms::ocio::apply(ctx.gpu, pass, &src)?
            }
            _ => src,
        };
        let u = ImageInputParams {
            channels: file.channels,
            channel: channel as u32,
            _pad0: 0,
            _pad1: 0,
        };
        let (w, h) = (file.width, file.height);
        if ctx.wants("image") {
            let out = ctx.gpu.texture(w, h, TexFormat::Rgba32F)?;
            ctx.gpu.dispatch(
                SHADER,
                "to_image",
                &[
                    ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                    ("src", Bind::Texture(&src)),
                    ("out_image", Bind::Storage(&out)),
                ],
                w,
                h,
            )?;
            ctx.set("image", PortValue::Image(Arc::new(out)));
        }
        if ["scalar", "shadow", "depth"].iter().any(|p| ctx.wants(p)) {
            let out = ctx.gpu.texture(w, h, TexFormat::R32F)?;
            ctx.gpu.dispatch(
                SHADER,
                "to_scalar",
                &[
                    ("P", Bind::Uniform(bytemuck::bytes_of(&u))),
                    ("src", Bind::Texture(&src)),
                    ("out_scalar", Bind::Storage(&out)),
                ],
                w,
                h,
            )?;
            let out = Arc::new(out);
            ctx.set("scalar", PortValue::Scalar(out.clone()));
            ctx.set(
                "shadow",
                PortValue::ShadowMap(out.clone(), Matrices::default()),
            );
            ctx.set("depth", PortValue::Depth(out, camera.unwrap_or_default()));
        }
        Ok(())
    }
}
