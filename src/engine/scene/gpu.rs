//! A scene uploaded for rasterisation: one vertex and one index buffer, a range per object.

use std::ops::Range;

pub use crate::gpu::MeshVertex;
use crate::gpu::{Gpu, GpuError};

use super::Scene;

/// A scene on the GPU, with its CPU description (camera, sun, tags, bounds).
pub struct GpuScene {
    /// The scene as built or loaded, camera and sun already overridden by node parameters.
    pub scene: Scene,
    /// Vertices of all objects.
    pub vertices: wgpu::Buffer,
    /// Indices of all objects (already offset into the shared vertex buffer).
    pub indices: wgpu::Buffer,
    /// Index range of each object, in `scene.objects` order.
    pub ranges: Vec<Range<u32>>,
    /// A content key per part of `scene` (what a node declaring the parts it reads is keyed on).
    pub parts: super::PartKeys,
}

impl std::fmt::Debug for GpuScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "GpuScene({} objects, {} triangles)",
            self.scene.objects.len(),
            self.scene.triangles()
        )
    }
}

impl GpuScene {
    /// Upload `scene`.
    pub fn upload(gpu: &Gpu, scene: Scene) -> Result<GpuScene, GpuError> {
        let mut verts: Vec<MeshVertex> = Vec::new();
        let mut idx: Vec<u32> = Vec::new();
        let mut ranges = Vec::new();
        for o in &scene.objects {
            let base = verts.len() as u32;
            for (p, n) in o.positions.iter().zip(&o.normals) {
                verts.push(MeshVertex {
                    position: p.to_array(),
                    normal: n.to_array(),
                    colour: o.colour,
                });
            }
            let start = idx.len() as u32;
            idx.extend(o.indices.iter().map(|i| i + base));
            ranges.push(start..idx.len() as u32);
        }
        if verts.is_empty() {
            verts.push(MeshVertex {
                position: [0.0; 3],
                normal: [0.0, 1.0, 0.0],
                colour: [0.0; 4],
            });
        }
        if idx.is_empty() {
            idx.extend_from_slice(&[0, 0, 0]);
        }
        let (vertices, indices) = gpu.scoped(|| {
            let make = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
                let b = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes.len() as u64,
                    usage: usage | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                gpu.queue.write_buffer(&b, 0, bytes);
                b
            };
            (
                make(
                    "vertices",
                    bytemuck::cast_slice(&verts),
                    wgpu::BufferUsages::VERTEX,
                ),
                make(
                    "indices",
                    bytemuck::cast_slice(&idx),
                    wgpu::BufferUsages::INDEX,
                ),
            )
        })?;
        Ok(GpuScene {
            parts: super::PartKeys::of(&scene),
            scene,
            vertices,
            indices,
            ranges,
        })
    }

    /// Index ranges of the objects whose tags pass the filter: with a non-empty `include`, an
    /// object needs one of its tags; an object with a tag in `exclude` is left out.
    pub fn select(&self, include: &[String], exclude: &[String]) -> Vec<Range<u32>> {
        self.scene
            .objects
            .iter()
            .zip(&self.ranges)
            .filter(|(o, _)| include.is_empty() || o.tags.iter().any(|t| include.contains(t)))
            .filter(|(o, _)| !o.tags.iter().any(|t| exclude.contains(t)))
            .map(|(_, r)| r.clone())
            .collect()
    }

    /// GPU memory held, in bytes.
    pub fn bytes(&self) -> usize {
        (self.vertices.size() + self.indices.size()) as usize
    }
}
