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
    /// Whether `vertices` and `indices` are those of an earlier upload of the same geometry
    /// still held (the scene of the previous frame when only the camera or the sun moved), not
    /// uploaded again.
    pub geometry_reused: bool,
    /// Keeps the shared buffers findable by the next upload of the same geometry.
    _buffers: std::sync::Arc<(wgpu::Buffer, wgpu::Buffer)>,
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
    /// Upload `scene`: its geometry only when no scene of the same geometry is held on this
    /// GPU ([`Gpu::shared_by_key`] on the geometry key of [`super::PartKeys`]) — a shot whose
    /// camera or sun moves uploads its meshes once.
    pub fn upload(gpu: &Gpu, scene: Scene) -> Result<GpuScene, GpuError> {
        let parts = super::PartKeys::of(&scene);
        let (buffers, geometry_reused) =
            gpu.shared_by_key(parts.geometry, || upload_geometry(gpu, &scene))?;
        let mut ranges = Vec::new();
        let mut start = 0u32;
        for o in &scene.objects {
            let end = start + o.indices.len() as u32;
            ranges.push(start..end);
            start = end;
        }
        Ok(GpuScene {
            parts,
            scene,
            vertices: buffers.0.clone(),
            indices: buffers.1.clone(),
            ranges,
            geometry_reused,
            _buffers: buffers,
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

/// The vertex and index buffers of every object of `scene` (indices offset into the shared
/// vertex buffer), with one degenerate triangle for an empty scene.
fn upload_geometry(gpu: &Gpu, scene: &Scene) -> Result<(wgpu::Buffer, wgpu::Buffer), GpuError> {
    let mut verts: Vec<MeshVertex> = Vec::new();
    let mut idx: Vec<u32> = Vec::new();
    for o in &scene.objects {
        let base = verts.len() as u32;
        for (p, n) in o.positions.iter().zip(&o.normals) {
            verts.push(MeshVertex {
                position: p.to_array(),
                normal: n.to_array(),
                colour: o.colour,
            });
        }
        idx.extend(o.indices.iter().map(|i| i + base));
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
    Ok((vertices, indices))
}
