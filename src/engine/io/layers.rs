//! Reading one layer of a multi-layer EXR (Blender/Cycles, Nuke, `AovOutput`) and the camera
//! of its header.

use std::path::Path;

use exr::prelude::{self as exrp, ReadChannels, ReadLayers};

use super::{ExrHeader, IoError, Raster, MAX_READ_TEXELS};

/// A channel name as text: its bytes as UTF-8 (what Blender and Tyndall write; the exr crate's
/// own `to_string` reads each byte as a Latin-1 character).
fn utf8(name: &exrp::Text) -> String {
    String::from_utf8_lossy(name.as_slice()).into_owned()
}

/// The one channel `layer` names: a full channel name, or a layer with a single channel.
fn layer_channel<'a>(
    chans: &'a [exrp::AnyChannel<exrp::FlatSamples>],
    layer: &str,
    names: &[String],
) -> Result<&'a exrp::AnyChannel<exrp::FlatSamples>, String> {
    let lower = format!("{layer}.").to_ascii_lowercase();
    if let Some(c) = chans
        .iter()
        .find(|c| utf8(&c.name).eq_ignore_ascii_case(layer))
    {
        return Ok(c);
    }
    let in_layer: Vec<_> = chans
        .iter()
        .filter(|c| {
            let n = utf8(&c.name).to_ascii_lowercase();
            n.strip_prefix(&lower)
                .is_some_and(|rest| !rest.contains('.'))
        })
        .collect();
    match in_layer.as_slice() {
        [c] => Ok(*c),
        [] => Err(format!(
            "no layer or channel '{layer}' (layers: {})",
            layer_names(names).join(", ")
        )),
        several => Err(format!(
            "layer '{layer}' has channels {} but no R, G, B: name one of them",
            several
                .iter()
                .map(|c| utf8(&c.name))
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// Refuse an EXR whose header claims more texels than Tyndall reads, before anything is
/// allocated (a forged size made the reader ask for 42 GB; found by fuzzing).
fn check_exr_size(path: &Path) -> Result<(), IoError> {
    let err = |reason: String| IoError::Read {
        path: path.to_path_buf(),
        reason,
    };
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| err(e.to_string()))?;
    for header in &meta.headers {
        let size = header.layer_size;
        let texels = size.width() as u64 * size.height() as u64;
        let channels = header.channels.list.len().max(1) as u64;
        if texels > MAX_READ_TEXELS || texels.saturating_mul(channels) > 4 * MAX_READ_TEXELS {
            return Err(err(format!(
                "the header claims {}×{} texels × {channels} channels, beyond the {}×{} \
                 Tyndall reads",
                size.width(),
                size.height(),
                16384,
                16384
            )));
        }
    }
    Ok(())
}

/// The layers of a multi-layer EXR's channel names: `ViewLayer.Combined.R` → `ViewLayer.Combined`
/// (channels without a dot form the unnamed layer, listed as `(main)`), in first-seen order.
fn layer_names(channels: &[String]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for c in channels {
        let layer = c
            .rsplit_once('.')
            .map_or("(main)".to_string(), |(l, _)| l.to_string());
        if !out.contains(&layer) {
            out.push(layer);
        }
    }
    out
}

/// Read one layer of an EXR, and the camera matrices of its header (`worldToCamera`,
/// `worldToNDC`, when both are present). `layer` empty: the main image as [`super::read_image`] reads
/// it. Otherwise `layer` names a layer of a multi-layer file as Blender, Cycles and Nuke write
/// them — `ViewLayer.Combined` gives its `R`,`G`,`B`(,`A`) as RGBA, a layer with one channel
/// (`ViewLayer.Depth` with its `Z`) gives that channel — or one full channel name
/// (`ViewLayer.Depth.Z`). Names compare case-insensitively. A layer that is not in the file is
/// an error listing the layers that are.
pub fn read_exr_layer(path: &Path, layer: &str) -> Result<(Raster, Option<ExrHeader>), IoError> {
    let err = |reason: String| IoError::Read {
        path: path.to_path_buf(),
        reason,
    };
    check_exr_size(path)?;
    let img = exrp::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| err(e.to_string()))?;
    let attrs = &img.layer_data.attributes;
    let header = match (attrs.world_to_camera, attrs.world_to_normalized_device) {
        (Some(c), Some(n)) => Some(ExrHeader {
            world_to_camera: Some(c),
            world_to_ndc: Some(n),
            ..Default::default()
        }),
        _ => None,
    };
    let layer_data = img.layer_data;
    let (w, h) = (layer_data.size.width(), layer_data.size.height());
    let chans = &layer_data.channel_data.list;
    let samples = |c: &exrp::AnyChannel<exrp::FlatSamples>| -> Vec<f32> {
        match &c.sample_data {
            exrp::FlatSamples::F16(v) => v.iter().map(|x| x.to_f32()).collect(),
            exrp::FlatSamples::F32(v) => v.clone(),
            exrp::FlatSamples::U32(v) => v.iter().map(|x| *x as f32).collect(),
        }
    };
    let names: Vec<String> = chans.iter().map(|c| utf8(&c.name)).collect();
    let prefix = if layer.is_empty() {
        String::new()
    } else {
        format!("{layer}.")
    };
    let find = |name: &str| {
        let full = format!("{prefix}{name}");
        chans
            .iter()
            .find(|c| utf8(&c.name).eq_ignore_ascii_case(&full))
    };
    let (width, height) = (w as u32, h as u32);
    if let (Some(r), Some(g), Some(b)) = (find("R"), find("G"), find("B")) {
        let (r, g, b) = (samples(r), samples(g), samples(b));
        let a = find("A").map(samples);
        let mut data = Vec::with_capacity(w * h * 4);
        for i in 0..w * h {
            data.extend_from_slice(&[r[i], g[i], b[i], a.as_ref().map_or(1.0, |a| a[i])]);
        }
        let raster = Raster {
            width,
            height,
            channels: 4,
            data,
        };
        return Ok((raster, header));
    }
    let one = if layer.is_empty() {
        find("Y").or_else(|| find("R")).or_else(|| {
            if chans.len() == 1 {
                chans.first()
            } else {
                None
            }
        })
    } else {
        Some(layer_channel(chans, layer, &names).map_err(err)?)
    };
    match one {
        Some(c) => Ok((
            Raster {
                width,
                height,
                channels: 1,
                data: samples(c),
            },
            header,
        )),
        None => Err(err(format!(
            "expected one channel (Y or R) or R,G,B(,A); found channels {} (a multi-layer file: set the layer, one of {})",
            names.join(", "),
            layer_names(&names).join(", ")
        ))),
    }
}
