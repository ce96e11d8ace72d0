//! Posing an asset: the scene at a time of its animations (`GltfAsset::pose`) — node
//! transforms with the channels applied, meshes placed in world space (and, for the objects an
//! animation moves, kept in their own space with the matrix placing them), the first camera
//! and the lights.

use std::path::Path;

use glam::{Mat3, Mat4, Vec3};

use super::animation::Animation;
use super::{err, AssetNode, GltfAsset, Primitive, LUX_PER_WATT, MEDIUM_TAG};
use crate::scene::{
    Camera, Light, LightKind, Object, Placement, Scene, SceneError, Sun, VolumeObject,
};

/// The name of the sun a glTF file with no lights at all is lit by (`tyndall validate` lists
/// it): a white 3 W/m² sun 60° up at azimuth 30°, so that such a file still renders.
pub const DEFAULT_SUN: &str = "default_sun";

/// The sun of a file with no lights (see [`DEFAULT_SUN`]).
fn default_sun() -> Sun {
    Sun {
        azimuth: 30.0,
        elevation: 60.0,
        colour: [1.0; 3],
        intensity: 3.0,
    }
}

impl GltfAsset {
    /// The scene at `seconds` of `animation` (`None`: the rest pose): node transforms with the
    /// animation's channels applied, meshes in world space, the first camera and every light
    /// in the scene's node order. The camera defaults to a view of the bounds when the file
    /// has none; a file with no lights at all gets [`DEFAULT_SUN`] (a file with any light gets
    /// only its own: with a spot alone it has no sun).
    pub fn pose(&self, animations: &[usize], seconds: f32) -> Result<Scene, SceneError> {
        let path = Path::new(&self.path);
        let anim: Vec<&Animation> = animations
            .iter()
            .filter_map(|i| self.animations.get(*i))
            .collect();
        let mut objects = Vec::new();
        let mut camera = None;
        let mut lights = Vec::new();
        let mut volumes = Vec::new();
        // Nodes the played animations move (and, below, their descendants).
        let keyed: std::collections::HashSet<usize> = anim
            .iter()
            .flat_map(|a| a.channels.iter().map(|c| c.node))
            .collect();
        let mut stack: Vec<(usize, Mat4, bool)> = self
            .roots
            .iter()
            .map(|n| (*n, Mat4::IDENTITY, false))
            .collect();
        // A node listed twice (a cycle or shared child, invalid glTF) is visited once.
        let mut seen = vec![false; self.nodes.len()];
        while let Some((index, parent, parent_moves)) = stack.pop() {
            let Some(node) = self.nodes.get(index) else {
                continue;
            };
            if std::mem::replace(&mut seen[index], true) {
                continue;
            }
            let world = parent * node.rest.animated(index, &anim, seconds).matrix();
            let moves = parent_moves || keyed.contains(&index);
            for child in &node.children {
                stack.push((*child, world, moves));
            }
            let (_, rot, pos) = world.to_scale_rotation_translation();
            let forward = (rot * Vec3::NEG_Z).normalize_or(Vec3::NEG_Z);
            if let (Some((yfov, near, far)), None) = (node.camera, camera) {
                camera = Some(Camera {
                    position: pos,
                    target: pos + forward * 10.0,
                    fov_y: yfov.to_degrees(),
                    near,
                    far,
                });
            }
            if let Some(l) = &node.light {
                let kind = match l.local {
                    None => {
                        let (azimuth, elevation) = Sun::angles_of(-forward);
                        LightKind::Directional { azimuth, elevation }
                    }
                    Some(None) => LightKind::Point { position: pos },
                    Some(Some((inner, outer))) => LightKind::Spot {
                        position: pos,
                        direction: forward,
                        inner,
                        outer,
                    },
                };
                let light = Light {
                    name: node.name.clone(),
                    kind,
                    colour: l.colour,
                    intensity: l.intensity / LUX_PER_WATT,
                    range: l.range,
                };
                lights.push((index, light));
            }
            if let Some(file) = &node.vdb {
                volumes.push((
                    index,
                    VolumeObject {
                        name: node.name.clone(),
                        file: file.clone(),
                        frame_file: file.clone(),
                        stamp: 0,
                        world,
                    },
                ));
            }
            let normal_m = Mat3::from_mat4(world).inverse().transpose();
            for (pi, prim) in node.primitives.iter().enumerate() {
                let mut o = posed(node, pi, prim, world, normal_m);
                if moves {
                    o.placement = Some(Placement {
                        mesh: prim.local.clone(),
                        world,
                    });
                }
                objects.push(o);
            }
        }
        let (media, objects): (Vec<Object>, Vec<Object>) = objects
            .into_iter()
            .partition(|o| o.tags.iter().any(|t| t == MEDIUM_TAG));
        if objects.is_empty() {
            return Err(err(
                path,
                "no triangle meshes (other than the medium's bounds)",
            ));
        }
        let medium = media.iter().flat_map(|o| o.positions.iter()).fold(
            None,
            |b: Option<(Vec3, Vec3)>, p| {
                Some(b.map_or((*p, *p), |(lo, hi)| (lo.min(*p), hi.max(*p))))
            },
        );
        // Lights in the file's node order (the traversal above is depth first from the last
        // root), so that an index names the same light in every pose.
        lights.sort_by_key(|(index, _)| *index);
        let mut lights: Vec<Light> = lights.into_iter().map(|(_, l)| l).collect();
        if lights.is_empty() {
            lights.push(Light::sun(DEFAULT_SUN, default_sun()));
        }
        volumes.sort_by_key(|(index, _)| *index);
        let mut s = Scene {
            objects,
            medium,
            volumes: volumes.into_iter().map(|(_, v)| v).collect(),
            camera: Camera {
                position: Vec3::ZERO,
                target: Vec3::NEG_Z,
                fov_y: 45.0,
                near: 0.1,
                far: 100.0,
            },
            lights,
        };
        s.camera = camera.unwrap_or_else(|| {
            let (lo, hi) = s.bounds();
            let c = (lo + hi) * 0.5;
            let r = ((hi - lo).length() * 0.5).max(1e-3);
            Camera {
                position: c + Vec3::new(1.0, 0.6, 1.0).normalize() * r * 2.5,
                target: c,
                fov_y: 45.0,
                near: r * 0.01,
                far: r * 10.0,
            }
        });
        Ok(s)
    }
}

/// One primitive of `node` placed by `world` (normals by its inverse transpose; computed from
/// the faces when the file gives none).
fn posed(node: &AssetNode, pi: usize, prim: &Primitive, world: Mat4, normal_m: Mat3) -> Object {
    let positions: Vec<Vec3> = prim
        .positions
        .iter()
        .map(|p| world.transform_point3(*p))
        .collect();
    let normals = match &prim.normals {
        Some(n) => n
            .iter()
            .map(|n| (normal_m * *n).normalize_or(Vec3::Y))
            .collect(),
        None => face_normals(&positions, &prim.indices),
    };
    Object {
        name: if pi == 0 {
            node.name.clone()
        } else {
            format!("{}.{pi}", node.name)
        },
        node: node.name.clone(),
        material: prim.material.clone(),
        positions,
        normals,
        indices: prim.indices.clone(),
        colour: prim.colour,
        tags: node.tags.clone(),
        placement: None,
    }
}

/// Vertex normals from the faces around each vertex (area-weighted), for meshes without any.
pub(super) fn face_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [0, 1, 2].map(|k| positions[t[k] as usize]);
        let n = (b - a).cross(c - a);
        for i in t {
            acc[*i as usize] += n;
        }
    }
    acc.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect()
}
