//! The parts of a scene a node can read — camera, lights, geometry, medium bounds, volume
//! objects — and a
//! content key for each, so that a node declaring the parts it reads (`NodeDecl::scene_parts`)
//! is keyed on those alone: a change of the lights re-runs the shadow map but reuses the
//! G-buffer.

use std::hash::{DefaultHasher, Hash, Hasher};

use super::Scene;

/// One part of a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ScenePart {
    /// The camera: position, target, field of view, near and far.
    Camera,
    /// The lights (every [`Scene::lights`] entry: kind, placement, colour, intensity, range).
    Lights,
    /// The objects: names (object, node, material), vertices, normals, indices, colours and tags.
    Geometry,
    /// The bounds of the objects tagged `medium`.
    Medium,
    /// The objects naming OpenVDB files ([`Scene::volumes`]: names, files, stamps, placements).
    Volumes,
}

/// A content key per part of a scene (equal keys: equal parts).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct PartKeys {
    /// Of [`ScenePart::Camera`].
    pub camera: u64,
    /// Of [`ScenePart::Lights`].
    pub lights: u64,
    /// Of [`ScenePart::Geometry`].
    pub geometry: u64,
    /// Of [`ScenePart::Medium`].
    pub medium: u64,
    /// Of [`ScenePart::Volumes`].
    pub volumes: u64,
    /// Of the meshes as uploaded to the GPU: a placed object's mesh in its own space (not its
    /// placement), every other object's world-space mesh, with indices and colours. Not a part
    /// a node reads: equal keys share vertex and index buffers (`GpuScene::upload`), so an
    /// animation that only moves objects uploads no mesh after its first frame.
    pub meshes: u64,
}

impl PartKeys {
    /// The keys of `scene`'s parts (the geometry's costs one pass over its vertices).
    pub fn of(scene: &Scene) -> Self {
        let key = |f: &dyn Fn(&mut DefaultHasher)| {
            let mut h = DefaultHasher::new();
            f(&mut h);
            h.finish()
        };
        let bits = |v: &[f32], h: &mut DefaultHasher| v.iter().for_each(|x| x.to_bits().hash(h));
        let c = &scene.camera;
        Self {
            camera: key(&|h| {
                bits(&c.position.to_array(), h);
                bits(&c.target.to_array(), h);
                bits(&[c.fov_y, c.near, c.far], h);
            }),
            lights: key(&|h| {
                for l in &scene.lights {
                    format!("{l:?}").hash(h);
                }
            }),
            geometry: key(&|h| {
                for o in &scene.objects {
                    (&o.name, &o.node, &o.material, &o.tags, &o.indices).hash(h);
                    bits(&o.colour, h);
                    for (p, n) in o.positions.iter().zip(&o.normals) {
                        bits(&p.to_array(), h);
                        bits(&n.to_array(), h);
                    }
                    (o.positions.len(), o.normals.len()).hash(h);
                }
            }),
            meshes: key(&|h| {
                for o in &scene.objects {
                    o.indices.hash(h);
                    bits(&o.colour, h);
                    match &o.placement {
                        Some(p) => p.mesh.key.hash(h),
                        None => {
                            for (p, n) in o.positions.iter().zip(&o.normals) {
                                bits(&p.to_array(), h);
                                bits(&n.to_array(), h);
                            }
                            (o.positions.len(), o.normals.len()).hash(h);
                        }
                    }
                }
            }),
            medium: key(&|h| {
                if let Some((lo, hi)) = &scene.medium {
                    bits(&lo.to_array(), h);
                    bits(&hi.to_array(), h);
                }
                scene.medium.is_some().hash(h);
            }),
            volumes: key(&|h| {
                for v in &scene.volumes {
                    (&v.name, &v.file, &v.frame_file, v.stamp).hash(h);
                    bits(&v.world.to_cols_array(), h);
                }
            }),
        }
    }

    /// One key of the parts `parts` (in that order).
    pub fn select(&self, parts: &[ScenePart]) -> u64 {
        let mut h = DefaultHasher::new();
        for p in parts {
            match p {
                ScenePart::Camera => self.camera,
                ScenePart::Lights => self.lights,
                ScenePart::Geometry => self.geometry,
                ScenePart::Medium => self.medium,
                ScenePart::Volumes => self.volumes,
            }
            .hash(&mut h);
        }
        h.finish()
    }
}
