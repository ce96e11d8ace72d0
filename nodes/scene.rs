//! `Scene`: a built-in procedural scene or a glTF file, with its camera and sun (SPEC §1).
//!
//! Without a `path`, the built-in scene `name` is built from `seed` (see [`crate::scene::builtin`]
//! for the list: torus, tree, window, fence, figure). With a `path`, the glTF file is loaded:
//! meshes, node transforms, base colours, its first camera and its first directional light
//! (`KHR_lights_punctual`, whose illuminance in lux is read as irradiance in W/m² by dividing by
//! 683 lm/W, as Blender's glTF importer does); objects tagged `medium` are not drawn and bound
//! the medium for `SingleScattering`'s `bounds = tagged`. `camera = custom` and `light = custom`
//! replace the scene's own camera and sun with the parameters below (all key-frameable).
//!
//! The node uploads vertex and index buffers; it runs no shader pass (so it has no WGSL file).
//!
//! | port | dir | type |
//! |---|---|---|
//! | `scene` | out | Scene |
//!
//! | param | type | default | range | |
//! |---|---|---|---|---|
//! | `name` | Enum | torus | torus, tree, window, fence, figure | built-in scene |
//! | `path` | Text | "" | | glTF file (.gltf/.glb); overrides `name` |
//! | `seed` | Int | 1 | 0…2³¹ | variation of built-in scenes |
//! | `camera` | Enum | scene | scene, custom | use the scene's camera or the parameters |
//! | `cam_x`, `cam_y`, `cam_z` | Float | 8, 3, 9 | ±1e5 m | camera position |
//! | `target_x`, `target_y`, `target_z` | Float | 0, 1.5, 0 | ±1e5 m | point looked at |
//! | `fov` | Float | 45 | 1…170 ° | vertical field of view |
//! | `light` | Enum | scene | scene, custom | use the scene's sun or the parameters |
//! | `sun_azimuth` | Float | 30 | −720…720 ° | clockwise from +Z seen from above |
//! | `sun_elevation` | Float | 45 | −90…90 ° | above the horizon |
//! | `sun_colour` | Colour | (1, 0.95, 0.85, 1) | 0…1e6 | linear RGB (alpha unused) |
//! | `sun_intensity` | Float | 3 | 0…1e6 W/m² | irradiance on a surface facing the sun, multiplying the colour |

use std::path::Path;
use std::sync::Arc;

use glam::Vec3;

use crate::eval::{NodeDecl, NodeError, NodeKind, PortValue, RunCtx};
use crate::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use crate::scene::{builtin, load_gltf, Builtin, GpuScene, Sun};

/// The `Scene` node kind.
pub struct SceneNode;

crate::choice_enum! {
    /// Where the camera (or the sun) comes from.
    pub enum Source { Scene = "scene", Custom = "custom" }
}

#[rustfmt::skip]
crate::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        name: Builtin = ParamSpec::choice("name", Builtin::NAMES, "torus", "Built-in scene used when `path` is empty."),
        path: String = ParamSpec::text("path", "", "glTF file (.gltf/.glb); overrides `name`."),
        seed: i64 = ParamSpec::int("seed", 1, 0, 2147483647, "", "Variation of the built-in scene."),
        camera: Source = ParamSpec::choice("camera", Source::NAMES, "scene", "Use the scene's camera, or the cam_*/target_*/fov parameters."),
        cam_x: f32 = ParamSpec::float("cam_x", 8.0, -1e5, 1e5, "m", "Camera position x (camera = custom)."),
        cam_y: f32 = ParamSpec::float("cam_y", 3.0, -1e5, 1e5, "m", "Camera position y (camera = custom)."),
        cam_z: f32 = ParamSpec::float("cam_z", 9.0, -1e5, 1e5, "m", "Camera position z (camera = custom)."),
        target_x: f32 = ParamSpec::float("target_x", 0.0, -1e5, 1e5, "m", "Point looked at, x (camera = custom)."),
        target_y: f32 = ParamSpec::float("target_y", 1.5, -1e5, 1e5, "m", "Point looked at, y (camera = custom)."),
        target_z: f32 = ParamSpec::float("target_z", 0.0, -1e5, 1e5, "m", "Point looked at, z (camera = custom)."),
        fov: f32 = ParamSpec::float("fov", 45.0, 1.0, 170.0, "°", "Vertical field of view (camera = custom)."),
        light: Source = ParamSpec::choice("light", Source::NAMES, "scene", "Use the scene's sun, or the sun_* parameters."),
        sun_azimuth: f32 = ParamSpec::float("sun_azimuth", 30.0, -720.0, 720.0, "°", "Sun azimuth, clockwise from +Z seen from above (light = custom)."),
        sun_elevation: f32 = ParamSpec::float("sun_elevation", 45.0, -90.0, 90.0, "°", "Sun elevation above the horizon (light = custom)."),
        sun_colour: [f32; 4] = ParamSpec::colour("sun_colour", [1.0, 0.95, 0.85, 1.0], 0.0, 1e6, "linear RGB", "Sun colour (light = custom)."),
        sun_intensity: f32 = ParamSpec::float("sun_intensity", 3.0, 0.0, 1e6, "W/m²", "Sun irradiance on a surface facing it, multiplying the colour (light = custom); a glTF sun's lux are read as lux / 683."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Scene",
    category: "Scene",
    doc: "A built-in procedural scene (torus, tree, window, fence, figure) or a glTF file, with camera and sun.",
    inputs: &[],
    outputs: &[PortSpec::output("scene", &[PortType::Scene], "Meshes, camera and sun.")],
    params: Params::SPECS,
})
.files(&[("path", crate::eval::FileRole::Read)]);

impl NodeKind for SceneNode {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let path = p.path.as_str();
        let mut scene = if path.is_empty() {
            builtin(p.name.name(), p.seed as u64)
        } else {
            load_gltf(Path::new(path))
        }
        .map_err(|e| NodeError::Param {
            param: if path.is_empty() {
                "name".into()
            } else {
                "path".into()
            },
            message: e.to_string(),
        })?;
        if p.camera == Source::Custom {
            scene.camera.position = Vec3::new(p.cam_x, p.cam_y, p.cam_z);
            scene.camera.target = Vec3::new(p.target_x, p.target_y, p.target_z);
            scene.camera.fov_y = p.fov;
        }
        if p.light == Source::Custom {
            let c = p.sun_colour;
            scene.sun = Sun {
                azimuth: p.sun_azimuth,
                elevation: p.sun_elevation,
                colour: [c[0], c[1], c[2]],
                intensity: p.sun_intensity,
            };
        }
        let gpu_scene = GpuScene::upload(ctx.gpu, scene)?;
        ctx.set(
            "scene",
            PortValue::Other(PortType::Scene, Arc::new(gpu_scene)),
        );
        Ok(())
    }
}
