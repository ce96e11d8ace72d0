//! Writing EXR files: one picture (`write_exr`, what `write_image` uses for `.exr`) or several
//! named layers with a header (`write_exr_layers`: `AovOutput`, multi-layer renders).

use std::path::Path;

use exr::prelude::{self as exrp, WritableImage};

use super::{file_kind, write_via_temp, FileKind, IoError, Raster};

/// One layer of a multi-layer EXR: channel names are written as `layer.channel` (the layer
/// `rgba` as plain `R`, `G`, `B`, `A`, as Nuke and Blender expect the main image).
#[derive(Clone, Debug)]
pub struct ExrLayer {
    /// Layer name (`rgba`, `depth`, `visibility`, …).
    pub name: String,
    /// Channel names within the layer (`R`, `G`, `B`, `A`, `Y`, `Z`) and their samples (rows top
    /// to bottom, one value per pixel).
    pub channels: Vec<(String, Vec<f32>)>,
    /// Store as 16-bit half floats (else 32-bit floats).
    pub half: bool,
}

/// Header data of a multi-layer EXR: the standard `worldToCamera` and `worldToNDC` matrices
/// (Imath layout: row vectors, so glam's column-major array), and the frame number as an `int`
/// attribute `frame`.
#[derive(Clone, Debug, Default)]
pub struct ExrHeader {
    /// World → camera (view) matrix.
    pub world_to_camera: Option<[f32; 16]>,
    /// World → normalised device coordinates (projection × view).
    pub world_to_ndc: Option<[f32; 16]>,
    /// Frame number.
    pub frame: Option<i32>,
    /// The standard `chromaticities` attribute, `[rx, ry, gx, gy, bx, by, wx, wy]`; `None`:
    /// not written (Rec.709 / D65, what an EXR without it means).
    pub chromaticities: Option<[f32; 8]>,
    /// String attributes (`cryptomatte/<key>/manifest` …), written as UTF-8 bytes, in order.
    pub text: Vec<(String, String)>,
}

/// An EXR string: its UTF-8 bytes (the exr crate's `Text::from` panics on characters above
/// U+00FF, and a glTF object's name may hold any).
fn exr_text(s: &str) -> exrp::Text {
    exrp::Text::from_bytes_unchecked(exrp::SmallVec::from_slice(s.as_bytes()))
}

/// The exr crate's form of a `chromaticities` attribute.
fn exr_chromaticities(c: [f32; 8]) -> exr::meta::attribute::Chromaticities {
    let v = |i: usize| exr::math::Vec2(c[i], c[i + 1]);
    exr::meta::attribute::Chromaticities {
        red: v(0),
        green: v(2),
        blue: v(4),
        white: v(6),
    }
}

/// Write a `width × height` single-part EXR with the named layers (atomically; non-finite
/// samples become 0). Every channel must hold `width × height` samples.
pub fn write_exr_layers(
    path: &Path,
    size: (u32, u32),
    layers: &[ExrLayer],
    header: &ExrHeader,
) -> Result<(), IoError> {
    crate::trace::write(path, || {
        write_exr_layers_untraced(path, size, layers, header)
    })
}

fn write_exr_layers_untraced(
    path: &Path,
    (width, height): (u32, u32),
    layers: &[ExrLayer],
    header: &ExrHeader,
) -> Result<(), IoError> {
    let err = |reason: String| IoError::Write {
        path: path.to_path_buf(),
        reason,
    };
    require_exr(path, "a multi-layer image")?;
    let n = (width * height) as usize;
    let mut list: Vec<exrp::AnyChannel<exrp::FlatSamples>> = Vec::new();
    for layer in layers {
        for (channel, samples) in &layer.channels {
            if samples.len() != n {
                return Err(err(format!(
                    "layer {} channel {channel}: {} samples for a {width}×{height} image",
                    layer.name,
                    samples.len()
                )));
            }
            let clean = samples.iter().map(|v| if v.is_finite() { *v } else { 0.0 });
            let data = if layer.half {
                exrp::FlatSamples::F16(clean.map(exrp::f16::from_f32).collect())
            } else {
                exrp::FlatSamples::F32(clean.collect())
            };
            let name = if layer.name == "rgba" {
                channel.clone()
            } else {
                format!("{}.{channel}", layer.name)
            };
            list.push(exrp::AnyChannel::new(exr_text(&name), data));
        }
    }
    let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
    if let Some(dup) = names
        .iter()
        .enumerate()
        .find(|(i, a)| names[..*i].contains(a))
    {
        return Err(err(format!("channel {} appears twice", dup.1)));
    }
    let mut attributes = exrp::LayerAttributes {
        world_to_camera: header.world_to_camera,
        world_to_normalized_device: header.world_to_ndc,
        software_name: Some(exrp::Text::from("Tyndall")),
        ..Default::default()
    };
    for (key, value) in &header.text {
        if key.is_empty() || key.len() > 255 {
            return Err(err(format!(
                "header attribute name '{key}' must hold 1 to 255 bytes"
            )));
        }
        attributes.other.insert(
            exr_text(key),
            exr::meta::attribute::AttributeValue::Text(exr_text(value)),
        );
    }
    if let Some(frame) = header.frame {
        attributes.other.insert(
            exrp::Text::from("frame"),
            exr::meta::attribute::AttributeValue::I32(frame),
        );
    }
    let channels = exrp::AnyChannels::sort(exrp::SmallVec::from_vec(list));
    let layer = exrp::Layer::new(
        (width as usize, height as usize),
        attributes,
        // Scan lines, as compositing packages write them (the crate's default is tiles).
        exrp::Encoding {
            blocks: exrp::Blocks::ScanLines,
            line_order: exrp::LineOrder::Increasing,
            ..exrp::Encoding::FAST_LOSSLESS
        },
        channels,
    );
    let mut img = exrp::Image::from_layer(layer);
    img.attributes.chromaticities = header.chromaticities.map(exr_chromaticities);
    write_via_temp(path, |tmp| {
        img.write().to_file(tmp).map_err(|e| e.to_string())
    })
}

/// Refuse to write `what` (a multi-layer image, a deep image) to a file that is not an `.exr`.
pub(super) fn require_exr(path: &Path, what: &str) -> Result<(), IoError> {
    if file_kind(path)? != FileKind::Exr {
        return Err(IoError::Format {
            path: path.to_path_buf(),
            reason: format!("{what} must be an .exr file"),
        });
    }
    Ok(())
}

pub(super) fn write_exr(
    path: &Path,
    r: &Raster,
    half: bool,
    chromaticities: Option<[f32; 8]>,
) -> Result<(), String> {
    let (w, h) = (r.width as usize, r.height as usize);
    let samples = |c: usize| -> exrp::FlatSamples {
        let ch = r.channels as usize;
        let v: Vec<f32> = (0..w * h).map(|i| r.data[i * ch + c]).collect();
        if half {
            exrp::FlatSamples::F16(v.into_iter().map(exrp::f16::from_f32).collect())
        } else {
            exrp::FlatSamples::F32(v)
        }
    };
    let list: exrp::SmallVec<[exrp::AnyChannel<exrp::FlatSamples>; 4]> = if r.channels == 1 {
        exrp::SmallVec::from_vec(vec![exrp::AnyChannel::new("Y", samples(0))])
    } else {
        ["R", "G", "B", "A"][..r.channels as usize]
            .iter()
            .enumerate()
            .map(|(i, n)| exrp::AnyChannel::new(*n, samples(i)))
            .collect()
    };
    // Blocks in increasing order: the crate compresses them in parallel and would otherwise
    // write them as they finish, so the same picture could give different bytes (a farm
    // comparing checksums, a sequence written in the background against a frame alone).
    let layer = exrp::Layer::new(
        (w, h),
        exrp::LayerAttributes::default(),
        exrp::Encoding {
            line_order: exrp::LineOrder::Increasing,
            ..exrp::Encoding::FAST_LOSSLESS
        },
        exrp::AnyChannels::sort(list),
    );
    let mut img = exrp::Image::from_layer(layer);
    img.attributes.chromaticities = chromaticities.map(exr_chromaticities);
    img.write().to_file(path).map_err(|e| e.to_string())
}
