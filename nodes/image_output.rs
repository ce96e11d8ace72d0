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
//! | `display`, `view`, `look` | Text | "" | PNG: write through this OpenColorIO display / view / look of the evaluation's config (from the working space) instead of the plain sRGB encoding; all empty: the sRGB encoding (= the built-in config's `sRGB - Display` / `Un-tone-mapped`, within an 8-bit step) of the image converted to linear Rec.709 |
//!
//! Colour (issue #45): an EXR stays scene-linear in the graph's working space; in a working
//! space other than the default it carries that space's standard `chromaticities` attribute
//! (an EXR without one means Rec.709 / D65, the default's, so default files are unchanged).
//!
//! `path`, `precision`, `srgb`, `display`, `view` and `look` only affect the file (the view is
//! applied as it is written), so changing them does not re-run the sanitizing pass (they are
//! exempt from the cache key).
//!
//! `AovOutput` (same file, same pass): the compositing hand-off. It writes every connected port
//! as a named layer of one single-part EXR, the way Nuke and Blender read layers: `rgba` as
//! plain `R`, `G`, `B`, `A`; `inscatter` as `inscatter.R/G/B`; `visibility` and `transmittance`
//! as `NAME.Y`; `depth` as `depth.Z`; two free slots `aov1`, `aov2` named by parameters (an
//! Image as `.R/G/B/A`, a Scalar as `.Y`, Depth or ShadowMap as `.Z`). Layers are half floats
//! unless listed in `float_layers` (default: depth, whose metres need more than half's 11 bits);
//! the header carries the camera's `worldToCamera` and `worldToNDC` matrices (from `depth`, or
//! the first connected Depth), the frame (`frame`, int) and, as `ImageOutput`'s, the working
//! space's `chromaticities`.
//!
//! | port | dir | type |
//! |---|---|---|
//! | `rgba` | in | Image (optional) — the beauty |
//! | `visibility` | in | Scalar (optional) |
//! | `depth` | in | Depth (optional) |
//! | `inscatter` | in | Image (optional) |
//! | `transmittance` | in | Scalar (optional) |
//! | `aov1`, `aov2` | in | Image \| Scalar \| ShadowMap \| Depth (optional) |
//! | `layers` | in | Layers (optional) — layers written as they are named, always 32-bit where the producer asks (Cryptomatte's IDs), with their header attributes |
//!
//! | param | type | default | |
//! |---|---|---|---|
//! | `path` | Text | "out/aovs.exr" | the .exr file to write |
//! | `precision` | Enum | half | half or float: storage of the layers not in `float_layers` |
//! | `float_layers` | Text | "depth" | comma-separated layers always stored as 32-bit floats |
//! | `aov1_name`, `aov2_name` | Text | "aov1", "aov2" | layer names of the free slots |

use std::collections::BTreeMap;
use std::sync::Arc;

use tyndall_engine::eval::{
    download, download_later, NodeDecl, NodeError, NodeKind, PortValue, RunCtx,
};
use tyndall_engine::gpu::{Bind, Shader, TexFormat};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::io::{
    file_kind, write_exr_layers, write_image_later, ExrHeader, ExrLayer, FileKind, Precision,
    Raster,
};

/// The `ImageOutput` node kind.
pub struct ImageOutput;

/// Names of the `precision` parameter.
pub const PRECISIONS: &[&str] = Storage::NAMES;

tyndall_engine::choice_enum! {
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
tyndall_engine::params! {
    /// `ImageOutput`'s parameters.
    pub struct OutParams {
        path: String = ParamSpec::text("path", "out.exr", "File to write (.exr or .png)."),
        precision: Storage = ParamSpec::choice("precision", Storage::NAMES, "auto", "Sample storage: auto (EXR f32, PNG u8), f32, f16, u8, u16."),
        srgb: bool = ParamSpec::flag("srgb", true, "Encode PNG colour to sRGB; turn off for data maps."),
        display: String = ParamSpec::text("display", "", "PNG: an OpenColorIO display to write for (with `view`, `look`) instead of the plain sRGB encoding; empty with `view` empty: the sRGB encoding, which is the built-in config's sRGB - Display / Un-tone-mapped."),
        view: String = ParamSpec::text("view", "", "PNG: the display's view (e.g. ACES 2.0 - SDR 100 nits (Rec.709)); empty: the display's default when `display` is set."),
        look: String = ParamSpec::text("look", "", "PNG: a look applied before the view; empty: none."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "ImageOutput",
    category: "Input/Output",
    doc: "Writes its input to an EXR (f32/f16) or PNG (8/16-bit) file; NaN/Inf become 0.",
    inputs: &[PortSpec::required("image", ANY, "What to write.")],
    outputs: &[],
    params: OutParams::SPECS,
})
.shaders(&[SHADER])
.key_exempt(&["path", "precision", "srgb", "display", "view", "look"])
.colour()
.files(&[("path", tyndall_engine::eval::FileRole::Write)])
.sink();

const SHADER: Shader = crate::shader("image_output", include_str!("../shaders/image_output.wgsl"));

/// The texture on input `port` with non-finite samples replaced by 0 (the GPU pass), as a Scalar
/// or an Image.
fn sanitized(ctx: &RunCtx, port: &str) -> Result<PortValue, NodeError> {
    let tex = ctx.require_texture(port)?;
    let (entry, slot) = match tex.format {
        TexFormat::R32F => ("sanitize_scalar", "out_scalar"),
        TexFormat::Rgba32F => ("sanitize_image", "out_image"),
        TexFormat::Rg32F => {
            return Err(NodeError::Input {
                port: port.into(),
                message: "has an internal two-channel format".into(),
            })
        }
    };
    let out = ctx.gpu.texture(tex.width, tex.height, tex.format)?;
    ctx.gpu.dispatch(
        SHADER,
        entry,
        &[("src", Bind::Texture(&tex)), (slot, Bind::Storage(&out))],
        tex.width,
        tex.height,
    )?;
    Ok(super::util::image_like(Arc::new(out)))
}

/// The file a sink writes: its `path` (not empty) named for the wedge and frame.
fn file_to_write(ctx: &RunCtx, path: &str) -> Result<std::path::PathBuf, NodeError> {
    if path.is_empty() {
        return Err(NodeError::Param {
            param: "path".into(),
            message: "is empty: set the file to write".into(),
        });
    }
    Ok(ctx.suffixed(path))
}

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
        let value = sanitized(ctx, "image")?;
        ctx.set("written", value);
        Ok(())
    }

    fn commit(&self, ctx: &RunCtx, outputs: &BTreeMap<String, PortValue>) -> Result<(), NodeError> {
        let p = OutParams::from_ctx(ctx)?;
        let path = file_to_write(ctx, &p.path)?;
        let precision = resolve_precision(&path, p.precision)?;
        let value = outputs
            .get("written")
            .ok_or_else(|| NodeError::Other("no sanitized image to write".into()))?;
        // Read back while the next frame is recorded when writes are deferred (a sequence).
        let viewed;
        let mut srgb = p.srgb;
        let value = match view_for_png(ctx, &p, &path)? {
            Some((pass, encode)) => {
                srgb = encode;
                let tex = value
                    .texture()
                    .ok_or_else(|| NodeError::Other("no image to view".into()))?;
                viewed = PortValue::Image(Arc::new(crate::algorithms::ocio::apply(
                    ctx.gpu, &pass, tex,
                )?));
                &viewed
            }
            None => value,
        };
        let pending = download_later(ctx.gpu, value)?;
        let raster = Box::new(move || pending.wait().map_err(|e| e.to_string()));
        write_image_later(&path, raster, precision, srgb, chromaticities(ctx)?)?;
        Ok(())
    }
}

/// The OpenColorIO pass a PNG is written through, and whether the sRGB encoding follows it.
/// With `display` or `view` set: that display / view / look of the evaluation's config from
/// the working space, already encoded. Both empty: nothing in the default working space (the
/// plain sRGB encoding, = `sRGB - Display` / `Un-tone-mapped`); in another working space, its
/// conversion to linear Rec.709 before that encoding. None for an EXR (scene-linear in the
/// working space) or `srgb = false` (data written raw).
fn view_for_png(
    ctx: &RunCtx,
    p: &OutParams,
    path: &std::path::Path,
) -> Result<Option<(crate::algorithms::ocio::OcioPass, bool)>, NodeError> {
    if !p.srgb || !matches!(file_kind(path), Ok(FileKind::Png)) {
        return Ok(None);
    }
    use crate::algorithms::ocio;
    if p.display.is_empty() && p.view.is_empty() {
        if ctx.colour.is_default_space() {
            return Ok(None);
        }
        let to_rec709 = ocio::colour_space_processor(
            ctx.colour,
            "",
            "",
            tyndall_engine::colour::WORKING_SPACE,
        )?;
        return ocio::prepare(&to_rec709, "path").map(|pass| Some((pass, true)));
    }
    let processor = ocio::display_view_processor(ctx.colour, "", "", &p.display, &p.view, &p.look)?;
    ocio::prepare(&processor, "view").map(|pass| Some((pass, false)))
}

/// An EXR's `chromaticities` attribute: the working space's, when it is not the default.
fn chromaticities(ctx: &RunCtx) -> Result<Option<[f32; 8]>, NodeError> {
    ctx.colour
        .chromaticities()
        .map_err(crate::algorithms::ocio::param_error("path"))
}

/// The `AovOutput` node kind: connected ports as named layers of one EXR.
pub struct AovOutput;

/// Names of `AovOutput`'s `precision` parameter.
pub const LAYER_PRECISIONS: &[&str] = LayerStorage::NAMES;

tyndall_engine::choice_enum! {
    /// `AovOutput`'s `precision`: storage of the layers not listed in `float_layers`.
    pub enum LayerStorage { Half = "half", Float = "float" }
}

/// `AovOutput`'s named ports (besides the free slots `aov1`, `aov2`), in layer order.
const LAYERS: &[&str] = &["rgba", "visibility", "depth", "inscatter", "transmittance"];

#[rustfmt::skip]
tyndall_engine::params! {
    /// `AovOutput`'s parameters.
    pub struct AovParams {
        path: String = ParamSpec::text("path", "out/aovs.exr", "The .exr file to write."),
        precision: LayerStorage = ParamSpec::choice("precision", LayerStorage::NAMES, "half", "Storage of the layers not in float_layers: half (16-bit) or float (32-bit)."),
        float_layers: String = ParamSpec::text("float_layers", "depth", "Comma-separated layers always stored as 32-bit floats."),
        aov1_name: String = ParamSpec::text("aov1_name", "aov1", "Layer name of the aov1 slot."),
        aov2_name: String = ParamSpec::text("aov2_name", "aov2", "Layer name of the aov2 slot."),
    }
}

#[rustfmt::skip]
static AOV_DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "AovOutput",
    category: "Input/Output",
    doc: "Writes every connected port as a named layer of one multi-layer EXR (rgba, visibility, depth, inscatter, transmittance, two free slots) with the camera matrices and frame in the header, for Nuke and Blender.",
    inputs: &[
        PortSpec::input("rgba", &[PortType::Image], "The beauty, written as plain R, G, B, A."),
        PortSpec::input("visibility", &[PortType::Scalar], "Average visibility V̄ (layer visibility.Y)."),
        PortSpec::input("depth", &[PortType::Depth], "Camera depth, m (layer depth.Z); its camera fills the header's matrices."),
        PortSpec::input("inscatter", &[PortType::Image], "In-scattered radiance, W/(m²·sr) (layer inscatter.R/G/B)."),
        PortSpec::input("transmittance", &[PortType::Scalar], "Transmittance (layer transmittance.Y)."),
        PortSpec::input("aov1", ANY, "Any image-like port, as layer `aov1_name`."),
        PortSpec::input("aov2", ANY, "Any image-like port, as layer `aov2_name`."),
        PortSpec::input("layers", &[PortType::Layers], "Named layers and their header attributes (Cryptomatte), written as named."),
    ],
    outputs: &[],
    params: AovParams::SPECS,
})
.shaders(&[SHADER])
.key_exempt(&["path", "precision", "float_layers", "aov1_name", "aov2_name"])
.colour()
.files(&[("path", tyndall_engine::eval::FileRole::Write)])
.sink();

/// Channel names of the layer on `port` holding `value` (`inscatter` has no alpha).
fn channel_names(port: &str, value: &PortValue) -> &'static [&'static str] {
    match value {
        PortValue::Image(_) if port == "inscatter" => &["R", "G", "B"],
        PortValue::Image(_) => &["R", "G", "B", "A"],
        PortValue::Depth(..) | PortValue::ShadowMap(..) => &["Z"],
        _ => &["Y"],
    }
}

impl NodeKind for AovOutput {
    fn decl(&self) -> &'static NodeDecl {
        &AOV_DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let connected: Vec<&str> = LAYERS
            .iter()
            .chain(&["aov1", "aov2"])
            .copied()
            .filter(|p| ctx.input(p).is_some())
            .collect();
        if let Some(set) = ctx.input("layers").cloned() {
            // Written as they are (IDs are bit patterns: no sanitizing pass may touch them).
            ctx.set("layers", set);
        } else if connected.is_empty() {
            return Err(NodeError::Input {
                port: "rgba".into(),
                message: "nothing to write: connect at least one port".into(),
            });
        }
        for port in connected {
            let value = sanitized(ctx, port)?;
            ctx.set(port, value);
        }
        Ok(())
    }

    fn commit(&self, ctx: &RunCtx, outputs: &BTreeMap<String, PortValue>) -> Result<(), NodeError> {
        let p = AovParams::from_ctx(ctx)?;
        let path = file_to_write(ctx, &p.path)?;
        let half = p.precision == LayerStorage::Half;
        let floats: Vec<String> = p
            .float_layers
            .split(',')
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty())
            .collect();
        let mut size = None;
        let mut layers = Vec::new();
        let mut text = Vec::new();
        for (port, written) in outputs {
            if let PortValue::Layers(set) = written {
                for layer in &set.layers {
                    let raster = download(ctx.gpu, &PortValue::Image(layer.texture.clone()))?;
                    same_size(&mut size, &raster, "layers")?;
                    layers.push(ExrLayer {
                        half: half && !layer.float && !floats.contains(&layer.name),
                        name: layer.name.clone(),
                        channels: split_channels(&raster, &layer.channels),
                    });
                }
                text.extend(set.attributes.iter().cloned());
                continue;
            }
            let name = match port.as_str() {
                "aov1" => p.aov1_name.trim().to_string(),
                "aov2" => p.aov2_name.trim().to_string(),
                other => other.to_string(),
            };
            if name.is_empty() || name.contains('.') {
                return Err(NodeError::Param {
                    param: format!("{port}_name"),
                    message: format!("'{name}' is not a layer name (non-empty, no '.')"),
                });
            }
            let original = ctx.input(port).unwrap_or(written);
            let raster = download(ctx.gpu, written)?;
            same_size(&mut size, &raster, port)?;
            let names: Vec<String> = channel_names(port, original)
                .iter()
                .map(|c| c.to_string())
                .collect();
            layers.push(ExrLayer {
                half: half && !floats.contains(&name),
                name,
                channels: split_channels(&raster, &names),
            });
        }
        // The rgba layer first, then the rest in port order (BTreeMap: alphabetical).
        layers.sort_by_key(|l| l.name != "rgba");
        let camera = ctx
            .input("depth")
            .into_iter()
            .chain(["aov1", "aov2"].iter().filter_map(|p| ctx.input(p)))
            .find_map(|v| match v {
                PortValue::Depth(_, m) => Some(*m),
                _ => None,
            });
        let header = ExrHeader {
            world_to_camera: camera
                .map(|m| glam::Mat4::from_cols_array_2d(&m.view).to_cols_array()),
            world_to_ndc: camera.map(|m| m.view_proj().to_cols_array()),
            frame: Some(ctx.time.round() as i32),
            chromaticities: chromaticities(ctx)?,
            text,
        };
        let size = size.unwrap_or((1, 1));
        write_exr_layers(&path, size, &layers, &header)?;
        Ok(())
    }
}

/// Hold every layer to the first one's size (`size`), naming `port` when one differs.
fn same_size(size: &mut Option<(u32, u32)>, raster: &Raster, port: &str) -> Result<(), NodeError> {
    let dims = (raster.width, raster.height);
    let first = *size.get_or_insert(dims);
    if first != dims {
        return Err(NodeError::Input {
            port: port.into(),
            message: format!(
                "is {}×{}, other layers are {}×{}: every layer needs the same size",
                dims.0, dims.1, first.0, first.1
            ),
        });
    }
    Ok(())
}

/// The channels of `raster` as `(name, samples)`, one per name (a name past the raster's
/// channels repeats its last one).
fn split_channels(raster: &Raster, names: &[String]) -> Vec<(String, Vec<f32>)> {
    let c = raster.channels as usize;
    names
        .iter()
        .enumerate()
        .map(|(i, ch)| {
            let k = i.min(c - 1);
            (ch.clone(), raster.data.chunks(c).map(|p| p[k]).collect())
        })
        .collect()
}
