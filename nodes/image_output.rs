//! `ImageOutput`: writes its input to an EXR or PNG file — a sink, so it runs whenever the
//! graph's outputs are rendered.
//!
//! The GPU pass replaces non-finite samples (NaN, ±Inf) by 0, so no NaN/Inf ever reaches a file.
//! The file is written atomically (temporary file, then rename).
//!
//! | port | dir | type |
//! |---|---|---|
//! | `image` | in | Image \| Scalar \| ShadowMap \| Depth — required |
//!
//! | param | type | default | |
//! |---|---|---|---|
//! | `path` | Text | "out.exr" | file to write; the extension chooses EXR or PNG |
//! | `precision` | Enum | auto | auto (EXR f32, PNG u8), f32, f16 (EXR), u8, u16 (PNG) |
//! | `srgb` | Bool | true | encode PNG colour to sRGB (EXR stays linear) |
//!
//! `path`, `precision` and `srgb` only affect the file, so changing them does not re-run the
//! GPU pass (they are exempt from the cache key).

use std::collections::BTreeMap;
use std::sync::Arc;

use crate::eval::{download, NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use crate::gpu::{Bind, Shader, TexFormat};
use crate::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use crate::io::{file_kind, write_image, FileKind, Precision, Raster};

/// The `ImageOutput` node kind.
pub struct ImageOutput;

/// Names of the `precision` parameter.
pub const PRECISIONS: &[&str] = Storage::NAMES;

crate::choice_enum! {
    /// The `precision` parameter: how samples are stored.
    pub enum Storage { Auto = "auto", F32 = "f32", F16 = "f16", U8 = "u8", U16 = "u16" }
}

const ANY: &[PortType] = &[
    PortType::Image,
    PortType::Scalar,
    PortType::ShadowMap,
    PortType::Depth,
];

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "ImageOutput",
    category: "Input/Output",
    doc: "Writes its input to an EXR (f32/f16) or PNG (8/16-bit) file; NaN/Inf become 0.",
    inputs: &[PortSpec::required("image", ANY, "What to write.")],
    outputs: &[],
    params: &[
        ParamSpec::text("path", "out.exr", "File to write (.exr or .png)."),
        ParamSpec::choice("precision", Storage::NAMES, "auto", "Sample storage: auto (EXR f32, PNG u8), f32, f16, u8, u16."),
        ParamSpec::flag("srgb", true, "Encode PNG colour to sRGB; turn off for data maps."),
    ],
})
.shader(SHADER)
.key_exempt(&["path", "precision", "srgb"])
.sink();

const SHADER: Shader = Shader::new("image_output", include_str!("../shaders/image_output.wgsl"));

/// CPU reference of the GPU pass: non-finite samples become 0.
pub fn reference(input: &Raster) -> Raster {
    let mut out = input.clone();
    for v in &mut out.data {
        if !v.is_finite() {
            *v = 0.0;
        }
    }
    out
}

/// The storage precision for `path` given the `precision` parameter.
pub fn resolve_precision(path: &std::path::Path, storage: Storage) -> Result<Precision, NodeError> {
    let kind = file_kind(path)?;
    Ok(match (storage, kind) {
        (Storage::F32, _) | (Storage::Auto, FileKind::Exr) => Precision::F32,
        (Storage::F16, _) => Precision::F16,
        (Storage::U16, _) => Precision::U16,
        (Storage::U8, _) | (Storage::Auto, FileKind::Png) => Precision::U8,
    })
}

impl NodeKind for ImageOutput {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let tex = ctx.require_texture("image")?;
        let (entry, slot) = match tex.format {
            TexFormat::R32F => ("sanitize_scalar", 1),
            TexFormat::Rgba32F => ("sanitize_image", 2),
            TexFormat::Rg32F => {
                return Err(NodeError::Input {
                    port: "image".into(),
                    message: "has an internal two-channel format".into(),
                })
            }
        };
        let out = ctx.gpu.texture(tex.width, tex.height, tex.format)?;
        ctx.gpu.dispatch(
            SHADER,
            entry,
            &[(0, Bind::Texture(&tex)), (slot, Bind::Storage(&out))],
            tex.width,
            tex.height,
        )?;
        ctx.set("written", super::util::image_like(Arc::new(out)));
        Ok(())
    }

    fn commit(&self, ctx: &RunCtx, outputs: &BTreeMap<String, PortValue>) -> Result<(), NodeError> {
        let path = ctx.text("path")?;
        if path.is_empty() {
            return Err(NodeError::Param {
                param: "path".into(),
                message: "is empty: set the file to write".into(),
            });
        }
        let path = ctx.suffixed(path);
        let precision = resolve_precision(&path, ctx.choice("precision")?)?;
        let value = outputs
            .get("written")
            .ok_or_else(|| NodeError::Other("no sanitized image to write".into()))?;
        let raster = download(ctx.gpu, value)?;
        write_image(&path, &raster, precision, ctx.bool("srgb")?)?;
        Ok(())
    }
}
