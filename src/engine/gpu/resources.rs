//! Making GPU resources: pooled textures (recycled, or zeroed), uploads of CPU samples, storage
//! buffers, and region copies between textures.

use super::*;

impl Gpu {
    /// A texture from the pool (contents undefined), checked against the device's size limit.
    pub fn texture(
        &self,
        width: u32,
        height: u32,
        format: TexFormat,
    ) -> Result<GpuTexture, GpuError> {
        let limit = self.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > limit || height > limit {
            return Err(GpuError::TooLarge {
                width,
                height,
                limit,
            });
        }
        Ok(self.pool.acquire(width, height, format))
    }

    /// Textures idle in the pool, ready to be handed out again.
    pub fn idle_textures(&self) -> usize {
        self.pool.idle()
    }

    /// A texture of zeros. ([`Gpu::texture`] recycles textures, so its contents are whatever the
    /// last user left: a pass that reads a texture before writing every texel starts here.)
    pub fn zeroed(
        &self,
        width: u32,
        height: u32,
        format: TexFormat,
    ) -> Result<GpuTexture, GpuError> {
        let channels = match format {
            TexFormat::R32F => 1,
            TexFormat::Rg32F => 2,
            TexFormat::Rgba32F => 4,
        };
        let zeros = vec![0.0f32; (width * height * channels) as usize];
        let tex = self.texture(width, height, format)?;
        self.write(&tex, &zeros)?;
        Ok(tex)
    }

    /// Upload interleaved float samples (1 channel → `R32F`, 4 → `RGBA32F`; pad two or three
    /// values per texel to four) into a new texture. Any other channel count, or `data` not
    /// `width × height × channels` long, is [`GpuError::BadData`].
    pub fn upload(
        &self,
        width: u32,
        height: u32,
        channels: u32,
        data: &[f32],
    ) -> Result<GpuTexture, GpuError> {
        let want = width as usize * height as usize * channels as usize;
        if !matches!(channels, 1 | 4) || data.len() != want {
            return Err(GpuError::BadData(format!(
                "{} values for a {width}×{height} texture of {channels} channel(s) \
                 (1 or 4 channels, {want} values expected)",
                data.len()
            )));
        }
        let format = if channels == 1 {
            TexFormat::R32F
        } else {
            TexFormat::Rgba32F
        };
        let tex = self.texture(width, height, format)?;
        self.write(&tex, data)?;
        Ok(tex)
    }

    /// Overwrite every texel of `tex` with interleaved float samples.
    fn write(&self, tex: &GpuTexture, data: &[f32]) -> Result<(), GpuError> {
        // A queue write runs before the next submission, but no recorded pass still uses a
        // texture the pool hands out (see recorder.rs: one dropped while used returns after its
        // recorder submits), so nothing recorded sees it change.
        let (width, height) = (tex.width, tex.height);
        let widened = widen(data, tex.format.channels(), tex.stored_channels());
        let data: &[f32] = &widened;
        self.scoped(|| {
            self.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: tex.raw(),
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(data),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(width * tex.stored_channels() * 4),
                    rows_per_image: Some(height),
                },
                wgpu::Extent3d {
                    width,
                    height,
                    depth_or_array_layers: 1,
                },
            );
        })
    }

    /// A storage buffer of `words` 32-bit zeros (WebGPU zero-initialises every new buffer, on
    /// the device; no zeros are uploaded).
    pub fn buffer_zeroed(&self, words: u32) -> Result<GpuBuffer, GpuError> {
        let size = (words.max(1) as u64) * 4;
        if size > self.limits.max_storage_buffer_binding_size {
            return Err(GpuError::Validation(format!(
                "a storage buffer of {words} words exceeds the adapter's limit"
            )));
        }
        let raw = self.scoped(|| {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("storage"),
                size,
                // INDIRECT: a pass may write the workgroup counts of a later one
                // (`Recorder::dispatch_indirect`).
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_SRC
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::INDIRECT,
                mapped_at_creation: false,
            })
        })?;
        Ok(GpuBuffer { raw, words })
    }

    /// A storage buffer holding `data` (32-bit words: u32, or f32 as bits), written through the
    /// queue (a new buffer: no recorded pass uses it yet).
    pub fn buffer_from(&self, data: &[u32]) -> Result<GpuBuffer, GpuError> {
        let words = u32::try_from(data.len()).map_err(|_| {
            GpuError::Validation(format!(
                "a storage buffer of {} words is too large",
                data.len()
            ))
        })?;
        let b = self.buffer_zeroed(words)?;
        if !data.is_empty() {
            self.queue
                .write_buffer(&b.raw, 0, bytemuck::cast_slice(data));
        }
        Ok(b)
    }

    /// The value made by `make` for content `key`, made once and shared while anything holds
    /// it: a second request for the same key (a scene's unchanged geometry on the next frame)
    /// gets the same GPU resources instead of uploading them again. Keys are 64-bit content
    /// hashes, per type; the second value says whether it was shared (not made now).
    pub fn shared_by_key<T: std::any::Any + Send + Sync>(
        &self,
        key: u64,
        make: impl FnOnce() -> Result<T, GpuError>,
    ) -> Result<(std::sync::Arc<T>, bool), GpuError> {
        use std::hash::{Hash, Hasher};
        let mut h = std::hash::DefaultHasher::new();
        (key, std::any::TypeId::of::<T>()).hash(&mut h);
        let key = h.finish();
        let held = self
            .keyed
            .lock()
            .ok()
            .and_then(|m| m.get(&key).and_then(std::sync::Weak::upgrade))
            .and_then(|v| v.downcast::<T>().ok());
        if let Some(v) = held {
            return Ok((v, true));
        }
        let v = std::sync::Arc::new(make()?);
        if let Ok(mut m) = self.keyed.lock() {
            m.retain(|_, w| w.strong_count() > 0);
            let any: std::sync::Arc<dyn std::any::Any + Send + Sync> = v.clone();
            m.insert(key, std::sync::Arc::downgrade(&any));
        }
        Ok((v, false))
    }
}

impl Recorder<'_> {
    /// Copy a `width × height` block from `src` at `(x, y)` to the same place in `dst` (same
    /// format).
    pub fn copy_region(
        &self,
        src: &GpuTexture,
        dst: &GpuTexture,
        x: u32,
        y: u32,
        width: u32,
        height: u32,
    ) -> Result<(), GpuError> {
        self.copy_block(src, (x, y), dst, (x, y), (width, height))
    }

    /// Copy the whole of `src` into `dst` with its top-left corner at `(x, y)` (same format;
    /// `dst` large enough), e.g. a cube face into its place in an atlas.
    pub fn copy_into(
        &self,
        src: &GpuTexture,
        dst: &GpuTexture,
        x: u32,
        y: u32,
    ) -> Result<(), GpuError> {
        self.copy_block(src, (0, 0), dst, (x, y), (src.width, src.height))
    }

    /// Copy a `size` block from `src` at `from` to `dst` at `to` (same format).
    fn copy_block(
        &self,
        src: &GpuTexture,
        from: (u32, u32),
        dst: &GpuTexture,
        to: (u32, u32),
        (width, height): (u32, u32),
    ) -> Result<(), GpuError> {
        self.uses(src);
        self.uses(dst);
        self.scoped(|| {
            self.encode(|enc| {
                fn at(t: &GpuTexture, (x, y): (u32, u32)) -> wgpu::TexelCopyTextureInfo<'_> {
                    wgpu::TexelCopyTextureInfo {
                        texture: t.raw(),
                        mip_level: 0,
                        origin: wgpu::Origin3d { x, y, z: 0 },
                        aspect: wgpu::TextureAspect::All,
                    }
                }
                enc.copy_texture_to_texture(
                    at(src, from),
                    at(dst, to),
                    wgpu::Extent3d {
                        width,
                        height,
                        depth_or_array_layers: 1,
                    },
                );
            })
        })
    }
}
