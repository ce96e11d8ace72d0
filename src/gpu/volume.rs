//! 3D textures (`Volume` values: noise and painted blend volumes): one float channel, with a
//! chain of mip levels (each half the size, rounded up, of the one below) that shaders read with
//! `textureLoad(volume, texel, level)` and write one level at a time.

use super::{Gpu, GpuError};

/// A one-channel 3D texture with its mip chain.
pub struct GpuVolume {
    raw: wgpu::Texture,
    all: wgpu::TextureView,
    levels: Vec<wgpu::TextureView>,
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

    /// Bytes held on the GPU.
    pub fn bytes(&self) -> usize {
        (0..self.mips())
            .map(|l| {
                let s = self.level_size(l);
                (s[0] * s[1] * s[2] * 4) as usize
            })
            .sum()
    }
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
            size,
        })
    }

    /// Read mip `level` of a volume back: x fastest, then y, then z.
    pub fn read_volume(&self, v: &GpuVolume, level: u32) -> Result<Vec<f32>, GpuError> {
        self.read_texels(&v.raw, level, v.level_size(level), 4)
    }
}
