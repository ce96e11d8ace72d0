//! Deep EXR (issue #62): a deep scan-line file whose pixels hold samples along the view ray —
//! slabs of the medium (from `Z` to `ZBack`) and surfaces (`Z` = `ZBack`) — that Nuke's deep
//! tools and OpenImageIO (`oiiotool --flatten`) read. Written through the exr crate's block API
//! (`vendor/exr/PATCHES.md`: the release refused deep headers), one scan line per chunk,
//! uncompressed (the crate has no deep compressor).

use std::path::Path;

use exr::block::chunk::{Chunk, CompressedBlock, CompressedDeepScanLineBlock};
use exr::block::writer::ChunksWriter;
use exr::meta::attribute::{ChannelDescription, LineOrder, SampleType, Text};
use exr::meta::header::Header;
use exr::meta::BlockDescription;

use super::{write_via_temp, IoError};

/// One sample of a deep pixel: what lies between the depths `z` and `z_back` (metres along the
/// view ray; a surface has `z == z_back`), its colour premultiplied by its alpha, and its alpha
/// (a slab of medium: 1 − its transmittance; an opaque surface: 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeepSample {
    /// Front depth, m.
    pub z: f32,
    /// Back depth, m (≥ `z`).
    pub z_back: f32,
    /// Premultiplied R, G, B and alpha.
    pub rgba: [f32; 4],
}

/// The flat picture of a deep pixel: its samples composited front to back with `over`
/// (C = Σ cᵢ Πⱼ<ᵢ (1 − aⱼ)), as `oiiotool --flatten` does; RGBA.
pub fn flatten(samples: &[DeepSample]) -> [f32; 4] {
    let mut out = [0.0f32; 4];
    let mut through = 1.0f32;
    for s in samples {
        for (o, c) in out.iter_mut().zip(s.rgba) {
            *o += through * c;
        }
        through *= 1.0 - s.rgba[3];
    }
    out
}

/// The channels in the file's order (sorted by name) and which value of a sample each holds.
const CHANNELS: [(&str, usize); 6] = [
    ("A", 3),
    ("B", 2),
    ("G", 1),
    ("R", 0),
    ("Z", 4),
    ("ZBack", 5),
];

/// Write `pixels` (each pixel's samples front to back, rows top to bottom, `width × height` of
/// them) as a deep scan-line EXR with channels `R G B A Z ZBack` in 32-bit floats, atomically.
/// Samples must be finite with `z ≤ z_back`.
pub fn write_deep_exr(
    path: &Path,
    (width, height): (u32, u32),
    pixels: &[Vec<DeepSample>],
) -> Result<(), IoError> {
    let err = |reason: String| IoError::Write {
        path: path.to_path_buf(),
        reason,
    };
    super::exr_out::require_exr(path, "a deep image")?;
    let (w, h) = (width as usize, height as usize);
    if pixels.len() != w * h || w == 0 || h == 0 {
        return Err(err(format!(
            "{} pixels for a {width}×{height} deep image",
            pixels.len()
        )));
    }
    if let Some(bad) = pixels.iter().flatten().find(|s| {
        !(s.z.is_finite() && s.z_back.is_finite() && s.rgba.iter().all(|v| v.is_finite()))
            || s.z > s.z_back
    }) {
        return Err(err(format!(
            "a sample is not finite or ends before it starts: {bad:?}"
        )));
    }
    crate::trace::write(path, || {
        write_via_temp(path, |tmp| write_deep(tmp, (w, h), pixels))
    })
}

/// One scan line's chunk: the running sample counts, then each channel's samples of every pixel.
fn line_block(y: usize, row: &[Vec<DeepSample>]) -> Result<CompressedDeepScanLineBlock, String> {
    let mut table = Vec::with_capacity(row.len() * 4);
    let mut total = 0i32;
    for p in row {
        total = total
            .checked_add(i32::try_from(p.len()).map_err(|e| e.to_string())?)
            .ok_or("too many samples in one line")?;
        table.extend(total.to_le_bytes().map(|b| b as i8));
    }
    let mut data = Vec::with_capacity(total as usize * CHANNELS.len() * 4);
    for (_, k) in CHANNELS {
        for s in row.iter().flatten() {
            let v = [s.rgba[0], s.rgba[1], s.rgba[2], s.rgba[3], s.z, s.z_back][k];
            data.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(CompressedDeepScanLineBlock {
        y_coordinate: i32::try_from(y).map_err(|e| e.to_string())?,
        decompressed_sample_data_size: data.len(),
        compressed_pixel_offset_table: table,
        compressed_sample_data_le: data,
    })
}

fn write_deep(
    tmp: &Path,
    (w, h): (usize, usize),
    pixels: &[Vec<DeepSample>],
) -> Result<(), String> {
    let channels = CHANNELS
        .iter()
        .map(|(n, _)| ChannelDescription::new(Text::from(*n), SampleType::F32, false))
        .collect();
    let mut header = Header::new(Text::from("deep"), (w, h), channels);
    header.compression = exr::compression::Compression::Uncompressed;
    header.blocks = BlockDescription::ScanLines;
    header.line_order = LineOrder::Increasing;
    header.deep = true;
    header.deep_data_version = Some(1);
    header.max_samples_per_pixel = Some(pixels.iter().map(Vec::len).max().unwrap_or(0));
    header.chunk_count = h;
    header.own_attributes.software_name = Some(Text::from("Tyndall"));
    // Every line gets its chunk, an empty one too (its table of zeros, no samples).
    let blocks = pixels
        .chunks(w)
        .enumerate()
        .map(|(y, row)| line_block(y, row))
        .collect::<Result<Vec<_>, _>>()?;
    let file = std::fs::File::create(tmp).map_err(|e| e.to_string())?;
    let write = std::io::BufWriter::new(file);
    let headers = exr::prelude::SmallVec::from_vec(vec![header]);
    exr::block::writer::write_chunks_with(write, headers, true, |_, out| {
        for (y, block) in blocks.into_iter().enumerate() {
            out.write_chunk(
                y,
                Chunk {
                    layer_index: 0,
                    compressed_block: CompressedBlock::DeepScanLine(block),
                },
            )?;
        }
        Ok(())
    })
    .map_err(|e| e.to_string())
}
