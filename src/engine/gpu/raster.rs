//! Rasterising triangle meshes into float targets (shadow maps, G-buffers): a raster shader's
//! `vs` gets each vertex with its object's placement (group 1: `scene::PLACEMENT_FLOATS` floats
//! per object, object `i` drawn as instance `i`), its `fs` writes the targets.
//!
//! Where the adapter cannot render into 32-bit float formats (wgpu's GL backend on Mesa), the
//! pass renders the same values as bit patterns into 32-bit unsigned-integer targets and turns
//! them back into floats, bit-identical to the float path (`raster_bits.rs`).

use std::ops::Range;
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::{Gpu, GpuError, GpuTexture, Recorder, Shader};

/// The vertex every mesh is drawn with: position, normal, linear RGBA colour (40 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct MeshVertex {
    /// World-space position.
    pub position: [f32; 3],
    /// World-space unit normal.
    pub normal: [f32; 3],
    /// Linear RGBA base colour.
    pub colour: [f32; 4],
}

/// A colour target of a raster pass and the value it is cleared to.
pub struct RasterTarget<'a> {
    /// The texture written by fragment output `location(i)` for the i-th target.
    pub texture: &'a GpuTexture,
    /// Clear value.
    pub clear: [f64; 4],
}

/// Indexed triangles to draw: ranges of the index buffer, each an object placed by its matrix.
pub struct MeshDraw<'a> {
    /// Vertex buffer of [`MeshVertex`].
    pub vertices: &'a wgpu::Buffer,
    /// `u32` index buffer.
    pub indices: &'a wgpu::Buffer,
    /// The objects' placements (a storage buffer, `scene::PLACEMENT_FLOATS` floats each), bound
    /// at group 1, binding 0; the raster shader reads object `i`'s at instance index `i`.
    pub placements: &'a wgpu::Buffer,
    /// What to draw: `(object, index range)`.
    pub ranges: &'a [(u32, Range<u32>)],
}

impl Gpu {
    fn raster_pipeline(
        &self,
        shader: Shader,
        formats: &[wgpu::TextureFormat],
        bits: bool,
        params_in_storage: bool,
    ) -> Result<Arc<wgpu::RenderPipeline>, GpuError> {
        let key = format!("{}:raster:{formats:?}:{params_in_storage}", shader.stem);
        let wgsl = shader.wgsl().map_err(GpuError::Validation)?;
        let noted = format!("{wgsl}|bits={bits}");
        let source = if bits {
            wgpu::ShaderSource::Naga(std::borrow::Cow::Owned(
                super::raster_bits::bits_module(&self.caps.adapt_source(wgsl, params_in_storage))
                    .map_err(|e| {
                    GpuError::Validation(format!("shader {}.wgsl, entry fs: {e}", shader.stem))
                })?,
            ))
        } else {
            wgpu::ShaderSource::Wgsl(self.caps.adapt_source(wgsl, params_in_storage))
        };
        let fs_entry = if bits {
            super::raster_bits::BITS_ENTRY
        } else {
            "fs"
        };
        let mut cache = match self.render_pipelines.lock() {
            Ok(c) => c,
            Err(p) => p.into_inner(),
        };
        if let Some(p) = cache.get(&key) {
            return Ok(p.clone());
        }
        self.disk.note(&key, &noted);
        let created = std::time::Instant::now();
        let p = self.scoped(|| {
            let bgl = self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(&key),
                entries: &[wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: super::adapter::Capabilities::params_binding(params_in_storage),
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                }],
            });
            // Group 1: the objects' placements, read by the vertex shader.
            let placements = self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("placements"),
                entries: &[wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                }],
            });
            let layout = self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(&key),
                bind_group_layouts: &[Some(&bgl), Some(&placements)],
                immediate_size: 0,
            });
            let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(shader.stem),
                source,
            });
            let targets: Vec<Option<wgpu::ColorTargetState>> = formats
                .iter()
                .map(|f| Some(wgpu::ColorTargetState { format: *f, blend: None, write_mask: wgpu::ColorWrites::ALL }))
                .collect();
            Arc::new(self.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(&key),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<MeshVertex>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4],
                    })],
                },
                primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: wgpu::TextureFormat::Depth32Float,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs_entry),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: self.disk.cache.as_ref(),
            }))
        })?;
        crate::trace::pipeline_created(&key, created);
        cache.insert(key, p.clone());
        Ok(p)
    }

    /// The render-target format of each stored format: itself where the adapter renders to it,
    /// else the integer format its bit patterns go through.
    fn render_formats(
        &self,
        stored: &[wgpu::TextureFormat],
    ) -> Result<Vec<wgpu::TextureFormat>, GpuError> {
        stored
            .iter()
            .map(|f| {
                self.caps
                    .render_format(*f)
                    .ok_or_else(|| GpuError::Unsupported {
                        adapter: self.describe(),
                        lacks: format!("a render target for {f:?} values"),
                    })
            })
            .collect()
    }

    /// The bind group of a raster pass: its uniform bytes at binding 0 (padded to 16 bytes).
    fn uniform_group(
        &self,
        shader: Shader,
        pipeline: &wgpu::RenderPipeline,
        uniform: &[u8],
        params_in_storage: bool,
    ) -> wgpu::BindGroup {
        let mut padded = uniform.to_vec();
        padded.resize(uniform.len().div_ceil(16).max(1) * 16, 0);
        let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("raster uniform"),
            size: padded.len() as u64,
            usage: super::adapter::Capabilities::params_usage(params_in_storage),
            mapped_at_creation: false,
        });
        self.queue.write_buffer(&buf, 0, &padded);
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(shader.stem),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: buf.as_entire_binding(),
            }],
        })
    }

    /// A single-level 2D texture of a raster pass (depth buffer, bit-pattern target).
    fn attachment(
        &self,
        label: &str,
        (width, height): (u32, u32),
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        super::pool::texture_2d(&self.device, label, (width, height), format, usage)
    }
}

impl Recorder<'_> {
    /// Draw `mesh` with the shader's `vs`/`fs` entry points into `targets` (all the same size),
    /// with a fresh depth buffer (less-than test) and the uniform bytes at binding 0.
    pub fn raster(
        &self,
        shader: Shader,
        uniform: &[u8],
        targets: &[RasterTarget],
        mesh: &MeshDraw,
    ) -> Result<(), GpuError> {
        let first = targets
            .first()
            .ok_or_else(|| GpuError::Validation("raster pass without targets".into()))?;
        let (w, h) = (first.texture.width, first.texture.height);
        let stored: Vec<wgpu::TextureFormat> = targets.iter().map(|t| t.texture.stored()).collect();
        let formats = self.render_formats(&stored)?;
        let bits = formats != stored;
        let storage = self.caps.params_in_storage(u64::from(w) * u64::from(h));
        let pipeline = self.raster_pipeline(shader, &formats, bits, storage)?;
        // The bit-pattern path renders into integer textures of the same size.
        let temps: Vec<(wgpu::Texture, wgpu::TextureView)> = if bits {
            formats
                .iter()
                .map(|f| {
                    let t = self.attachment(
                        "raster bits",
                        (w, h),
                        *f,
                        wgpu::TextureUsages::RENDER_ATTACHMENT
                            | wgpu::TextureUsages::TEXTURE_BINDING,
                    );
                    let v = t.create_view(&Default::default());
                    (t, v)
                })
                .collect()
        } else {
            Vec::new()
        };
        self.scoped(|| {
            let depth = self.attachment(
                "depth",
                (w, h),
                wgpu::TextureFormat::Depth32Float,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            );
            let depth_view = depth.create_view(&Default::default());
            let group = self.uniform_group(shader, &pipeline, uniform, storage);
            let placed = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("placements"),
                layout: &pipeline.get_bind_group_layout(1),
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: mesh.placements.as_entire_binding(),
                }],
            });
            let attachments = color_attachments(targets, &temps, bits);
            // Into the recorder's encoder; timed, with its timestamps resolved in it.
            let record = |enc: &mut wgpu::CommandEncoder,
                          timer: Option<&super::PassTimer>|
             -> Result<(), GpuError> {
                {
                    let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                        label: Some(shader.stem),
                        color_attachments: &attachments,
                        depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                            view: &depth_view,
                            depth_ops: Some(wgpu::Operations {
                                load: wgpu::LoadOp::Clear(1.0),
                                store: wgpu::StoreOp::Discard,
                            }),
                            stencil_ops: None,
                        }),
                        timestamp_writes: timer.map(|t| wgpu::RenderPassTimestampWrites {
                            query_set: &t.query,
                            beginning_of_pass_write_index: Some(0),
                            end_of_pass_write_index: Some(1),
                        }),
                        occlusion_query_set: None,
                        multiview_mask: None,
                    });
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &group, &[]);
                    pass.set_bind_group(1, &placed, &[]);
                    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                    for (object, r) in mesh.ranges {
                        if !r.is_empty() {
                            pass.draw_indexed(r.clone(), 0, *object..*object + 1);
                        }
                    }
                }
                if let Some(t) = timer {
                    self.resolve_timer(t, enc);
                }
                for ((_, bits), target) in temps.iter().zip(targets) {
                    self.unbits(enc, bits, target.texture)?;
                }
                Ok(())
            };
            for t in targets {
                self.uses(t.texture);
            }
            match self.pass_timer(shader.stem) {
                None => self.encode(|enc| record(enc, None)),
                Some(timer) => {
                    self.encode(|enc| record(enc, Some(&timer)))?;
                    self.keep_timer(timer);
                    Ok(())
                }
            }
        })?
    }
}

/// The colour attachments of a raster pass: each target (or its bit-pattern stand-in),
/// cleared to its clear value.
fn color_attachments<'a>(
    targets: &'a [RasterTarget],
    temps: &'a [(wgpu::Texture, wgpu::TextureView)],
    bits: bool,
) -> Vec<Option<wgpu::RenderPassColorAttachment<'a>>> {
    // Integer targets are cleared to the bit patterns of the float clear values.
    let clear = |v: f64| if bits { (v as f32).to_bits() as f64 } else { v };
    targets
        .iter()
        .enumerate()
        .map(|(i, t)| {
            Some(wgpu::RenderPassColorAttachment {
                view: temps.get(i).map_or(t.texture.view(), |(_, v)| v),
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: clear(t.clear[0]),
                        g: clear(t.clear[1]),
                        b: clear(t.clear[2]),
                        a: clear(t.clear[3]),
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })
        })
        .collect()
}
