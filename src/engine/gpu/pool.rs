//! Texture pool: textures are recycled by (size, format) when the last handle drops.

use std::sync::{Arc, Mutex, Weak};

use super::adapter::Capabilities;
use super::recorder::{Release, Retired};

/// Texel formats used between nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TexFormat {
    /// One float channel (`Scalar`, `Depth`, `ShadowMap`).
    R32F,
    /// Four float channels (`Image`).
    Rgba32F,
    /// Two float channels (min-max pyramids and other node-internal data).
    Rg32F,
}

impl TexFormat {
    /// The wgpu format.
    pub fn wgpu(self) -> wgpu::TextureFormat {
        match self {
            TexFormat::R32F => wgpu::TextureFormat::R32Float,
            TexFormat::Rgba32F => wgpu::TextureFormat::Rgba32Float,
            TexFormat::Rg32F => wgpu::TextureFormat::Rg32Float,
        }
    }

    /// Channels per texel.
    pub fn channels(self) -> u32 {
        match self {
            TexFormat::R32F => 1,
            TexFormat::Rgba32F => 4,
            TexFormat::Rg32F => 2,
        }
    }
}

type Free = Vec<(u32, u32, TexFormat, wgpu::Texture)>;

/// Recycles textures; holds at most `capacity` idle textures.
pub struct TexturePool {
    device: wgpu::Device,
    free: Arc<Mutex<Free>>,
    capacity: usize,
    caps: Capabilities,
}

/// A pooled 2D texture with its view; returns to the pool when dropped.
pub struct GpuTexture {
    tex: wgpu::Texture,
    view: wgpu::TextureView,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texel format (what nodes see; see [`GpuTexture::stored`] for what the adapter holds).
    pub format: TexFormat,
    stored: wgpu::TextureFormat,
    home: Weak<Mutex<Free>>,
    capacity: usize,
    /// The recorders whose unsubmitted passes use it ([`super::Recorder`]s' retired lists:
    /// dropped before they submit, it returns to the pool once all have).
    used_by: Mutex<Vec<Weak<Retired>>>,
}

impl std::fmt::Debug for GpuTexture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "GpuTexture({}x{} {:?})",
            self.width, self.height, self.format
        )
    }
}

impl GpuTexture {
    /// The wgpu texture.
    pub fn raw(&self) -> &wgpu::Texture {
        &self.tex
    }

    /// A view of the whole texture.
    pub fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// The format the adapter stores it in: [`TexFormat::wgpu`], or a wider one where the
    /// adapter cannot bind that as a storage texture (`Rg32F` as `Rgba32Float` on GL).
    pub fn stored(&self) -> wgpu::TextureFormat {
        self.stored
    }

    /// Channels of [`GpuTexture::stored`] (at least [`TexFormat::channels`]).
    pub fn stored_channels(&self) -> u32 {
        self.stored.components() as u32
    }

    /// Mark it as used by the unsubmitted passes whose retired list is `retired`.
    pub(crate) fn used_by(&self, retired: &Arc<Retired>) {
        let mut users = self.used_by.lock().unwrap_or_else(|e| e.into_inner());
        // Recorders that have submitted since are done with it.
        users.retain(|w| w.strong_count() > 0);
        if !users
            .iter()
            .any(|w| std::ptr::eq(w.as_ptr(), Arc::as_ptr(retired)))
        {
            users.push(Arc::downgrade(retired));
        }
    }

    /// Size in bytes, as stored.
    pub fn bytes(&self) -> usize {
        self.width as usize * self.height as usize * self.stored_channels() as usize * 4
    }
}

impl Drop for GpuTexture {
    fn drop(&mut self) {
        // wgpu textures are reference-counted handles: the pool keeps a clone of this one.
        let home = self.home.clone();
        let entry = (self.width, self.height, self.format, self.tex.clone());
        let capacity = self.capacity;
        let release = move || {
            if let Some(home) = home.upgrade() {
                if let Ok(mut free) = home.lock() {
                    if free.len() < capacity {
                        free.push(entry);
                    }
                }
            }
        };
        // Recorded passes not yet submitted may still use it: back to the pool only once every
        // recorder holding such passes has submitted them (at once when none does), so no other
        // work reaching the queue earlier reuses it first.
        let release = Release::new(Box::new(release));
        let users = self.used_by.get_mut().unwrap_or_else(|e| e.into_inner());
        for retired in users.iter().filter_map(Weak::upgrade) {
            retired.hold(release.clone());
        }
    }
}

impl TexturePool {
    /// A pool keeping at most `capacity` idle textures, storing and flagging each format as
    /// the adapter's `caps` allow.
    pub fn new(device: wgpu::Device, capacity: usize, caps: Capabilities) -> Self {
        Self {
            device,
            free: Arc::new(Mutex::new(Vec::new())),
            capacity,
            caps,
        }
    }

    /// A texture of this size and format, recycled when one is idle.
    pub fn acquire(&self, width: u32, height: u32, format: TexFormat) -> GpuTexture {
        let recycled = self.free.lock().ok().and_then(|mut free| {
            let i = free
                .iter()
                .position(|(w, h, f, _)| *w == width && *h == height && *f == format)?;
            Some(free.swap_remove(i).3)
        });
        let stored = self.caps.stored(format.wgpu());
        let tex = recycled.unwrap_or_else(|| {
            let usage = self.caps.texture_usages(stored);
            texture_2d(&self.device, "tyndall", (width, height), stored, usage)
        });
        let view = tex.create_view(&Default::default());
        GpuTexture {
            tex,
            view,
            width,
            height,
            format,
            stored,
            home: Arc::downgrade(&self.free),
            capacity: self.capacity,
            used_by: Mutex::new(Vec::new()),
        }
    }

    /// Number of idle textures held.
    pub fn idle(&self) -> usize {
        self.free.lock().map(|f| f.len()).unwrap_or(0)
    }
}

/// Interleaved samples of `from` channels as `to ≥ from` channels (extra channels zero).
pub(crate) fn widen(data: &[f32], from: u32, to: u32) -> std::borrow::Cow<'_, [f32]> {
    if from >= to || from == 0 {
        return std::borrow::Cow::Borrowed(data);
    }
    let (from, to) = (from as usize, to as usize);
    let mut out = Vec::with_capacity(data.len() / from * to);
    for texel in data.chunks(from) {
        out.extend_from_slice(texel);
        out.extend(std::iter::repeat_n(0.0, to - from));
    }
    std::borrow::Cow::Owned(out)
}

/// Interleaved samples of `from` channels cut to the first `to ≤ from`.
pub(crate) fn narrow(data: Vec<f32>, from: u32, to: u32) -> Vec<f32> {
    if to >= from || to == 0 {
        return data;
    }
    data.chunks(from as usize)
        .flat_map(|t| t[..to as usize].iter().copied())
        .collect()
}

/// A single-level 2D texture (pooled textures, raster attachments).
pub(crate) fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    (width, height): (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}
