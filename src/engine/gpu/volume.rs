//! 3D textures (`Volume` values: noise and painted blend volumes): one float channel, with a
//! chain of mip levels (each half the size, rounded up, of the one below) that shaders read with
//! `textureLoad(volume, texel, level)` and write one level at a time.
//!
//! **Written through rows** where an adapter cannot bind a whole 3D level as a storage texture
//! (wgpu's GL backend binds one slice of it: see
//! [`Capabilities::volume_rows`](super::adapter::Capabilities::volume_rows)): each level then
//! has a storage buffer laid out as a buffer-to-texture copy reads it — a 16-byte header (the
//! level's size and the row pitch, in texels), then rows of `pitch` floats (a multiple of 64, so
//! rows are 256 bytes apart), `size.y` rows per slice. A pass writes the buffer (its WGSL
//! rewritten by [`rows_source`]: `textureStore(v, p, x)` stores `x.r` at row `p.y` of slice
//! `p.z`, `textureDimensions(v)` reads the header), and the whole level is copied into the
//! texture before anything next reads the volume (a pass binding it, a read-back). The buffer
//! keeps what earlier passes wrote, so passes that each write one slice (`SoftVisibility`) build
//! the level up as they do on a storage texture. Shaders read volumes as textures either way.

use super::{Gpu, GpuError, Recorder};

/// A one-channel 3D texture with its mip chain (or a read-only RGBA lookup table:
/// [`Gpu::lut_volume`]).
pub struct GpuVolume {
    raw: wgpu::Texture,
    all: wgpu::TextureView,
    levels: Vec<wgpu::TextureView>,
    /// Per level, the storage buffer its passes write where volumes are written through rows
    /// (empty otherwise).
    rows: Vec<wgpu::Buffer>,
    /// Levels whose row buffer was written since it was last copied into the texture (bit l:
    /// level l). The copy waits until something reads the volume.
    dirty: std::sync::atomic::AtomicU32,
    /// Size of level 0 in texels (x, y, z).
    pub size: [u32; 3],
}

impl std::fmt::Debug for GpuVolume {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "GpuVolume({}x{}x{}, {} levels)",
            self.size[0],
            self.size[1],
            self.size[2],
            self.levels.len()
        )
    }
}

/// The number of mip levels of a volume of this size: down to 1 texel on the longest side.
pub fn mip_count(size: [u32; 3]) -> u32 {
    32 - size
        .iter()
        .copied()
        .max()
        .unwrap_or(1)
        .max(1)
        .leading_zeros()
}

/// Size of mip `level` of a volume of `size`.
pub fn mip_size(size: [u32; 3], level: u32) -> [u32; 3] {
    size.map(|s| (s >> level).max(1))
}

impl GpuVolume {
    /// Number of mip levels.
    pub fn mips(&self) -> u32 {
        self.levels.len() as u32
    }

    /// Size of mip `level`.
    pub fn level_size(&self, level: u32) -> [u32; 3] {
        mip_size(self.size, level)
    }

    /// A view of every level (for reading).
    pub fn view(&self) -> &wgpu::TextureView {
        &self.all
    }

    /// A view of one level (for writing).
    pub fn level_view(&self, level: u32) -> &wgpu::TextureView {
        &self.levels[(level as usize).min(self.levels.len() - 1)]
    }

    /// Bytes held on the GPU (the row buffers too, where there are some).
    pub fn bytes(&self) -> usize {
        let texels: usize = (0..self.mips())
            .map(|l| {
                let s = self.level_size(l);
                (s[0] * s[1] * s[2] * 4) as usize
            })
            .sum();
        texels + self.rows.iter().map(|b| b.size() as usize).sum::<usize>()
    }

    /// The storage buffer that passes writing `level` bind, where volumes are written through
    /// rows (`None`: they bind [`GpuVolume::level_view`] as a storage texture).
    pub(crate) fn rows(&self, level: u32) -> Option<&wgpu::Buffer> {
        self.rows.get(level as usize)
    }

    /// Note that a pass wrote level `level` through its row buffer.
    pub(crate) fn mark_written(&self, level: u32) {
        if self.rows(level).is_some() {
            self.dirty
                .fetch_or(1 << level, std::sync::atomic::Ordering::AcqRel);
        }
    }

    /// Before something reads the volume (a pass binds it, or it is read back): copy every
    /// level written through its row buffer since the last copy into the texture. Once per
    /// write, not per pass: `SoftVisibility` writes one slice per pass, and copying the whole
    /// level after each of its 96 passes was most of its time on GL.
    pub(crate) fn flush_rows(&self, enc: &mut wgpu::CommandEncoder) {
        let dirty = self.dirty.swap(0, std::sync::atomic::Ordering::AcqRel);
        for level in 0..self.mips() {
            if dirty & (1 << level) != 0 {
                self.copy_rows(enc, level);
            }
        }
    }

    /// Whether a level waits for [`GpuVolume::flush_rows`].
    pub(crate) fn has_unflushed_rows(&self) -> bool {
        self.dirty.load(std::sync::atomic::Ordering::Acquire) != 0
    }

    /// Copy level `level`'s row buffer into the texture.
    fn copy_rows(&self, enc: &mut wgpu::CommandEncoder, level: u32) {
        let Some(buffer) = self.rows(level) else {
            return;
        };
        let s = self.level_size(level);
        enc.copy_buffer_to_texture(
            wgpu::TexelCopyBufferInfo {
                buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: ROWS_HEADER,
                    bytes_per_row: Some(row_pitch(s[0]) * 4),
                    rows_per_image: Some(s[1]),
                },
            },
            wgpu::TexelCopyTextureInfo {
                texture: &self.raw,
                mip_level: level,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::Extent3d {
                width: s[0],
                height: s[1],
                depth_or_array_layers: s[2],
            },
        );
    }
}

/// Bytes before the texels of a row buffer: the level's size (x, y, z) and the row pitch.
const ROWS_HEADER: u64 = 16;

/// Texels from one row of a row buffer to the next: `width` rounded up to 64 (256 bytes, what a
/// buffer-to-texture copy requires of `bytes_per_row`).
pub fn row_pitch(width: u32) -> u32 {
    width.div_ceil(64) * 64
}

/// Bytes of the row buffer of a level of `size`.
fn rows_bytes(size: [u32; 3]) -> u64 {
    let texels = u64::from(row_pitch(size[0])) * u64::from(size[1]) * u64::from(size[2]);
    ROWS_HEADER + texels * 4
}

/// The row buffer of a level of `size`, its header written.
fn rows_buffer(device: &wgpu::Device, queue: &wgpu::Queue, size: [u32; 3]) -> wgpu::Buffer {
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("volume rows"),
        size: rows_bytes(size),
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let header = [size[0], size[1], size[2], row_pitch(size[0])];
    queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&header));
    buffer
}

/// The WGSL declarations [`rows_source`] adds once per shader.
const ROWS_STRUCT: &str = "
// Added by Tyndall (src/engine/gpu/volume.rs): a 3D storage level written through a row buffer.
struct TyndallVolumeRows {
    size: vec3<u32>,
    pitch: u32,
    texels: array<f32>,
}
";

/// `source` with every `var NAME: texture_storage_3d<r32float, write>` binding written through
/// a row buffer (see the module docs): the declaration becomes a read-write storage buffer,
/// `textureStore(NAME, p, v)` a call that stores `v.r` at texel `p` (a `vec3<u32>`), and
/// `textureDimensions(NAME)` the level's size from the buffer's header. Other uses of such a
/// binding are not rewritten (naga then rejects the shader, naming them).
pub fn rows_source(source: &str) -> String {
    const TY: &str = "texture_storage_3d<r32float, write>";
    let mut names = Vec::new();
    let mut out = String::with_capacity(source.len() + 512);
    for line in source.lines() {
        let decl = line
            .find("var ")
            .filter(|_| line.contains(TY))
            .and_then(|at| {
                let rest = &line[at + 4..];
                let (name, ty) = rest.split_once(':')?;
                (ty.trim().trim_end_matches(';').trim() == TY).then(|| (at, name.trim()))
            });
        match decl {
            Some((at, name)) => {
                out.push_str(&line[..at]);
                out.push_str(&format!(
                    "var<storage, read_write> {name}: TyndallVolumeRows;"
                ));
                names.push(name.to_string());
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    if names.is_empty() {
        return source.to_string();
    }
    for name in &names {
        out = out
            .replace(
                &format!("textureStore({name},"),
                &format!("tyndall_rows_store_{name}("),
            )
            .replace(
                &format!("textureDimensions({name})"),
                &format!("{name}.size"),
            );
    }
    out.push_str(ROWS_STRUCT);
    for name in &names {
        out.push_str(&format!(
            "fn tyndall_rows_store_{name}(p: vec3<u32>, v: vec4<f32>) {{
    {name}.texels[(p.z * {name}.size.y + p.y) * {name}.pitch + p.x] = v.r;
}}
"
        ));
    }
    out
}

impl Gpu {
    /// A zero-initialised volume of `size` with its whole mip chain.
    pub fn volume(&self, size: [u32; 3]) -> Result<GpuVolume, GpuError> {
        let limit = self.limits.max_texture_dimension_3d;
        if size.iter().any(|&s| s == 0 || s > limit) {
            return Err(GpuError::TooLarge {
                width: size[0],
                height: size[1],
                limit,
            });
        }
        let mips = mip_count(size);
        let raw = self.scoped(|| {
            self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("volume"),
                size: wgpu::Extent3d {
                    width: size[0],
                    height: size[1],
                    depth_or_array_layers: size[2],
                },
                mip_level_count: mips,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::R32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        })?;
        let rows = if self.caps.volume_rows() {
            let level0 = rows_bytes(size);
            let limit = self.limits.max_storage_buffer_binding_size;
            if level0 > limit {
                return Err(GpuError::Unsupported {
                    adapter: self.describe(),
                    lacks: format!(
                        "storage buffers of {level0} bytes (a {}×{}×{} volume is written through one here; the limit is {limit})",
                        size[0], size[1], size[2]
                    ),
                });
            }
            self.scoped(|| {
                (0..mips)
                    .map(|l| rows_buffer(&self.device, &self.queue, mip_size(size, l)))
                    .collect()
            })?
        } else {
            Vec::new()
        };
        let all = raw.create_view(&Default::default());
        let levels = (0..mips)
            .map(|l| {
                raw.create_view(&wgpu::TextureViewDescriptor {
                    base_mip_level: l,
                    mip_level_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        Ok(GpuVolume {
            raw,
            all,
            levels,
            rows,
            dirty: std::sync::atomic::AtomicU32::new(0),
            size,
        })
    }

    /// A one-channel volume of `size` with level 0 set to `values` (x fastest, then y, then z)
    /// and the levels above zero: a volume read from a file (`VdbVolume`), whose mips a pass
    /// then builds from level 0.
    pub fn upload_volume(&self, size: [u32; 3], values: &[f32]) -> Result<GpuVolume, GpuError> {
        let texels = size.iter().map(|&s| s as usize).product::<usize>();
        if values.len() != texels {
            return Err(GpuError::BadData(format!(
                "{} values for a {}×{}×{} volume ({texels} expected)",
                values.len(),
                size[0],
                size[1],
                size[2],
            )));
        }
        let v = self.volume(size)?;
        // A new texture: no recorded pass reads or writes it before this queue write, and no
        // pass has written level 0 through its row buffer (so no later flush overwrites it).
        self.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &v.raw,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(values),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size[0] * 4),
                rows_per_image: Some(size[1]),
            },
            wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: size[2],
            },
        );
        Ok(v)
    }

    /// A read-only RGBA 3D lookup table of `size` texels (one level), `rgba` x fastest, then
    /// y, then z — what a colour transform's 3D LUT is read from (`textureLoad`; no sampler,
    /// not filterable). Not for [`Recorder::read_volume`], which reads one-channel volumes.
    pub fn lut_volume(&self, size: [u32; 3], rgba: &[f32]) -> Result<GpuVolume, GpuError> {
        let limit = self.limits.max_texture_dimension_3d;
        if size.iter().any(|&s| s == 0 || s > limit) {
            return Err(GpuError::TooLarge {
                width: size[0],
                height: size[1],
                limit,
            });
        }
        let texels = size.iter().map(|&s| s as usize).product::<usize>();
        if rgba.len() != texels * 4 {
            return Err(GpuError::BadData(format!(
                "{} values for a {}×{}×{} RGBA lookup table ({} expected)",
                rgba.len(),
                size[0],
                size[1],
                size[2],
                texels * 4
            )));
        }
        let extent = wgpu::Extent3d {
            width: size[0],
            height: size[1],
            depth_or_array_layers: size[2],
        };
        let raw = self.scoped(|| {
            self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("lut volume"),
                size: extent,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D3,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        })?;
        // A new texture: no recorded pass reads it before this queue write.
        self.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &raw,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(rgba),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(size[0] * 16),
                rows_per_image: Some(size[1]),
            },
            extent,
        );
        let all = raw.create_view(&Default::default());
        let levels = vec![raw.create_view(&Default::default())];
        Ok(GpuVolume {
            raw,
            all,
            levels,
            rows: Vec::new(),
            dirty: std::sync::atomic::AtomicU32::new(0),
            size,
        })
    }
}

impl Recorder<'_> {
    /// Read mip `level` of a volume back: x fastest, then y, then z.
    pub fn read_volume(&self, v: &GpuVolume, level: u32) -> Result<Vec<f32>, GpuError> {
        if v.has_unflushed_rows() {
            self.encode(|enc| v.flush_rows(enc));
        }
        self.read_texels(&v.raw, level, v.level_size(level), 4)
    }
}
