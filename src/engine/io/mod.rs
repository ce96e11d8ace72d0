//! Image files: OpenEXR (f32 and f16; one channel `Y`/`R`, or RGB(A)) and PNG (8/16-bit,
//! grey or RGBA) read and write, through the `exr` and `image` crates.

use std::path::{Path, PathBuf};

use thiserror::Error;

mod deep;
pub mod deferred;
mod exr_out;
mod layers;
mod vdb;

pub use deep::{flatten, write_deep_exr, DeepSample};
use exr_out::write_exr;
pub use exr_out::{write_exr_layers, ExrHeader, ExrLayer};
pub use layers::read_exr_layer;
pub use vdb::{read_vdb_grid, vdb_grids, GridInfo, VdbError, VdbGrid};

/// A CPU-side float image: row-major, `channels` interleaved floats per pixel (1 or 4).
#[derive(Debug, Clone, PartialEq)]
pub struct Raster {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Channels per pixel: 1 (grey/scalar) or 4 (RGBA).
    pub channels: u32,
    /// `width * height * channels` samples, rows top to bottom.
    pub data: Vec<f32>,
}

impl Raster {
    /// A raster filled with `fill`.
    pub fn new(width: u32, height: u32, channels: u32, fill: f32) -> Self {
        Self {
            width,
            height,
            channels,
            data: vec![fill; (width * height * channels) as usize],
        }
    }

    /// The samples of pixel (x, y).
    pub fn pixel(&self, x: u32, y: u32) -> &[f32] {
        let c = self.channels as usize;
        let i = (y as usize * self.width as usize + x as usize) * c;
        &self.data[i..i + c]
    }

    /// The raster as RGBA: four channels kept, one channel becomes grey with alpha 1 (what
    /// `read_image` gives: 1 or 4 channels).
    pub fn into_rgba(self) -> Self {
        match self.channels {
            4 => self,
            _ => Raster {
                width: self.width,
                height: self.height,
                channels: 4,
                data: self.data.iter().flat_map(|v| [*v, *v, *v, 1.0]).collect(),
            },
        }
    }
}

/// How samples are stored in a written file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    /// 32-bit float (EXR).
    F32,
    /// 16-bit float (EXR).
    F16,
    /// 8-bit integer (PNG).
    U8,
    /// 16-bit integer (PNG).
    U16,
}

/// Errors reading or writing image files; each names the file.
#[derive(Debug, Error)]
pub enum IoError {
    /// The file could not be read or decoded.
    #[error("cannot read image {path}: {reason}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The file could not be encoded or written.
    #[error("cannot write image {path}: {reason}")]
    Write {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The extension is neither `.exr` nor `.png`, or the precision does not fit the format.
    #[error("{path}: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// Which file format a path's extension asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// OpenEXR.
    Exr,
    /// PNG.
    Png,
}

/// The file format for `path`, from its extension (case-insensitive).
pub fn file_kind(path: &Path) -> Result<FileKind, IoError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("exr") => Ok(FileKind::Exr),
        Some("png") => Ok(FileKind::Png),
        _ => Err(IoError::Format {
            path: path.to_path_buf(),
            reason: "unsupported image extension (use .exr or .png)".into(),
        }),
    }
}

/// sRGB transfer: encoded \[0,1\] → linear.
pub fn srgb_to_linear(v: f32) -> f32 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB transfer: linear → encoded, for values clamped to \[0,1\].
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// Read an EXR or PNG file. EXR: a single channel (any name, `Y` or `R` preferred) gives a
/// one-channel raster, `R`,`G`,`B`(,`A`) give RGBA (alpha 1 when absent). PNG: grey gives one
/// channel, anything else RGBA; with `srgb` the colour channels are decoded to linear.
pub fn read_image(path: &Path, srgb: bool) -> Result<Raster, IoError> {
    match file_kind(path)? {
        FileKind::Exr => read_exr(path),
        FileKind::Png => read_png(path, srgb),
    }
}

/// Largest image Tyndall reads, in texels (16384², the largest texture side it uses): a header
/// claiming more is refused before anything is allocated (a forged size made the EXR reader
/// ask for 42 GB; found by fuzzing).
pub const MAX_READ_TEXELS: u64 = 16384 * 16384;

fn read_exr(path: &Path) -> Result<Raster, IoError> {
    read_exr_layer(path, "").map(|(r, _)| r)
}

fn read_png(path: &Path, srgb: bool) -> Result<Raster, IoError> {
    let err = |reason: String| IoError::Read {
        path: path.to_path_buf(),
        reason,
    };
    let img = image::open(path).map_err(|e| err(e.to_string()))?;
    let (width, height) = (img.width(), img.height());
    let decode = |v: f32| if srgb { srgb_to_linear(v) } else { v };
    let grey = matches!(img.color(), image::ColorType::L8 | image::ColorType::L16);
    if grey {
        let l = img.to_luma32f();
        Ok(Raster {
            width,
            height,
            channels: 1,
            data: l.into_raw().into_iter().map(decode).collect(),
        })
    } else {
        let rgba = img.to_rgba32f();
        let mut data = rgba.into_raw();
        for px in data.chunks_mut(4) {
            for c in &mut px[..3] {
                *c = decode(*c);
            }
        }
        Ok(Raster {
            width,
            height,
            channels: 4,
            data,
        })
    }
}

/// Write a raster as EXR (`F32`/`F16`; one channel is written as `Y`, three as `R`,`G`,`B`, four
/// as `R`,`G`,`B`,`A`) or PNG (`U8`/`U16`; one channel as grey, three or four as RGBA (alpha 1
/// for three), colour channels sRGB-encoded when
/// `srgb`). Missing parent folders are created. Non-finite samples are written as 0, so no NaN/Inf reaches a file. The write is
/// atomic (temporary file beside the target, flushed to disk, then renamed over it). While
/// writes are [`deferred`] (a sequence render), the raster is queued and written on a
/// background thread: the file exists, or its failure is known, after [`deferred::wait`].
pub fn write_image(
    path: &Path,
    r: &Raster,
    precision: Precision,
    srgb: bool,
) -> Result<(), IoError> {
    let traced = move |path: &Path, r: &Raster| {
        crate::trace::write(path, || {
            write_image_untraced(path, r, precision, srgb, None)
        })
    };
    if !deferred::deferred() {
        return traced(path, r);
    }
    // On a writer thread, with the frame it belongs to.
    let (path, r, frame) = (path.to_path_buf(), r.clone(), crate::trace::frame());
    deferred::submit(
        path.clone(),
        Box::new(move || {
            crate::trace::set_frame(frame);
            traced(&path, &r)
        }),
    )
}

/// [`write_image`] of a raster still being read back from the GPU: `raster` waits for it (on
/// the writer thread when writes are [`deferred`], so the next frame is recorded meanwhile;
/// here otherwise). A failed read is a failed write of `path`. An EXR gets the
/// `chromaticities` attribute when given (`[rx, ry, gx, gy, bx, by, wx, wy]`; none: Rec.709,
/// what the format means without it).
pub fn write_image_later(
    path: &Path,
    raster: Box<dyn FnOnce() -> Result<Raster, String> + Send>,
    precision: Precision,
    srgb: bool,
    chromaticities: Option<[f32; 8]>,
) -> Result<(), IoError> {
    let read = move |path: &Path| {
        raster().map_err(|reason| IoError::Write {
            path: path.to_path_buf(),
            reason: format!("reading the picture back: {reason}"),
        })
    };
    if !deferred::deferred() {
        let r = read(path)?;
        return crate::trace::write(path, || {
            write_image_untraced(path, &r, precision, srgb, chromaticities)
        });
    }
    let (path, frame) = (path.to_path_buf(), crate::trace::frame());
    deferred::submit(
        path.clone(),
        Box::new(move || {
            crate::trace::set_frame(frame);
            let r = read(&path)?;
            crate::trace::write(&path, || {
                write_image_untraced(&path, &r, precision, srgb, chromaticities)
            })
        }),
    )
}

fn write_image_untraced(
    path: &Path,
    r: &Raster,
    precision: Precision,
    srgb: bool,
    chromaticities: Option<[f32; 8]>,
) -> Result<(), IoError> {
    let err = |reason: String| IoError::Write {
        path: path.to_path_buf(),
        reason,
    };
    let kind = file_kind(path)?;
    let fits = matches!(
        (kind, precision),
        (FileKind::Exr, Precision::F32 | Precision::F16)
            | (FileKind::Png, Precision::U8 | Precision::U16)
    );
    if !fits {
        return Err(IoError::Format {
            path: path.to_path_buf(),
            reason: format!("precision {precision:?} cannot be written to this format (EXR: F32/F16, PNG: U8/U16)"),
        });
    }
    if !matches!(r.channels, 1 | 3 | 4) {
        return Err(err(format!("{} channels (expected 1, 3 or 4)", r.channels)));
    }
    let mut clean = r.clone();
    for v in &mut clean.data {
        if !v.is_finite() {
            *v = 0.0;
        }
    }
    if clean.channels == 3 && kind == FileKind::Png {
        clean = Raster {
            channels: 4,
            data: clean
                .data
                .chunks(3)
                .flat_map(|p| [p[0], p[1], p[2], 1.0])
                .collect(),
            ..clean
        };
    }
    let r = &clean;
    write_via_temp(path, |tmp| match kind {
        FileKind::Exr => write_exr(tmp, r, precision == Precision::F16, chromaticities),
        FileKind::Png => write_png(tmp, r, precision == Precision::U16, srgb),
    })
}

/// Write `path` atomically: `write` fills a temporary file beside it (unique per process and
/// per write: two evaluations may write the same file at once), which is flushed to disk and
/// renamed over `path`, so a crash leaves the old file or the new one, never a partial one.
/// Missing parent folders are created.
fn write_via_temp(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), IoError> {
    let err = |reason: String| IoError::Write {
        path: path.to_path_buf(),
        reason,
    };
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)
        .map_err(|e| err(format!("cannot create folder {}: {e}", dir.display())))?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("tmp");
    remove_stale_temporaries(dir, &name);
    static WRITES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = WRITES.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(
        ".{name}.tmp{}-{n}-{}.{ext}",
        std::process::id(),
        host_tag()
    ));
    let synced = |()| {
        std::fs::File::open(&tmp)
            .and_then(|f| f.sync_all())
            .map_err(|e| e.to_string())
    };
    match write(&tmp)
        .and_then(synced)
        .and_then(|_| std::fs::rename(&tmp, path).map_err(|e| e.to_string()))
    {
        Ok(()) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(err(e))
        }
    }
}

/// This machine's tag in temporary names: 8 hex digits of a hash of its host name (so a
/// temporary on shared storage says which machine's process wrote it).
pub fn host_tag() -> String {
    use std::hash::{Hash, Hasher};
    static TAG: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TAG.get_or_init(|| {
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .or_else(|_| std::env::var("HOSTNAME"))
            .or_else(|_| std::env::var("COMPUTERNAME"))
            .unwrap_or_default();
        let mut h = std::collections::hash_map::DefaultHasher::new();
        host.trim().hash(&mut h);
        format!("{:08x}", h.finish() as u32)
    })
    .clone()
}

/// Remove temporaries of `name` in `dir` (`.{name}.tmp{pid}-{n}-{host}.{ext}`) left by a process
/// of this machine that no longer runs — a render killed while writing (a farm pre-empting a
/// task) — so the resumed run leaves no partial file behind. Temporaries of other machines
/// (shared storage) are never touched. Only where process ids can be checked (`/proc`, Linux);
/// elsewhere leftovers stay (hidden, never taken for the file itself).
fn remove_stale_temporaries(dir: &Path, name: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let prefix = format!(".{name}.tmp");
    let host = host_tag();
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let file = e.file_name().to_string_lossy().into_owned();
        let Some(rest) = file.strip_prefix(&prefix) else {
            continue;
        };
        // rest: `{pid}-{n}-{host}.{ext}`
        let mut parts = rest.splitn(3, '-');
        let (Some(pid), Some(_), Some(tail)) = (parts.next(), parts.next(), parts.next()) else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else {
            continue;
        };
        if !tail.starts_with(&format!("{host}.")) {
            continue;
        }
        if pid != std::process::id() && !Path::new(&format!("/proc/{pid}")).exists() {
            // Best effort: another process may be removing it too.
            let _ = std::fs::remove_file(e.path());
        }
    }
}

fn write_png(path: &Path, r: &Raster, sixteen: bool, srgb: bool) -> Result<(), String> {
    let (w, h) = (r.width, r.height);
    let enc = |v: f32, colour: bool| -> f32 {
        let v = if v.is_finite() { v } else { 0.0 };
        if srgb && colour {
            linear_to_srgb(v)
        } else {
            v.clamp(0.0, 1.0)
        }
    };
    let q8 = |v: f32| (v * 255.0).round() as u8;
    let q16 = |v: f32| (v * 65535.0).round() as u16;
    let samples: Vec<f32> = r
        .data
        .iter()
        .enumerate()
        .map(|(i, v)| enc(*v, r.channels == 1 || i % 4 != 3))
        .collect();
    let res = match (r.channels, sixteen) {
        (1, false) => {
            image::GrayImage::from_raw(w, h, samples.iter().map(|v| q8(*v)).collect::<Vec<u8>>())
                .map(|i| i.save(path))
        }
        (1, true) => image::ImageBuffer::<image::Luma<u16>, _>::from_raw(
            w,
            h,
            samples.iter().map(|v| q16(*v)).collect::<Vec<u16>>(),
        )
        .map(|i| i.save(path)),
        (_, false) => {
            image::RgbaImage::from_raw(w, h, samples.iter().map(|v| q8(*v)).collect::<Vec<u8>>())
                .map(|i| i.save(path))
        }
        (_, true) => image::ImageBuffer::<image::Rgba<u16>, _>::from_raw(
            w,
            h,
            samples.iter().map(|v| q16(*v)).collect::<Vec<u16>>(),
        )
        .map(|i| i.save_with_format(path, image::ImageFormat::Png)),
    };
    match res {
        Some(Ok(())) => Ok(()),
        Some(Err(e)) => Err(e.to_string()),
        None => Err("raster size does not match its data".into()),
    }
}
