//! The display pass: an evaluated picture drawn for a window from the GPU texture it was
//! evaluated into, with no read-back (`shaders/display.wgsl`). The editor runs one pass per
//! picture shown — the viewer's (channel, exposure), the A/B wipe's other side, each node
//! thumbnail (shrunk by a box filter; one-channel values above 1 normalised) — and
//! `tyndall bench interactive` times the same path. The result is an 8-bit texture of
//! sRGB-encoded bytes, which egui samples through an `Rgba8UnormSrgb` view (what its own
//! textures hold), so the window shows what the CPU path (the editor's `view::to_srgb8`, the
//! oracle of `tests/editor/display.rs`) shows.
//!
//! The editor uses it when its window draws with the evaluation's device; otherwise (a window
//! on another adapter, wgpu's GL backend, after a lost device) pictures are read back as before.

use crate::gpu::{Gpu, GpuError, GpuTexture};

/// The pass's shader file, `shaders/<STEM>.wgsl` (the engine's own, not a node's).
pub const STEM: &str = "display";

const SOURCE: &str = include_str!("../../shaders/display.wgsl");

/// Which channel(s) a picture shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Channel {
    /// Colour (a one-channel picture shows as grey).
    #[default]
    Rgb,
    /// Red only, as grey.
    R,
    /// Green only, as grey.
    G,
    /// Blue only, as grey.
    B,
    /// Alpha only, as grey.
    A,
    /// Rec. 709 luminance, as grey.
    Luma,
}

impl Channel {
    /// All, in menu order.
    pub const ALL: [Channel; 6] = [
        Channel::Rgb,
        Channel::R,
        Channel::G,
        Channel::B,
        Channel::A,
        Channel::Luma,
    ];

    /// Menu label.
    pub fn label(self) -> &'static str {
        match self {
            Channel::Rgb => "RGB",
            Channel::R => "R",
            Channel::G => "G",
            Channel::B => "B",
            Channel::A => "A",
            Channel::Luma => "Luma",
        }
    }
}

/// Whether an editor window on `gpu`'s adapter draws with the evaluation's device (and so
/// with this pass): on every backend but wgpu's GL, where a long pass would hold the context
/// lock the window's frames need for longer than they wait (over a second on llvmpipe).
pub fn window_shares_device(gpu: &Gpu) -> bool {
    gpu.info.backend != wgpu::Backend::Gl
}

/// How a picture is shown.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Look {
    /// Which channel(s) (a one-channel picture shows grey whatever this says).
    pub channel: Channel,
    /// Exposure in stops (the values are multiplied by 2^stops).
    pub stops: f32,
    /// Box filter side in source texels (1: the picture itself).
    pub factor: u32,
    /// Divide one-channel values by their largest finite box average when that is above 1.
    pub normalise: bool,
    /// The values are display values already (a viewer transform ran first:
    /// [`crate::colour_pass::view`]): clamped and quantized, not sRGB-encoded.
    pub encoded: bool,
}

impl Look {
    /// The viewer's look: the picture itself.
    pub fn viewer(channel: Channel, stops: f32) -> Look {
        Look {
            channel,
            stops,
            factor: 1,
            normalise: false,
            encoded: false,
        }
    }

    /// The look of display values a viewer transform made: RGB as they are, no exposure (it
    /// came before the transform), no encoding.
    pub fn encoded() -> Look {
        Look {
            channel: Channel::Rgb,
            stops: 0.0,
            factor: 1,
            normalise: false,
            encoded: true,
        }
    }

    /// A node thumbnail's look for a `w × h` picture: shrunk so its longer side is at most
    /// `side` texels (the integer factor `⌈max(w, h) / side⌉`), one-channel values normalised.
    pub fn thumbnail(w: u32, h: u32, side: u32) -> Look {
        Look {
            channel: Channel::Rgb,
            stops: 0.0,
            factor: w.max(h).div_ceil(side.max(1)).max(1),
            normalise: true,
            encoded: false,
        }
    }
}

/// A picture drawn by [`Display::draw`].
pub struct Shown {
    /// The 8-bit texture (`Rgba8Unorm` holding sRGB-encoded bytes).
    pub texture: wgpu::Texture,
    /// The view egui samples: `Rgba8UnormSrgb` where the backend can view a texture in another
    /// format (not wgpu's GL), else `Rgba8Unorm`.
    pub view: wgpu::TextureView,
    /// Width and height in texels.
    pub size: (u32, u32),
}

/// The display pipelines of one device.
pub struct Display {
    device: wgpu::Device,
    layout: wgpu::BindGroupLayout,
    peak: wgpu::ComputePipeline,
    show: wgpu::ComputePipeline,
    srgb_view: bool,
}

crate::uniforms! {
    /// Uniforms of `shaders/display.wgsl` (struct `DisplayParams`).
    pub struct DisplayParams as "DisplayParams" {
        /// Box filter side in source texels (≥ 1).
        pub factor: u32,
        /// 1: a one-channel picture (grey from red); 4: RGBA.
        pub channels: u32,
        /// [`Channel`] as 0 RGB, 1 R, 2 G, 3 B, 4 A, 5 luminance.
        pub channel: u32,
        /// 1: divide one-channel values by their peak when above 1.
        pub normalise: u32,
        /// 2^stops of exposure.
        pub gain: f32,
        /// Output width in texels.
        pub out_w: u32,
        /// Output height in texels.
        pub out_h: u32,
        /// 1: sRGB-encode; 0: the values are display values already (clamped and quantized).
        pub encode: u32,
    }
}

/// `c` as the shaders number it (0 RGB, 1 R, 2 G, 3 B, 4 A, 5 luminance).
pub fn channel_index(c: Channel) -> u32 {
    match c {
        Channel::Rgb => 0,
        Channel::R => 1,
        Channel::G => 2,
        Channel::B => 3,
        Channel::A => 4,
        Channel::Luma => 5,
    }
}

impl Display {
    /// The pipelines on `gpu`'s device.
    pub fn new(gpu: &Gpu) -> Result<Display, GpuError> {
        let device = gpu.device.clone();
        gpu.scoped(|| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("editor/display"),
                source: wgpu::ShaderSource::Wgsl(SOURCE.into()),
            });
            let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty,
                count: None,
            };
            let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("editor/display"),
                entries: &[
                    entry(
                        0,
                        wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                    ),
                    entry(
                        1,
                        wgpu::BindingType::Texture {
                            sample_type: wgpu::TextureSampleType::Float { filterable: false },
                            view_dimension: wgpu::TextureViewDimension::D2,
                            multisampled: false,
                        },
                    ),
                    entry(
                        2,
                        wgpu::BindingType::StorageTexture {
                            access: wgpu::StorageTextureAccess::WriteOnly,
                            format: wgpu::TextureFormat::Rgba8Unorm,
                            view_dimension: wgpu::TextureViewDimension::D2,
                        },
                    ),
                    entry(
                        3,
                        wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Storage { read_only: false },
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                    ),
                ],
            });
            let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("editor/display"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = |entry: &str| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some("editor/display"),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            };
            Display {
                peak: pipeline("find_peak"),
                show: pipeline("show"),
                layout,
                srgb_view: gpu.info.backend != wgpu::Backend::Gl,
                device: device.clone(),
            }
        })
    }

    /// Draw `src` (a one- or four-channel picture) as `look` says into a new 8-bit texture, on
    /// the GPU: one submission, nothing read back.
    pub fn draw(&self, gpu: &Gpu, src: &GpuTexture, look: Look) -> Result<Shown, GpuError> {
        let factor = look.factor.max(1);
        let size = (src.width.div_ceil(factor), src.height.div_ceil(factor));
        let params = DisplayParams {
            factor,
            channels: if src.format.channels() == 1 { 1 } else { 4 },
            channel: channel_index(look.channel),
            normalise: u32::from(look.normalise),
            gain: 2f32.powf(look.stops),
            out_w: size.0,
            out_h: size.1,
            encode: u32::from(!look.encoded),
        };
        let device = &self.device;
        gpu.scoped(|| {
            let texture = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("editor/display"),
                size: wgpu::Extent3d {
                    width: size.0,
                    height: size.1,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba8Unorm,
                usage: wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: if self.srgb_view {
                    &[wgpu::TextureFormat::Rgba8UnormSrgb]
                } else {
                    &[]
                },
            });
            let uniform = buffer(
                device,
                bytemuck::bytes_of(&params),
                wgpu::BufferUsages::UNIFORM,
            );
            let peak = buffer(device, &[0u8; 4], wgpu::BufferUsages::STORAGE);
            gpu.queue
                .write_buffer(&uniform, 0, bytemuck::bytes_of(&params));
            gpu.queue.write_buffer(&peak, 0, &[0u8; 4]);
            let storage = texture.create_view(&Default::default());
            let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("editor/display"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(src.view()),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::TextureView(&storage),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: peak.as_entire_binding(),
                    },
                ],
            });
            let mut enc = device.create_command_encoder(&Default::default());
            {
                let mut pass = enc.begin_compute_pass(&Default::default());
                pass.set_bind_group(0, &group, &[]);
                let groups = (size.0.div_ceil(8), size.1.div_ceil(8), 1);
                if look.normalise && params.channels == 1 {
                    pass.set_pipeline(&self.peak);
                    pass.dispatch_workgroups(groups.0, groups.1, groups.2);
                }
                pass.set_pipeline(&self.show);
                pass.dispatch_workgroups(groups.0, groups.1, groups.2);
            }
            gpu.queue.submit([enc.finish()]);
            let view = texture.create_view(&wgpu::TextureViewDescriptor {
                format: Some(if self.srgb_view {
                    wgpu::TextureFormat::Rgba8UnormSrgb
                } else {
                    wgpu::TextureFormat::Rgba8Unorm
                }),
                // Sampled only (an sRGB view cannot be a storage binding).
                usage: Some(wgpu::TextureUsages::TEXTURE_BINDING),
                ..Default::default()
            });
            Shown {
                texture,
                view,
                size,
            }
        })
    }
}

/// A buffer of `bytes`' size for `usage` (written by the caller).
fn buffer(device: &wgpu::Device, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("editor/display"),
        size: bytes.len().max(16) as u64,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The bytes of a drawn picture (RGBA, 8 bits each, row by row), read back — for tests and the
/// benchmark's check, never on the window's path.
pub fn read_shown(gpu: &Gpu, shown: &Shown) -> Result<Vec<[u8; 4]>, GpuError> {
    let (w, h) = shown.size;
    let row = (w * 4).div_ceil(256) * 256;
    let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("editor/display read"),
        size: u64::from(row * h),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        shown.texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    gpu.queue.submit([enc.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    gpu.wait()?;
    rx.recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let data = staging
        .get_mapped_range(..)
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h as usize {
        let line = &data[y * row as usize..y * row as usize + w as usize * 4];
        out.extend(line.chunks_exact(4).map(|p| [p[0], p[1], p[2], p[3]]));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_parameter_block_matches_the_shader() {
        crate::gpu::check_uniform_layout(SOURCE, &DisplayParams::LAYOUT)
            .unwrap_or_else(|e| panic!("{e}"));
    }
}
