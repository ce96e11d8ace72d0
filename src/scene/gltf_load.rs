//! glTF 2.0 (`.gltf` with embedded or external buffers, `.glb`): meshes with node transforms,
//! base colours, the first camera and the first directional light (`KHR_lights_punctual`).
//! Tags come from a node's `extras: {"tags": [...]}`; objects tagged `medium` are not drawn but
//! give the scene's medium bounds. A directional light's intensity (lux) is read as irradiance
//! in W/m² (÷ 683, [`LUX_PER_WATT`]).

use std::path::Path;

use base64::Engine;
use glam::{Mat3, Mat4, Vec3};

use super::{Camera, Object, Scene, SceneError, Sun};

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

/// Every accessor a mesh primitive names (attributes, indices) exists, and the ones the loader
/// reads have the shape it reads them as: POSITION and NORMAL float VEC3, indices unsigned
/// SCALAR (the gltf crate asserts on a mismatch instead of reporting it; found by fuzzing).
fn accessor_indices_exist(root: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::accessor::{ComponentType, Type};
    use gltf::json::mesh::Semantic;
    use gltf::json::validation::Checked;
    let count = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let named = prim.attributes.values().chain(prim.indices.as_ref());
            if let Some(bad) = named.map(|i| i.value()).find(|i| *i >= count) {
                return Err(format!(
                    "mesh {m} primitive {p} names accessor {bad}, but the file has {count}"
                ));
            }
            let shape = |i: usize| {
                let a = &root.accessors[i];
                let ty = match a.type_ {
                    Checked::Valid(t) => Some(t),
                    Checked::Invalid => None,
                };
                let component = match a.component_type {
                    Checked::Valid(c) => Some(c.0),
                    Checked::Invalid => None,
                };
                (ty, component)
            };
            for (semantic, index) in &prim.attributes {
                let read = matches!(
                    semantic,
                    Checked::Valid(Semantic::Positions) | Checked::Valid(Semantic::Normals)
                );
                if read && shape(index.value()) != (Some(Type::Vec3), Some(ComponentType::F32)) {
                    return Err(format!(
                        "mesh {m} primitive {p}: accessor {} for {semantic:?} is not a float VEC3",
                        index.value()
                    ));
                }
            }
            if let Some(index) = &prim.indices {
                let ok = matches!(
                    shape(index.value()),
                    (
                        Some(Type::Scalar),
                        Some(ComponentType::U8 | ComponentType::U16 | ComponentType::U32)
                    )
                );
                if !ok {
                    return Err(format!(
                        "mesh {m} primitive {p}: index accessor {} is not an unsigned SCALAR",
                        index.value()
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Load a glTF scene. Camera and sun default to a view of the bounds and a high sun when the
/// file has none.
pub fn load_gltf(path: &Path) -> Result<Scene, SceneError> {
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
    // it exists (a panic on such a file, found by fuzzing): check the indices first.
    let unchecked = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| err(path, e))?;
    accessor_indices_exist(unchecked.document.as_json()).map_err(|m| err(path, m))?;
    let gltf::Gltf {
        document: doc,
        blob,
    } = gltf::Gltf::from_slice(&bytes).map_err(|e| err(path, e))?;
    let bufs = buffers(&doc, blob, path)?;
    let mut objects = Vec::new();
    let mut camera = None;
    let mut sun = None;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| err(path, "no scene"))?;
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        for child in node.children() {
            stack.push((child, world));
        }
        let name = node.name().unwrap_or("node").to_string();
        let tags: Vec<String> = node
            .extras()
            .as_ref()
            .and_then(|raw| serde_json::from_str::<serde_json::Value>(raw.get()).ok())
            .and_then(|v| v.get("tags").and_then(|t| t.as_array()).cloned())
            .map(|a| {
                a.iter()
                    .filter_map(|t| t.as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        let (_, rot, pos) = world.to_scale_rotation_translation();
        let forward = (rot * Vec3::NEG_Z).normalize_or(Vec3::NEG_Z);
        if let (Some(cam), None) = (node.camera(), camera) {
            if let gltf::camera::Projection::Perspective(p) = cam.projection() {
                camera = Some(Camera {
                    position: pos,
                    target: pos + forward * 10.0,
                    fov_y: p.yfov().to_degrees(),
                    near: p.znear().max(1e-4),
                    far: p.zfar().unwrap_or(1000.0),
                });
            }
        }
        if let (Some(light), None) = (node.light(), sun) {
            if let gltf::khr_lights_punctual::Kind::Directional = light.kind() {
                let (azimuth, elevation) = Sun::angles_of(-forward);
                sun = Some(Sun {
                    azimuth,
                    elevation,
                    colour: light.color(),
                    intensity: light.intensity() / LUX_PER_WATT,
                });
            }
        }
        let Some(mesh) = node.mesh() else { continue };
        let normal_m = Mat3::from_mat4(world).inverse().transpose();
        for (pi, prim) in mesh.primitives().enumerate() {
            if prim.mode() != gltf::mesh::Mode::Triangles {
                continue;
            }
            let reader = prim.reader(|b| bufs.get(b.index()).map(|v| v.as_slice()));
            let Some(positions) = reader.read_positions() else {
                continue;
            };
            let positions: Vec<Vec3> = positions
                .map(|p| world.transform_point3(Vec3::from(p)))
                .collect();
            let indices: Vec<u32> = match reader.read_indices() {
                Some(ix) => ix.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            if indices.iter().any(|i| *i as usize >= positions.len()) {
                return Err(err(path, format!("mesh '{name}': index out of range")));
            }
            let normals: Vec<Vec3> = match reader.read_normals() {
                Some(n) => n
                    .map(|n| (normal_m * Vec3::from(n)).normalize_or(Vec3::Y))
                    .collect(),
                None => {
                    let mut acc = vec![Vec3::ZERO; positions.len()];
                    for t in indices.chunks_exact(3) {
                        let (a, b, c) = (
                            positions[t[0] as usize],
                            positions[t[1] as usize],
                            positions[t[2] as usize],
                        );
                        let n = (b - a).cross(c - a);
                        for i in t {
                            acc[*i as usize] += n;
                        }
                    }
                    acc.into_iter().map(|n| n.normalize_or(Vec3::Y)).collect()
                }
            };
            let colour = prim.material().pbr_metallic_roughness().base_color_factor();
            objects.push(Object {
                name: if pi == 0 {
                    name.clone()
                } else {
                    format!("{name}.{pi}")
                },
                positions,
                normals,
                indices,
                colour,
                tags: tags.clone(),
            });
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
    let medium = media
        .iter()
        .flat_map(|o| o.positions.iter())
        .fold(None, |b: Option<(Vec3, Vec3)>, p| {
            Some(b.map_or((*p, *p), |(lo, hi)| (lo.min(*p), hi.max(*p))))
        });
    let mut s = Scene {
        objects,
        medium,
        camera: Camera {
            position: Vec3::ZERO,
            target: Vec3::NEG_Z,
            fov_y: 45.0,
            near: 0.1,
            far: 100.0,
        },
        sun: sun.unwrap_or(Sun {
            azimuth: 30.0,
            elevation: 60.0,
            colour: [1.0; 3],
            intensity: 3.0,
        }),
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
