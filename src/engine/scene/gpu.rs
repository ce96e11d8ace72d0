//! A scene uploaded for rasterisation: one vertex and one index buffer, a range per object, and
//! a placement (object → world matrix) per object.
//!
//! Meshes are uploaded once per content ([`super::PartKeys::meshes`]) while a scene of the same
//! meshes is held: a shot whose camera or lights move uploads them once. An object a glTF
//! animation moves is uploaded in its own space ([`super::Placement`]) and placed by its matrix
//! in the vertex shader, so moving it changes one matrix per frame, not its mesh; every other
//! object is uploaded in world space with the identity placement (which moves nothing, bit for
//! bit).

use std::any::Any;
use std::collections::HashMap;
use std::ops::Range;
use std::sync::Arc;

use glam::{Mat3, Mat4};

pub use crate::gpu::MeshVertex;
use crate::gpu::{Gpu, GpuError};

use super::Scene;

/// Floats per object in [`GpuScene::placements`]: the object → world matrix, then the normal
/// matrix (the inverse transpose of its upper 3 × 3, as a 4 × 4), both column-major — the
/// `Placement` struct the raster shaders read at their instance index.
pub const PLACEMENT_FLOATS: usize = 32;

/// Derived values kept per geometry ([`GpuScene::derived`]); the oldest is dropped beyond this
/// (an animated shot derives one per frame).
const DERIVED_KEPT: usize = 8;

/// A scene on the GPU, with its CPU description (camera, sun, tags, bounds).
pub struct GpuScene {
    /// The scene as built or loaded, camera and sun already overridden by node parameters.
    pub scene: Scene,
    /// Vertices of all objects (a placed object's in its own space).
    pub vertices: wgpu::Buffer,
    /// Indices of all objects (already offset into the shared vertex buffer).
    pub indices: wgpu::Buffer,
    /// Index range of each object, in `scene.objects` order.
    pub ranges: Vec<Range<u32>>,
    /// Each object's placement, [`PLACEMENT_FLOATS`] floats per object in `scene.objects`
    /// order (a storage buffer; draw object `i` as instance `i`).
    pub placements: wgpu::Buffer,
    /// A content key per part of `scene` (what a node declaring the parts it reads is keyed on).
    pub parts: super::PartKeys,
    /// Whether `vertices` and `indices` are those of an earlier upload of the same meshes
    /// still held (the scene of the previous frame when only the camera, the lights or the
    /// placements of moving objects changed), not uploaded again.
    pub geometry_reused: bool,
    /// Keeps the shared buffers (and what nodes derived from them) findable by the next upload
    /// of the same meshes.
    shared: Arc<SharedGeometry>,
}

/// Derived values by the deriving caller's key (and type), with the order they were made in.
type Derived = HashMap<(u64, std::any::TypeId), (u64, Arc<dyn Any + Send + Sync>)>;

/// What scenes of the same meshes share on one GPU: the mesh buffers, and what nodes derive
/// from the geometry ([`GpuScene::derived`]: a ray-casting BVH of a set of objects…).
struct SharedGeometry {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    derived: std::sync::Mutex<Derived>,
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
    /// Upload `scene`: its meshes only when no scene of the same meshes is held on this GPU
    /// ([`Gpu::shared_by_key`] on [`super::PartKeys::meshes`]), its placements always.
    pub fn upload(gpu: &Gpu, scene: Scene) -> Result<GpuScene, GpuError> {
        let parts = super::PartKeys::of(&scene);
        let (shared, geometry_reused) = gpu.shared_by_key(parts.meshes, || {
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
        let placements = upload_placements(gpu, &scene)?;
        Ok(GpuScene {
            parts,
            scene,
            vertices: shared.vertices.clone(),
            indices: shared.indices.clone(),
            ranges,
            placements,
            geometry_reused,
            shared,
        })
    }

    /// The value `make` derives from this scene's geometry for `key` (what else it depends on:
    /// the objects selected, and the placements when it uses world-space positions), made once
    /// and kept while any scene of the same meshes is held — the next frame of a shot whose
    /// camera or light moves gets it again without making it. The eight latest
    /// values are kept per geometry. The second value says whether it was made earlier.
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
            .and_then(|m| m.get(&slot).map(|(_, v)| v.clone()))
            .and_then(|v| v.downcast::<T>().ok());
        if let Some(v) = held {
            return Ok((v, true));
        }
        let v = Arc::new(make()?);
        if let Ok(mut m) = self.shared.derived.lock() {
            let order = m.values().map(|(n, _)| n + 1).max().unwrap_or(0);
            while m.len() >= DERIVED_KEPT {
                let oldest = m.iter().min_by_key(|(_, (n, _))| *n).map(|(k, _)| *k);
                match oldest {
                    Some(k) => m.remove(&k),
                    None => break,
                };
            }
            let any: Arc<dyn Any + Send + Sync> = v.clone();
            m.insert(slot, (order, any));
        }
        Ok((v, false))
    }

    /// Every object's draw: its index (the instance whose placement the vertex shader reads)
    /// and its index range.
    pub fn draws(&self) -> Vec<(u32, Range<u32>)> {
        self.select(&[], &[])
    }

    /// The draws ([`GpuScene::draws`]) of the objects whose tags pass the filter: with a
    /// non-empty `include`, an object needs one of its tags; an object with a tag in `exclude`
    /// is left out.
    pub fn select(&self, include: &[String], exclude: &[String]) -> Vec<(u32, Range<u32>)> {
        self.scene
            .objects
            .iter()
            .zip(&self.ranges)
            .enumerate()
            .filter(|(_, (o, _))| include.is_empty() || o.tags.iter().any(|t| include.contains(t)))
            .filter(|(_, (o, _))| !o.tags.iter().any(|t| exclude.contains(t)))
            .map(|(i, (_, r))| (i as u32, r.clone()))
            .collect()
    }

    /// GPU memory held, in bytes.
    pub fn bytes(&self) -> usize {
        (self.vertices.size() + self.indices.size() + self.placements.size()) as usize
    }
}

/// The vertices and indices of every object of `scene` as one world-space mesh, indices offset
/// into the shared vertex list: the layout [`GpuScene::ranges`] index into (object `i`'s
/// triangles are `indices[ranges[i]]`).
pub fn flatten(scene: &Scene) -> (Vec<MeshVertex>, Vec<u32>) {
    flatten_with(scene, false)
}

/// [`flatten`], with a placed object's mesh in its own space when `local` (what is uploaded).
fn flatten_with(scene: &Scene, local: bool) -> (Vec<MeshVertex>, Vec<u32>) {
    let mut verts: Vec<MeshVertex> = Vec::new();
    let mut idx: Vec<u32> = Vec::new();
    for o in &scene.objects {
        let base = verts.len() as u32;
        let (positions, normals) = match (&o.placement, local) {
            (Some(p), true) => (&p.mesh.positions, &p.mesh.normals),
            _ => (&o.positions, &o.normals),
        };
        for (p, n) in positions.iter().zip(normals) {
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

/// The vertex and index buffers of every object of `scene` (placed objects in their own
/// space), with one degenerate triangle for an empty scene.
fn upload_geometry(gpu: &Gpu, scene: &Scene) -> Result<(wgpu::Buffer, wgpu::Buffer), GpuError> {
    let (mut verts, mut idx) = flatten_with(scene, true);
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
    gpu.scoped(|| {
        (
            buffer(
                gpu,
                "vertices",
                bytemuck::cast_slice(&verts),
                wgpu::BufferUsages::VERTEX,
            ),
            buffer(
                gpu,
                "indices",
                bytemuck::cast_slice(&idx),
                wgpu::BufferUsages::INDEX,
            ),
        )
    })
}

/// The placements of `scene`'s objects ([`PLACEMENT_FLOATS`] each; the identity for an object
/// drawn in world space, and one identity for an empty scene).
fn upload_placements(gpu: &Gpu, scene: &Scene) -> Result<wgpu::Buffer, GpuError> {
    let placement = |world: Mat4| {
        let normal = Mat4::from_mat3(Mat3::from_mat4(world).inverse().transpose());
        let mut f = [0f32; PLACEMENT_FLOATS];
        f[..16].copy_from_slice(&world.to_cols_array());
        f[16..].copy_from_slice(&normal.to_cols_array());
        f
    };
    let mut floats: Vec<f32> = scene
        .objects
        .iter()
        .flat_map(|o| placement(o.placement.as_ref().map_or(Mat4::IDENTITY, |p| p.world)))
        .collect();
    if floats.is_empty() {
        floats.extend(placement(Mat4::IDENTITY));
    }
    gpu.scoped(|| {
        buffer(
            gpu,
            "placements",
            bytemuck::cast_slice(&floats),
            wgpu::BufferUsages::STORAGE,
        )
    })
}

/// A new buffer holding `bytes`, written through the queue (a new buffer: nothing recorded
/// reads it yet).
fn buffer(gpu: &Gpu, label: &str, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
    let b = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.len() as u64,
        usage: usage | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&b, 0, bytes);
    b
}
