//! Reading GPU results back: textures (and volume levels) and storage buffers. A read-back
//! first submits what this thread has recorded (see `batch.rs`).

use super::*;

thread_local! {
    /// Read-backs made by this thread and their bytes ([`Gpu::thread_readbacks`]).
    static THREAD_READBACKS: std::cell::Cell<(u64, u64)> = const { std::cell::Cell::new((0, 0)) };
}

impl Gpu {
    /// Read a storage buffer back as i32 words.
    pub fn read_buffer_i32(&self, b: &GpuBuffer) -> Result<Vec<i32>, GpuError> {
        let size = (b.words.max(1) as u64) * 4;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        self.scoped(|| {
            self.encode(|enc| enc.copy_buffer_to_buffer(&b.raw, 0, &staging, 0, size));
        })?;
        self.flush()?;
        let bytes = self.map_read(&staging)?;
        let words: Vec<i32> = bytemuck::cast_slice(&bytes).to_vec();
        Ok(words[..b.words as usize].to_vec())
    }

    /// Wait for `buffer` (MAP_READ) to be readable and copy its bytes out.
    fn map_read(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let started = std::time::Instant::now();
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        receive(&rx)?.map_err(|e| GpuError::Readback(e.to_string()))?;
        let bytes = buffer
            .get_mapped_range(..)
            .map_err(|e| GpuError::Readback(e.to_string()))?
            .to_vec();
        buffer.unmap();
        let [count, total] = &self.readbacks;
        count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        total.fetch_add(bytes.len() as u64, std::sync::atomic::Ordering::Relaxed);
        THREAD_READBACKS.with(|c| {
            let (n, b) = c.get();
            c.set((n + 1, b + bytes.len() as u64));
        });
        crate::trace::record(
            "readback",
            "read-back",
            started,
            started.elapsed(),
            serde_json::json!({ "bytes": bytes.len() }),
        );
        Ok(bytes)
    }

    /// Read-backs made by this thread so far (to any context), and their bytes: what one
    /// evaluation on this thread read back is the difference across it, whatever other threads
    /// read meanwhile.
    pub fn thread_readbacks(&self) -> (u64, u64) {
        THREAD_READBACKS.with(std::cell::Cell::get)
    }

    /// Read-backs made through this context so far (all threads), and their bytes (as mapped,
    /// row padding included).
    pub fn readbacks(&self) -> (u64, u64) {
        let [count, total] = &self.readbacks;
        (
            count.load(std::sync::atomic::Ordering::Relaxed),
            total.load(std::sync::atomic::Ordering::Relaxed),
        )
    }

    /// Read a texture back to the CPU. Returns `width * height * channels` interleaved floats,
    /// rows top to bottom, padding removed.
    pub fn read_texture(&self, tex: &GpuTexture) -> Result<Vec<f32>, GpuError> {
        let stored = tex.stored_channels();
        let texels = self.read_texels(tex.raw(), 0, [tex.width, tex.height, 1], stored * 4)?;
        Ok(narrow(texels, stored, tex.format.channels()))
    }

    /// The one row-padded readback helper (2D textures and volume levels): mip `level` of
    /// `texture`, `size` texels, `bpt` bytes per texel; x fastest, then y, then z.
    pub(crate) fn read_texels(
        &self,
        texture: &wgpu::Texture,
        level: u32,
        size: [u32; 3],
        bpt: u32,
    ) -> Result<Vec<f32>, GpuError> {
        let [w, h, d] = size;
        let row = w * bpt;
        let padded =
            row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: (padded * h * d) as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        self.scoped(|| {
            self.encode(|enc| {
                enc.copy_texture_to_buffer(
                    wgpu::TexelCopyTextureInfo {
                        texture,
                        mip_level: level,
                        origin: wgpu::Origin3d::ZERO,
                        aspect: wgpu::TextureAspect::All,
                    },
                    wgpu::TexelCopyBufferInfo {
                        buffer: &buffer,
                        layout: wgpu::TexelCopyBufferLayout {
                            offset: 0,
                            bytes_per_row: Some(padded),
                            rows_per_image: Some(h),
                        },
                    },
                    wgpu::Extent3d {
                        width: w,
                        height: h,
                        depth_or_array_layers: d,
                    },
                )
            });
        })?;
        self.flush()?;
        let bytes = self.map_read(&buffer)?;
        let mut out = Vec::with_capacity((row / 4 * h * d) as usize);
        for r in 0..h * d {
            let start = (r * padded) as usize;
            out.extend_from_slice(bytemuck::cast_slice(&bytes[start..start + row as usize]));
        }
        Ok(out)
    }
}
