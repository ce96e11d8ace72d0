//! Scenes: meshes with colours and tags, a perspective camera and lights (directional, spot, point);
//! built-in procedural scenes, glTF 2.0 loading, and mesh upload for rasterisation.

mod builtin;
mod gltf;
mod gpu;
mod light;
mod parts;

use glam::{Mat4, Vec3};
use thiserror::Error;

pub use builtin::{builtin, Builtin, BUILTIN_SCENES};
pub use gltf::{
    animation, find_animation, load_gltf, load_gltf_asset, parse_gltf, GltfAsset, DEFAULT_SUN,
    LUX_PER_WATT, MEDIUM_TAG,
};
pub use gpu::PLACEMENT_FLOATS;
pub use gpu::{flatten, GpuScene, MeshVertex};
pub use light::{
    cube_face, face_basis, face_view, local_proj, spot_view, Light, LightKind, LocalLight,
};
pub use parts::{PartKeys, ScenePart};

/// Errors building or loading a scene.
#[derive(Debug, Error, Clone)]
pub enum SceneError {
    /// The built-in name is unknown.
    #[error("unknown built-in scene '{0}' (built-in scenes: {list})", list = BUILTIN_SCENES.join(", "))]
    UnknownBuiltin(String),
    /// The glTF file could not be read or has no usable mesh.
    #[error("glTF {path}: {reason}")]
    Gltf {
        /// The file.
        path: String,
        /// Why.
        reason: String,
    },
}

/// One object: a triangle mesh in world space with a base colour and tags.
#[derive(Debug, Clone, PartialEq)]
pub struct Object {
    /// Name (glTF node name or a built-in part name; a node's second and later primitives are
    /// `<node>.<i>`).
    pub name: String,
    /// The glTF node (a Blender object) it belongs to — the same for every primitive of the
    /// node —, or the built-in part: the object Cryptomatte names.
    pub node: String,
    /// The glTF material's name (Blender's material), empty without one: the material
    /// Cryptomatte names.
    pub material: String,
    /// Vertex positions (world space).
    pub positions: Vec<Vec3>,
    /// Vertex normals (world space, unit length).
    pub normals: Vec<Vec3>,
    /// Triangle list indices.
    pub indices: Vec<u32>,
    /// Linear RGBA base colour.
    pub colour: [f32; 4],
    /// Tags (`foliage`, `figure`, ...) for nodes that treat objects separately.
    pub tags: Vec<String>,
    /// For an object an animation moves: its mesh in its own space and the matrix placing it,
    /// so the GPU keeps the mesh for the whole shot and only the matrix changes per frame
    /// (`positions` and `normals` above are the placed result, for everything on the CPU).
    /// `None`: the world-space mesh is what is drawn.
    pub placement: Option<Placement>,
}

/// An object's mesh in its own space and the matrix placing it in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// The mesh, shared by every pose of the object.
    pub mesh: std::sync::Arc<LocalMesh>,
    /// Object → world.
    pub world: Mat4,
}

/// A mesh in its object's own space (the object's `indices` index it).
#[derive(Debug, PartialEq)]
pub struct LocalMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex normals (unit length).
    pub normals: Vec<Vec3>,
    /// A content key of the positions and normals.
    pub key: u64,
}

impl LocalMesh {
    /// The mesh of these vertices, its key computed.
    pub fn new(positions: Vec<Vec3>, normals: Vec<Vec3>) -> Self {
        use std::hash::{Hash, Hasher};
        let mut h = std::hash::DefaultHasher::new();
        for v in positions.iter().chain(&normals) {
            v.to_array().map(f32::to_bits).hash(&mut h);
        }
        (positions.len(), normals.len()).hash(&mut h);
        let key = h.finish();
        Self {
            positions,
            normals,
            key,
        }
    }
}

/// A perspective camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Vertical field of view, degrees.
    pub fov_y: f32,
    /// Near plane distance.
    pub near: f32,
    /// Far plane distance; also the linear depth given to sky pixels.
    pub far: f32,
}

impl Camera {
    /// World → view (right-handed, looking down −Z, +Y up; a straight-down view uses +Z as up).
    pub fn view(&self) -> Mat4 {
        let dir = (self.target - self.position).normalize_or(Vec3::NEG_Z);
        let up = if dir.cross(Vec3::Y).length_squared() < 1e-8 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        glam::camera::rh::view::look_at_mat4(self.position, self.position + dir, up)
    }

    /// View → clip for an image of this aspect ratio (wgpu depth range 0..1).
    pub fn proj(&self, aspect: f32) -> Mat4 {
        glam::camera::rh::proj::directx::perspective(
            self.fov_y.to_radians(),
            aspect.max(1e-6),
            self.near,
            self.far,
        )
    }
}

/// The directional light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sun {
    /// Azimuth, degrees clockwise from +Z seen from above.
    pub azimuth: f32,
    /// Elevation above the horizon, degrees (90 = straight down).
    pub elevation: f32,
    /// Linear RGB colour.
    pub colour: [f32; 3],
    /// Irradiance in W/m² on a surface facing the sun (multiplies the colour). glTF files give
    /// lux; the loader divides by 683 lm/W as Blender's glTF importer does.
    pub intensity: f32,
}

impl Sun {
    /// Unit vector pointing from the scene towards the sun.
    pub fn to_sun(&self) -> Vec3 {
        let (az, el) = (self.azimuth.to_radians(), self.elevation.to_radians());
        Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos()).normalize()
    }

    /// Azimuth and elevation (degrees) of a direction pointing towards the sun.
    pub fn angles_of(to_sun: Vec3) -> (f32, f32) {
        let d = to_sun.normalize_or(Vec3::Y);
        (
            d.x.atan2(d.z).to_degrees(),
            d.y.clamp(-1.0, 1.0).asin().to_degrees(),
        )
    }

    /// Colour × intensity: the sun's irradiance per channel, W/m².
    pub fn radiance(&self) -> [f32; 3] {
        self.colour.map(|c| c * self.intensity)
    }
}

/// A scene: objects, camera and sun.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Objects.
    pub objects: Vec<Object>,
    /// The camera (the file's or the built-in's; node parameters may override it).
    pub camera: Camera,
    /// Every light of the scene: a glTF file's (directional, spot, point) in node order, a
    /// built-in scene's sun (a directional light named `sun`), or the light node parameters
    /// set. The one model of the scene's lights: a shadow map, the sky and radial blur all
    /// choose from it ([`Scene::find_light`], [`Scene::find_sun`]); a scene without a
    /// directional light has no sun. Empty: an unlit scene (a file without lights).
    pub lights: Vec<Light>,
    /// Bounds `(min, max)` of the objects tagged `medium` in a glTF file (those objects are not
    /// part of `objects`: they bound the participating medium and are not drawn); `None` when
    /// the scene has none.
    pub medium: Option<(Vec3, Vec3)>,
    /// The objects whose custom property `vdb` names an OpenVDB file (glTF node `extras:
    /// {"vdb": "smoke_####.vdb"}`, which Blender's exporter writes from a custom property), in
    /// the file's node order: `VdbVolume` places the file in the object's space. Empty for a
    /// built-in scene.
    pub volumes: Vec<VolumeObject>,
}

/// An object naming an OpenVDB file (see [`Scene::volumes`]).
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeObject {
    /// The glTF node's name.
    pub name: String,
    /// The file as the property names it, resolved against the glTF file's folder (a `####` or
    /// `%04d` in it follows the frame).
    pub file: String,
    /// The file of the frame the scene was posed at (`file` with its frame pattern replaced;
    /// `file` itself without one), set by the `Scene` node.
    pub frame_file: String,
    /// A stamp of `frame_file` (size and modification time), so a re-baked cache is read again.
    pub stamp: u64,
    /// Object → world (Tyndall's Y-up world), at the posed time.
    pub world: Mat4,
}

impl Scene {
    /// Apply `f` to every colour of the scene: objects' base colours (alpha kept) and every
    /// light's (what converting a file's colours to the working space does).
    pub fn convert_colours(&mut self, f: impl Fn([f32; 3]) -> [f32; 3]) {
        for o in &mut self.objects {
            let [r, g, b] = f([o.colour[0], o.colour[1], o.colour[2]]);
            o.colour = [r, g, b, o.colour[3]];
        }
        for l in &mut self.lights {
            l.colour = f(l.colour);
        }
    }

    /// Axis-aligned bounds of all vertices (a unit box around the origin when empty).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for o in &self.objects {
            for p in &o.positions {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        if lo.x > hi.x {
            (Vec3::splat(-1.0), Vec3::splat(1.0))
        } else {
            (lo, hi)
        }
    }

    /// The light `which` names: empty = the first of [`Scene::lights`], else a light's name or
    /// its index in that list. The error lists the scene's lights.
    pub fn find_light(&self, which: &str) -> Result<Light, String> {
        let list = &self.lights;
        let which = which.trim();
        let found = if which.is_empty() {
            list.first()
        } else {
            list.iter()
                .find(|l| l.name == which)
                .or_else(|| which.parse::<usize>().ok().and_then(|i| list.get(i)))
        };
        found
            .cloned()
            .ok_or_else(|| format!("no light '{which}' in the scene; {}", self.lights_named()))
    }

    /// The directional light `which` names, as the sun: empty = the scene's first directional
    /// light, else a light's name or index (as [`Scene::find_light`]). Refused, naming the
    /// scene's lights, when the scene has no directional light or `which` names another kind.
    pub fn find_sun(&self, which: &str) -> Result<Sun, String> {
        if which.trim().is_empty() {
            return self.lights.iter().find_map(Light::as_sun).ok_or_else(|| {
                format!(
                    "the scene has no directional light (no sun); {}",
                    self.lights_named()
                )
            });
        }
        let light = self.find_light(which)?;
        light.as_sun().ok_or_else(|| {
            format!(
                "light '{}' is a {} light, not directional (a sun); {}",
                light.name,
                light.type_name(),
                self.lights_named()
            )
        })
    }

    /// "its lights: 0 'sun' (directional), …" or "it has no lights", for error messages.
    pub fn lights_named(&self) -> String {
        if self.lights.is_empty() {
            return "it has no lights".into();
        }
        let names: Vec<String> = self
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| format!("{i} '{}' ({})", l.name, l.type_name()))
            .collect();
        format!("its lights: {}", names.join(", "))
    }

    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.objects.iter().map(|o| o.indices.len() / 3).sum()
    }

    /// The first surface along the ray `origin + t·dir`, t > 0 (Möller–Trumbore on every
    /// triangle, both faces): for picking one pixel, not for rendering.
    pub fn ray_hit(&self, origin: Vec3, dir: Vec3) -> Option<SurfacePoint> {
        let mut best: Option<SurfacePoint> = None;
        for o in &self.objects {
            for (ti, tri) in o.indices.chunks_exact(3).enumerate() {
                let [a, b, c] = [0, 1, 2].map(|k| o.positions[tri[k] as usize]);
                let (e1, e2) = (b - a, c - a);
                let pv = dir.cross(e2);
                let det = e1.dot(pv);
                if det.abs() < 1e-12 {
                    continue;
                }
                let inv = 1.0 / det;
                let tv = origin - a;
                let u = tv.dot(pv) * inv;
                if !(0.0..=1.0).contains(&u) {
                    continue;
                }
                let qv = tv.cross(e1);
                let v = dir.dot(qv) * inv;
                if v < 0.0 || u + v > 1.0 {
                    continue;
                }
                let t = e2.dot(qv) * inv;
                if t > 1e-6 && best.as_ref().is_none_or(|h| t < h.t) {
                    best = Some(SurfacePoint {
                        object: o.name.clone(),
                        triangle: ti as u32,
                        bary: [1.0 - u - v, u, v],
                        position: origin + dir * t,
                        t,
                    });
                }
            }
        }
        best
    }

    /// The world position of a surface point given as object name, triangle index and
    /// barycentric coordinates (weights of the triangle's three vertices); `None` when the
    /// object or triangle does not exist.
    pub fn surface_position(&self, object: &str, triangle: u32, bary: [f32; 3]) -> Option<Vec3> {
        let o = self.objects.iter().find(|o| o.name == object)?;
        let tri = o.indices.chunks_exact(3).nth(triangle as usize)?;
        let p = [0, 1, 2].map(|k| o.positions.get(tri[k] as usize).copied());
        Some(p[0]? * bary[0] + p[1]? * bary[1] + p[2]? * bary[2])
    }
}

/// A point on a scene surface, as `tyndall pick` reports it and anchors refer to it.
#[derive(Debug, Clone, PartialEq)]
pub struct SurfacePoint {
    /// The object's name.
    pub object: String,
    /// Triangle index within the object.
    pub triangle: u32,
    /// Barycentric coordinates: the weights of the triangle's three vertices (sum 1).
    pub bary: [f32; 3],
    /// World position.
    pub position: Vec3,
    /// Distance along the picking ray.
    pub t: f32,
}

/// Light-space matrices of an orthographic shadow map along `to_sun`, fitted to the bounds:
/// `(view, proj)` with depth 0 at the light's near plane and 1 at the far plane, both planes
/// touching the bounds.
pub fn fit_light(to_sun: Vec3, bounds: (Vec3, Vec3)) -> (Mat4, Mat4) {
    let (lo, hi) = bounds;
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let d = to_sun.normalize_or(Vec3::Y);
    let up = if d.cross(Vec3::Y).length_squared() < 1e-6 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let eye = centre + d * radius * 2.0;
    let view = glam::camera::rh::view::look_at_mat4(eye, centre, up);
    let mut vmin = Vec3::splat(f32::INFINITY);
    let mut vmax = Vec3::splat(f32::NEG_INFINITY);
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let v = view.transform_point3(c);
        vmin = vmin.min(v);
        vmax = vmax.max(v);
    }
    // A small margin keeps geometry on the box faces inside the map.
    let m = radius * 1e-3;
    let proj = glam::camera::rh::proj::directx::orthographic(
        vmin.x - m,
        vmax.x + m,
        vmin.y - m,
        vmax.y + m,
        -vmax.z - m,
        -vmin.z + m,
    );
    (view, proj)
}
