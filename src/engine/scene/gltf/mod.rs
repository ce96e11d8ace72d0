//! glTF 2.0 (`.gltf` with embedded or external buffers, `.glb`): meshes with node transforms,
//! base colours, the first camera, every `KHR_lights_punctual` light (directional, spot, point;
//! the first directional one is the scene's sun), and animations of node translation, rotation
//! and scale ([`animation`]), so the camera, the lights and meshes move over time.
//!
//! Tags come from a node's `extras`: `{"tags": ["a", "b"]}`, or `{"tyndall_tag": "a, b"}` (a
//! Blender object's custom property `tyndall_tag`, which Blender's exporter writes as extras);
//! objects tagged `medium` are not drawn but give the scene's medium bounds. A node whose
//! `extras` has `"vdb": "file.vdb"` (relative to the glTF file) places that OpenVDB file in its
//! space ([`crate::scene::Scene::volumes`]). A directional
//! light's intensity (lux) is read as irradiance in W/m² (÷ 683, [`LUX_PER_WATT`]), a spot or
//! point light's (candela) as radiant intensity in W/sr (÷ 683 too).
//!
//! A file is parsed once into a [`GltfAsset`] (cached by path, size and modification time,
//! [`load_gltf_asset`]); [`GltfAsset::pose`] places it at a time.

pub mod animation;
mod checks;
mod pose;

pub use self::animation::find_animation;
pub use self::pose::DEFAULT_SUN;

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

use base64::Engine;
use glam::{Quat, Vec3};

use self::animation::{Animation, Channel, Interpolation, Target, Trs};
use self::pose::face_normals;
use super::{LocalMesh, Scene, SceneError};

/// Luminous efficacy used to read a glTF directional light's illuminance (lux) as irradiance
/// (W/m²), as Blender's glTF importer does in its default ("Standard") lighting mode.
pub const LUX_PER_WATT: f32 = 683.0;

/// Objects carrying this tag (glTF node `extras: {"tags": ["medium"]}`) bound the participating
/// medium (`SingleScattering` with `bounds = tagged`) and are not drawn.
pub const MEDIUM_TAG: &str = "medium";

fn err(path: &Path, reason: impl std::fmt::Display) -> SceneError {
    SceneError::Gltf {
        path: path.display().to_string(),
        reason: reason.to_string(),
    }
}

fn buffers(
    doc: &gltf::Document,
    blob: Option<Vec<u8>>,
    path: &Path,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut out = Vec::new();
    let mut blob = blob;
    for b in doc.buffers() {
        let data = match b.source() {
            gltf::buffer::Source::Bin => blob
                .take()
                .ok_or_else(|| err(path, "buffer refers to a missing GLB binary chunk"))?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let b64 = rest
                        .split_once(";base64,")
                        .map(|(_, d)| d)
                        .ok_or_else(|| err(path, "data URI is not base64"))?;
                    base64::engine::general_purpose::STANDARD
                        .decode(b64)
                        .map_err(|e| err(path, format!("buffer: {e}")))?
                } else {
                    std::fs::read(dir.join(uri))
                        .map_err(|e| err(path, format!("buffer {uri}: {e}")))?
                }
            }
        };
        if data.len() < b.length() {
            return Err(err(
                path,
                format!(
                    "buffer {} is {} bytes, expected {}",
                    b.index(),
                    data.len(),
                    b.length()
                ),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// One triangle primitive in its node's local space.
#[derive(Debug, Clone)]
struct Primitive {
    positions: Vec<Vec3>,
    /// Local normals, `None` when the file gives none (then computed from the posed faces).
    normals: Option<Vec<Vec3>>,
    indices: Vec<u32>,
    colour: [f32; 4],
    /// The material's name (empty: none, or a material without a name).
    material: String,
    /// The mesh in the node's space (normals from the file, else from the local faces): what a
    /// moving object's placement draws.
    local: Arc<LocalMesh>,
}

/// A glTF node as the loader keeps it.
#[derive(Debug, Clone)]
struct AssetNode {
    name: String,
    rest: Trs,
    children: Vec<usize>,
    tags: Vec<String>,
    /// Vertical field of view (radians), near and far, of a perspective camera on the node.
    camera: Option<(f32, f32, f32)>,
    /// The `KHR_lights_punctual` light on the node.
    light: Option<NodeLight>,
    primitives: Vec<Primitive>,
    /// The OpenVDB file its `vdb` extra names, resolved against the glTF file's folder.
    vdb: Option<String>,
}

/// A `KHR_lights_punctual` light as the file gives it (placed by its node when posed).
#[derive(Debug, Clone)]
struct NodeLight {
    /// `None`: directional; `Some(None)`: point; `Some(Some((inner, outer)))`: a spot's cone
    /// half-angles (radians).
    local: Option<Option<(f32, f32)>>,
    colour: [f32; 3],
    /// lux (directional) or candela (spot, point).
    intensity: f32,
    range: Option<f32>,
}

/// A parsed glTF file: its node tree, meshes in local space and animations, ready to be posed
/// at any time ([`GltfAsset::pose`]).
#[derive(Debug, Clone)]
pub struct GltfAsset {
    path: String,
    nodes: Vec<AssetNode>,
    roots: Vec<usize>,
    /// The file's animations, in file order.
    pub animations: Vec<Animation>,
}

/// A node's `extras` as JSON (`None`: none, or not JSON).
fn extras_of(node: &gltf::Node) -> Option<serde_json::Value> {
    node.extras()
        .as_ref()
        .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
}

/// The file a node's `vdb` extra names (a non-empty string), against the glTF file's folder.
fn vdb_of(node: &gltf::Node, path: &Path) -> Option<String> {
    let v = extras_of(node)?;
    let name = v.get("vdb")?.as_str()?.trim();
    if name.is_empty() {
        return None;
    }
    let dir = path.parent().unwrap_or(Path::new("."));
    Some(dir.join(name).display().to_string())
}

fn tags_of(node: &gltf::Node) -> Vec<String> {
    let Some(v) = extras_of(node) else {
        return Vec::new();
    };
    let mut tags: Vec<String> = v
        .get("tags")
        .and_then(|t| t.as_array())
        .map(|a| {
            a.iter()
                .filter_map(|t| t.as_str().map(str::to_string))
                .collect()
        })
        .unwrap_or_default();
    if let Some(t) = v.get("tyndall_tag").and_then(|t| t.as_str()) {
        tags.extend(
            t.split(',')
                .map(str::trim)
                .filter(|s| !s.is_empty())
                .map(str::to_string),
        );
    }
    tags
}

fn read_animations(
    doc: &gltf::Document,
    bufs: &[Vec<u8>],
    path: &Path,
) -> Result<Vec<Animation>, SceneError> {
    use gltf::animation::util::ReadOutputs;
    let mut out = Vec::new();
    for anim in doc.animations() {
        let name = anim
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("animation {}", anim.index()));
        let mut channels = Vec::new();
        for (ci, ch) in anim.channels().enumerate() {
            let target = match ch.target().property() {
                gltf::animation::Property::Translation => Target::Translation,
                gltf::animation::Property::Rotation => Target::Rotation,
                gltf::animation::Property::Scale => Target::Scale,
                gltf::animation::Property::MorphTargetWeights => continue,
            };
            let interpolation = match ch.sampler().interpolation() {
                gltf::animation::Interpolation::Step => Interpolation::Step,
                gltf::animation::Interpolation::Linear => Interpolation::Linear,
                gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
            };
            let reader = ch.reader(|b| bufs.get(b.index()).map(|v| v.as_slice()));
            let bad = |what: &str| err(path, format!("animation '{name}' channel {ci}: {what}"));
            let times: Vec<f32> = reader
                .read_inputs()
                .ok_or_else(|| bad("key times cannot be read"))?
                .collect();
            let values: Vec<glam::Vec4> = match reader
                .read_outputs()
                .ok_or_else(|| bad("values cannot be read"))?
            {
                ReadOutputs::Translations(v) | ReadOutputs::Scales(v) => {
                    v.map(|p| Vec3::from(p).extend(0.0)).collect()
                }
                ReadOutputs::Rotations(r) => r.into_f32().map(glam::Vec4::from).collect(),
                ReadOutputs::MorphTargetWeights(_) => continue,
            };
            if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] <= w[0]) {
                return Err(bad("key times are not finite and strictly increasing"));
            }
            if values.iter().any(|v| !v.is_finite()) {
                return Err(bad("a value is not finite"));
            }
            channels.push(Channel {
                node: ch.target().node().index(),
                target,
                interpolation,
                times,
                values,
            });
        }
        out.push(Animation { name, channels });
    }
    Ok(out)
}

fn read_primitives(
    mesh: &gltf::Mesh,
    bufs: &[Vec<u8>],
    name: &str,
    path: &Path,
) -> Result<Vec<Primitive>, SceneError> {
    let mut out = Vec::new();
    for prim in mesh.primitives() {
        if prim.mode() != gltf::mesh::Mode::Triangles {
            continue;
        }
        let reader = prim.reader(|b| bufs.get(b.index()).map(|v| v.as_slice()));
        let Some(positions) = reader.read_positions() else {
            continue;
        };
        let positions: Vec<Vec3> = positions.map(Vec3::from).collect();
        let indices: Vec<u32> = match reader.read_indices() {
            Some(ix) => ix.into_u32().collect(),
            None => (0..positions.len() as u32).collect(),
        };
        if indices.iter().any(|i| *i as usize >= positions.len()) {
            return Err(err(path, format!("mesh '{name}': index out of range")));
        }
        let normals = reader
            .read_normals()
            .map(|n| n.map(Vec3::from).collect::<Vec<_>>())
            .filter(|n| n.len() == positions.len());
        let local = Arc::new(LocalMesh::new(
            positions.clone(),
            normals
                .clone()
                .unwrap_or_else(|| face_normals(&positions, &indices)),
        ));
        out.push(Primitive {
            positions,
            normals,
            indices,
            colour: prim.material().pbr_metallic_roughness().base_color_factor(),
            material: prim.material().name().unwrap_or_default().to_string(),
            local,
        });
    }
    Ok(out)
}

/// Parse a glTF file (no caching; see [`load_gltf_asset`]).
pub fn parse_gltf(path: &Path) -> Result<GltfAsset, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| err(path, e))?;
    // A binary glTF whose header length is shorter than the header itself makes the gltf crate
    // subtract with overflow (a panic in builds with overflow checks; found by fuzzing).
    if bytes.starts_with(b"glTF") {
        let length = bytes
            .get(8..12)
            .map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        if length < 12 {
            return Err(err(
                path,
                format!("GLB header length {length} is shorter than the header"),
            ));
        }
    }
    // The gltf crate's validation indexes a primitive's POSITION accessor before checking that
    // it exists, and its readers assert on accessor shapes (panics found by fuzzing): check
    // the indices and shapes first.
    let unchecked = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| err(path, e))?;
    checks::accessor_indices_exist(unchecked.document.as_json()).map_err(|m| err(path, m))?;
    checks::animations_are_readable(unchecked.document.as_json()).map_err(|m| err(path, m))?;
    let gltf::Gltf {
        document: doc,
        blob,
    } = gltf::Gltf::from_slice(&bytes).map_err(|e| err(path, e))?;
    let bufs = buffers(&doc, blob, path)?;
    let mut nodes = Vec::new();
    for node in doc.nodes() {
        let name = node.name().unwrap_or("node").to_string();
        let (t, r, s) = node.transform().decomposed();
        let camera = node.camera().and_then(|c| match c.projection() {
            gltf::camera::Projection::Perspective(p) => {
                Some((p.yfov(), p.znear().max(1e-4), p.zfar().unwrap_or(1000.0)))
            }
            gltf::camera::Projection::Orthographic(_) => None,
        });
        let light = node.light().map(|l| NodeLight {
            local: match l.kind() {
                gltf::khr_lights_punctual::Kind::Directional => None,
                gltf::khr_lights_punctual::Kind::Point => Some(None),
                gltf::khr_lights_punctual::Kind::Spot {
                    inner_cone_angle,
                    outer_cone_angle,
                } => Some(Some((inner_cone_angle, outer_cone_angle))),
            },
            colour: l.color(),
            intensity: l.intensity(),
            range: l.range(),
        });
        let primitives = match node.mesh() {
            Some(mesh) => read_primitives(&mesh, &bufs, &name, path)?,
            None => Vec::new(),
        };
        nodes.push(AssetNode {
            rest: Trs {
                translation: Vec3::from(t),
                rotation: Quat::from_array(r),
                scale: Vec3::from(s),
            },
            children: node.children().map(|c| c.index()).collect(),
            tags: tags_of(&node),
            vdb: vdb_of(&node, path),
            camera,
            light,
            primitives,
            name,
        });
    }
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| err(path, "no scene"))?;
    let asset = GltfAsset {
        path: path.display().to_string(),
        nodes,
        roots: scene.nodes().map(|n| n.index()).collect(),
        animations: read_animations(&doc, &bufs, path)?,
    };
    // Fail at load, not at some frame: the rest pose must have something to draw.
    asset.pose(&[], 0.0)?;
    Ok(asset)
}

/// A parsed file, shared: parsed once per (path, size, modification time) and process, so the
/// `Scene` node posing an animation at every frame — and its cache key asking whether the file
/// is animated — reads the file once.
pub fn load_gltf_asset(path: &Path) -> Result<Arc<GltfAsset>, SceneError> {
    type Cache =
        Mutex<HashMap<std::path::PathBuf, (Option<(u64, std::time::SystemTime)>, Arc<GltfAsset>)>>;
    static CACHE: std::sync::OnceLock<Cache> = std::sync::OnceLock::new();
    let stamp = std::fs::metadata(path)
        .ok()
        .and_then(|m| Some((m.len(), m.modified().ok()?)));
    let cache = CACHE.get_or_init(Default::default);
    if let Some((s, a)) = cache.lock().ok().and_then(|c| c.get(path).cloned()) {
        if s.is_some() && s == stamp {
            return Ok(a);
        }
    }
    let asset = Arc::new(parse_gltf(path)?);
    if let Ok(mut c) = cache.lock() {
        if c.len() > 64 {
            c.clear();
        }
        c.insert(path.to_path_buf(), (stamp, asset.clone()));
    }
    Ok(asset)
}

impl GltfAsset {
    /// The OpenVDB files the nodes' `vdb` extras name (resolved, frame patterns kept), in node
    /// order.
    pub fn volume_files(&self) -> Vec<&str> {
        self.nodes.iter().filter_map(|n| n.vdb.as_deref()).collect()
    }

    /// Whether anything moves: some channel of one of `animations` has two or more keys.
    pub fn moves(&self, animations: &[usize]) -> bool {
        animations
            .iter()
            .filter_map(|i| self.animations.get(*i))
            .any(|a| a.channels.iter().any(|c| c.times.len() > 1))
    }

    /// First and last key time, seconds, over `animations` together (`(0, 0)` for none).
    pub fn range(&self, animations: &[usize]) -> (f32, f32) {
        let ranges: Vec<(f32, f32)> = animations
            .iter()
            .filter_map(|i| self.animations.get(*i))
            .filter(|a| !a.channels.is_empty())
            .map(Animation::range)
            .collect();
        if ranges.is_empty() {
            return (0.0, 0.0);
        }
        ranges
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), r| {
                (lo.min(r.0), hi.max(r.1))
            })
    }

    /// One line per animation: name, channels, and the frame range at `fps` (frame = seconds ×
    /// fps, as Blender's exporter writes frame f at f / fps seconds).
    pub fn describe_animations(&self, fps: f64) -> Vec<String> {
        self.animations
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let (lo, hi) = a.range();
                format!(
                    "animation {i} '{}': {} channel{}, {:.3}–{:.3} s = frames {}–{} at {fps} fps",
                    a.name,
                    a.channels.len(),
                    if a.channels.len() == 1 { "" } else { "s" },
                    lo,
                    hi,
                    (lo as f64 * fps).round(),
                    (hi as f64 * fps).round()
                )
            })
            .collect()
    }
}

/// Load a glTF scene in its rest pose (no animation applied). Camera and sun default to a
/// view of the bounds and a high sun when the file has none.
pub fn load_gltf(path: &Path) -> Result<Scene, SceneError> {
    parse_gltf(path)?.pose(&[], 0.0)
}
