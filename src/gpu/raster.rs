//! Rasterising triangle meshes into float targets (shadow maps, G-buffers).

use std::ops::Range;
use std::sync::Arc;

use bytemuck::{Pod, Zeroable};

use super::{Gpu, GpuError, GpuTexture, Shader, TexFormat};

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

/// Indexed triangles to draw: ranges of the index buffer.
pub struct MeshDraw<'a> {
    /// Vertex buffer of [`MeshVertex`].
    pub vertices: &'a wgpu::Buffer,
    /// `u32` index buffer.
    pub indices: &'a wgpu::Buffer,
    /// Index ranges to draw.
    pub ranges: &'a [Range<u32>],
}

impl Gpu {
    fn raster_pipeline(
        &self,
        shader: Shader,
        formats: &[TexFormat],
    ) -> Result<Arc<wgpu::RenderPipeline>, GpuError> {
        let key = format!("{}:raster:{formats:?}", shader.stem);
        let mut cache = match self.render_pipelines.lock() {
            Ok(c) => c,
            Err(p) => p.into_inner(),
        };
        if let Some(p) = cache.get(&key) {
            return Ok(p.clone());
        }
        let p = self.scoped(|| {
            let bgl = self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(&key),
                entries: &[wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                }],
            });
            let layout = self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(&key),
                bind_group_layouts: &[Some(&bgl)],
                immediate_size: 0,
            });
            let module = self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(shader.stem),
                source: wgpu::ShaderSource::Wgsl(shader.source.into()),
            });
            let targets: Vec<Option<wgpu::ColorTargetState>> = formats
                .iter()
                .map(|f| Some(wgpu::ColorTargetState { format: f.wgpu(), blend: None, write_mask: wgpu::ColorWrites::ALL }))
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
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &targets,
                }),
                multiview_mask: None,
                cache: None,
            }))
        })?;
        cache.insert(key, p.clone());
        Ok(p)
    }

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
        let formats: Vec<TexFormat> = targets.iter().map(|t| t.texture.format).collect();
        let pipeline = self.raster_pipeline(shader, &formats)?;
        self.scoped(|| {
            let depth = self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("depth"),
                size: wgpu::Extent3d {
                    width: w,
                    height: h,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Depth32Float,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            });
            let depth_view = depth.create_view(&Default::default());
            let mut padded = uniform.to_vec();
            padded.resize(uniform.len().div_ceil(16).max(1) * 16, 0);
            let buf = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("raster uniform"),
                size: padded.len() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            self.queue.write_buffer(&buf, 0, &padded);
            let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(shader.stem),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: buf.as_entire_binding(),
                }],
            });
            let attachments: Vec<Option<wgpu::RenderPassColorAttachment>> = targets
                .iter()
                .map(|t| {
                    Some(wgpu::RenderPassColorAttachment {
                        view: t.texture.view(),
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color {
                                r: t.clear[0],
                                g: t.clear[1],
                                b: t.clear[2],
                                a: t.clear[3],
                            }),
                            store: wgpu::StoreOp::Store,
                        },
                    })
                })
                .collect();
            let timer = self.pass_timer();
            let mut enc = self.device.create_command_encoder(&Default::default());
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
                    timestamp_writes: timer.as_ref().map(|t| wgpu::RenderPassTimestampWrites {
                        query_set: &t.query,
                        beginning_of_pass_write_index: Some(0),
                        end_of_pass_write_index: Some(1),
                    }),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                for r in mesh.ranges {
                    if !r.is_empty() {
                        pass.draw_indexed(r.clone(), 0, 0..1);
                    }
                }
            }
            if let Some(t) = &timer {
                self.resolve_timer(t, &mut enc);
            }
            self.queue.submit([enc.finish()]);
            timer.map_or(Ok(()), |t| self.read_timer(t))
        })?
    }
}
