//! A scene uploaded for rasterisation: one vertex and one index buffer, a range per object.

use std::any::Any;
use std::collections::HashMap;
use std::ops::Range;
use std::sync::Arc;

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
    /// Keeps the shared buffers (and what nodes derived from them) findable by the next upload
    /// of the same geometry.
    shared: std::sync::Arc<SharedGeometry>,
}

/// What scenes of the same geometry share on one GPU: the mesh buffers, and what nodes derive
/// from the geometry once ([`GpuScene::derived`]: a ray-casting BVH of a set of objects…).
struct SharedGeometry {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    /// Derived values by the deriving caller's key (and type).
    derived: std::sync::Mutex<HashMap<(u64, std::any::TypeId), Arc<dyn Any + Send + Sync>>>,
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
        let (shared, geometry_reused) = gpu.shared_by_key(parts.geometry, || {
            let (vertices, indices) = upload_geometry(gpu, &scene)?;
            Ok(SharedGeometry {
                vertices,
                indices,
                derived: Default::default(),
            })
        })?;
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
            vertices: shared.vertices.clone(),
            indices: shared.indices.clone(),
            ranges,
            geometry_reused,
            shared,
        })
    }

    /// The value `make` derives from this scene's geometry for `key` (what else it depends on,
    /// e.g. the objects selected), made once per geometry and kept while any scene of that
    /// geometry is held: the next frame of a shot whose camera or light moves gets it again
    /// without making it. The second value says whether it was made earlier.
    pub fn derived<T: Any + Send + Sync>(
        &self,
        key: u64,
        make: impl FnOnce() -> Result<T, GpuError>,
    ) -> Result<(Arc<T>, bool), GpuError> {
        let slot = (key, std::any::TypeId::of::<T>());
        let held = self
            .shared
            .derived
            .lock()
            .ok()
            .and_then(|m| m.get(&slot).cloned())
            .and_then(|v| v.downcast::<T>().ok());
        if let Some(v) = held {
            return Ok((v, true));
        }
        let v = Arc::new(make()?);
        if let Ok(mut m) = self.shared.derived.lock() {
            let any: Arc<dyn Any + Send + Sync> = v.clone();
            m.insert(slot, any);
        }
        Ok((v, false))
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

/// The vertices and indices of every object of `scene` as one mesh, indices offset into the
/// shared vertex list: the layout [`GpuScene::ranges`] index into (object `i`'s triangles are
/// `indices[ranges[i]]`).
pub fn flatten(scene: &Scene) -> (Vec<MeshVertex>, Vec<u32>) {
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
    (verts, idx)
}

/// The vertex and index buffers of every object of `scene` ([`flatten`]), with one degenerate
/// triangle for an empty scene.
fn upload_geometry(gpu: &Gpu, scene: &Scene) -> Result<(wgpu::Buffer, wgpu::Buffer), GpuError> {
    let (mut verts, mut idx) = flatten(scene);
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
