//! Reading GPU results back: textures (and volume levels) and storage buffers. A read-back goes
//! through a [`Recorder`]: its copy follows what the recorder recorded, and both are submitted
//! before the bytes are waited for. (There is no read-back on [`Gpu`] itself: one beside a
//! recorder's unsubmitted passes would read what they have not written yet.)

use super::*;

thread_local! {
    /// Read-backs made by this thread and their bytes ([`Gpu::thread_readbacks`]).
    static THREAD_READBACKS: std::cell::Cell<(u64, u64)> = const { std::cell::Cell::new((0, 0)) };
}

/// Staging buffers kept for reuse, at most this many.
const STAGING_KEPT: usize = 8;

impl Gpu {
    /// A MAP_READ staging buffer of at least `size` bytes: a kept one that fits (and is at most
    /// twice as large), else a new one.
    fn staging(&self, size: u64) -> wgpu::Buffer {
        let mut kept = self.staging.lock().unwrap_or_else(|e| e.into_inner());
        let fit = kept
            .iter()
            .enumerate()
            .filter(|(_, b)| b.size() >= size && b.size() <= size.max(256) * 2)
            .min_by_key(|(_, b)| b.size())
            .map(|(i, _)| i);
        if let Some(i) = fit {
            return kept.swap_remove(i);
        }
        drop(kept);
        self.staging_created
            .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        })
    }

    /// Staging buffers created for read-backs so far (each is kept and reused afterwards).
    pub fn staging_buffers_created(&self) -> u64 {
        self.staging_created
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Wait for the first `size` bytes of `buffer` (a staging buffer) to be readable, hand them
    /// to `read` (the one copy out of the mapping is the caller's), and keep the buffer for the
    /// next read-back.
    fn map_read<T>(
        &self,
        buffer: wgpu::Buffer,
        size: u64,
        read: impl FnOnce(&[u8]) -> T,
    ) -> Result<T, GpuError> {
        let started = std::time::Instant::now();
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, ..size, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        receive(&rx)?.map_err(|e| GpuError::Readback(e.to_string()))?;
        let out = {
            let view = buffer
                .get_mapped_range(..size)
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            read(&view)
        };
        buffer.unmap();
        keep_staging(&self.staging, buffer);
        self.count_readback(size);
        crate::trace::record(
            "readback",
            "read-back",
            started,
            started.elapsed(),
            serde_json::json!({ "bytes": size }),
        );
        Ok(out)
    }

    /// Count a read-back of `size` bytes (for the context and for this thread).
    fn count_readback(&self, size: u64) {
        let [count, total] = &self.readbacks;
        count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        total.fetch_add(size, std::sync::atomic::Ordering::Relaxed);
        THREAD_READBACKS.with(|c| {
            let (n, b) = c.get();
            c.set((n + 1, b + size));
        });
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
}

impl Recorder<'_> {
    /// Read a storage buffer back as i32 words.
    pub fn read_buffer_i32(&self, b: &GpuBuffer) -> Result<Vec<i32>, GpuError> {
        let size = (b.words.max(1) as u64) * 4;
        let staging = self.staging(size);
        self.scoped(|| {
            self.encode(|enc| enc.copy_buffer_to_buffer(&b.raw, 0, &staging, 0, size));
        })?;
        self.flush()?;
        self.map_read(staging, size, |bytes| {
            bytemuck::cast_slice::<u8, i32>(bytes)[..b.words as usize].to_vec()
        })
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
        let copy = self.copy_texels(texture, level, size, bpt)?;
        let rows = copy.rows;
        self.map_read(copy.buffer, copy.bytes, |bytes| rows.unpad(bytes))
    }

    /// Record the copy of [`Recorder::read_texels`] into a staging buffer and submit it.
    fn copy_texels(
        &self,
        texture: &wgpu::Texture,
        level: u32,
        size: [u32; 3],
        bpt: u32,
    ) -> Result<Copied, GpuError> {
        let [w, h, d] = size;
        let row = w * bpt;
        let padded =
            row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let bytes = (padded * h * d) as u64;
        let buffer = self.staging(bytes);
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
        Ok(Copied {
            buffer,
            bytes,
            rows: Rows {
                row,
                padded,
                count: h * d,
            },
        })
    }

    /// Start reading `tex` back and return at once: the copy is submitted now, the bytes are
    /// waited for by [`PendingRead::wait`] — on another thread, while this one records more
    /// work (a sequence's next frame while this one is written). Counted as a read-back now.
    pub fn read_texture_later(&self, tex: &GpuTexture) -> Result<PendingRead, GpuError> {
        let stored = tex.stored_channels();
        let copy = self.copy_texels(tex.raw(), 0, [tex.width, tex.height, 1], stored * 4)?;
        self.count_readback(copy.bytes);
        Ok(PendingRead {
            device: self.device.clone(),
            copy,
            home: Arc::downgrade(&self.staging),
            stored,
            channels: tex.format.channels(),
        })
    }

    /// Start reading texel (`x`, `y`) of `tex` back without waiting (the editor's pixel probe:
    /// 4–16 bytes, and the window keeps drawing): [`TexelRead::try_take`] gives the values once
    /// the GPU has copied them. Counted as a read-back of the texel's bytes.
    pub fn read_texel_async(
        &self,
        tex: &GpuTexture,
        x: u32,
        y: u32,
    ) -> Result<TexelRead, GpuError> {
        let stored = tex.stored_channels();
        let bytes = u64::from(stored * 4);
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("texel read-back"),
            size: bytes,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        self.scoped(|| {
            self.encode(|enc| {
                enc.copy_texture_to_buffer(
                    wgpu::TexelCopyTextureInfo {
                        texture: tex.raw(),
                        mip_level: 0,
                        origin: wgpu::Origin3d {
                            x: x.min(tex.width.saturating_sub(1)),
                            y: y.min(tex.height.saturating_sub(1)),
                            z: 0,
                        },
                        aspect: wgpu::TextureAspect::All,
                    },
                    wgpu::TexelCopyBufferInfo {
                        buffer: &buffer,
                        layout: wgpu::TexelCopyBufferLayout {
                            offset: 0,
                            bytes_per_row: None,
                            rows_per_image: None,
                        },
                    },
                    wgpu::Extent3d {
                        width: 1,
                        height: 1,
                        depth_or_array_layers: 1,
                    },
                )
            });
        })?;
        self.flush()?;
        let done = Arc::new(Mutex::new(None));
        let flag = done.clone();
        buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            if let Ok(mut d) = flag.lock() {
                *d = Some(r.map_err(|e| e.to_string()));
            }
        });
        let [count, total] = &self.readbacks;
        count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        total.fetch_add(bytes, std::sync::atomic::Ordering::Relaxed);
        THREAD_READBACKS.with(|c| {
            let (n, b) = c.get();
            c.set((n + 1, b + bytes));
        });
        Ok(TexelRead {
            buffer,
            done,
            stored,
            channels: tex.format.channels(),
        })
    }
}

/// A texel read-back in flight ([`Recorder::read_texel_async`]).
pub struct TexelRead {
    buffer: wgpu::Buffer,
    done: Arc<Mutex<Option<Result<(), String>>>>,
    stored: u32,
    channels: u32,
}

impl TexelRead {
    /// The texel's values (its format's channels) once copied; `None` while the GPU has not got
    /// there (the device is polled, never waited for).
    pub fn try_take(&self, gpu: &Gpu) -> Option<Result<Vec<f32>, GpuError>> {
        let _ = gpu.device.poll(wgpu::PollType::Poll);
        let done = self.done.lock().ok()?.clone()?;
        Some(done.map_err(GpuError::Readback).and_then(|()| {
            let view = self
                .buffer
                .get_mapped_range(..)
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            let values: Vec<f32> = bytemuck::cast_slice::<u8, f32>(&view).to_vec();
            Ok(narrow(values, self.stored, self.channels))
        }))
    }
}

/// Keep `buffer` (unmapped) for the next read-backs, at most [`STAGING_KEPT`] of them.
fn keep_staging(staging: &Mutex<Vec<wgpu::Buffer>>, buffer: wgpu::Buffer) {
    let mut kept = staging.lock().unwrap_or_else(|e| e.into_inner());
    if kept.len() >= STAGING_KEPT {
        // The smallest goes: large read-backs (the viewer's picture) repeat.
        if let Some(i) = kept
            .iter()
            .enumerate()
            .min_by_key(|(_, b)| b.size())
            .map(|(i, _)| i)
        {
            kept.swap_remove(i);
        }
    }
    kept.push(buffer);
}

/// Rows of a texel copy: their bytes, their padded stride and how many.
#[derive(Clone, Copy)]
struct Rows {
    row: u32,
    padded: u32,
    count: u32,
}

impl Rows {
    /// The floats of the copy, padding removed.
    fn unpad(self, bytes: &[u8]) -> Vec<f32> {
        let mut out = Vec::with_capacity((self.row / 4 * self.count) as usize);
        for r in 0..self.count {
            let start = (r * self.padded) as usize;
            out.extend_from_slice(bytemuck::cast_slice(
                &bytes[start..start + self.row as usize],
            ));
        }
        out
    }
}

/// A texel copy submitted into a staging buffer.
struct Copied {
    buffer: wgpu::Buffer,
    bytes: u64,
    rows: Rows,
}

/// A texture read-back submitted and not yet waited for ([`Recorder::read_texture_later`]).
pub struct PendingRead {
    device: wgpu::Device,
    copy: Copied,
    home: std::sync::Weak<Mutex<Vec<wgpu::Buffer>>>,
    stored: u32,
    channels: u32,
}

impl PendingRead {
    /// Wait for the copy (polling the device, so other submissions are not waited for) and
    /// return the texture's values as [`Recorder::read_texture`] does.
    pub fn wait(self) -> Result<Vec<f32>, GpuError> {
        let started = std::time::Instant::now();
        let Copied {
            buffer,
            bytes,
            rows,
        } = self.copy;
        let done = Arc::new(Mutex::new(None));
        let flag = done.clone();
        buffer.map_async(wgpu::MapMode::Read, ..bytes, move |r| {
            if let Ok(mut d) = flag.lock() {
                *d = Some(r.map_err(|e| e.to_string()));
            }
        });
        let secs = watchdog_secs();
        loop {
            let _ = self.device.poll(wgpu::PollType::Poll);
            if let Some(r) = done.lock().ok().and_then(|d| d.clone()) {
                r.map_err(GpuError::Readback)?;
                break;
            }
            if secs > 0 && started.elapsed().as_secs() >= secs {
                return Err(GpuError::Hung(secs));
            }
            std::thread::sleep(std::time::Duration::from_micros(500));
        }
        let values = {
            let view = buffer
                .get_mapped_range(..bytes)
                .map_err(|e| GpuError::Readback(e.to_string()))?;
            rows.unpad(&view)
        };
        buffer.unmap();
        if let Some(home) = self.home.upgrade() {
            keep_staging(&home, buffer);
        }
        crate::trace::record(
            "readback",
            "read-back",
            started,
            started.elapsed(),
            serde_json::json!({ "bytes": bytes }),
        );
        Ok(narrow(values, self.stored, self.channels))
    }
}
