//! `Scene`: a built-in procedural scene or a glTF file, with its camera and lights (SPEC §1).
//!
//! Without a `path`, the built-in scene `name` is built from `seed` (see [`tyndall_engine::scene::builtin`]
//! for the list: torus, tree, window, fence, figure). With a `path`, the glTF file is loaded:
//! meshes, node transforms, base colours, its first camera and every `KHR_lights_punctual`
//! light — directional (illuminance in lux read as irradiance in W/m² by dividing by 683 lm/W,
//! as Blender's glTF importer does), spot and point (candela / 683 = W/sr), with their colour,
//! position and direction from their node, a spot's cone angles and `range` — (a file with no
//! light at all gets one sun, `default_sun`: white, 3 W/m², 60° up at azimuth 30°);
//! objects tagged `medium` are not drawn and bound the medium for `SingleScattering`'s
//! `bounds = tagged`; an object whose custom property `vdb` names an OpenVDB file (glTF
//! `extras`, relative to the glTF file; `####` follows the frame) is a volume object that
//! `VdbVolume` places in the object's space. `camera = custom` and `light = custom` replace the scene's own camera and
//! lights with the parameters below (all key-frameable): `light_type = directional` is the sun
//! of `sun_*`, `spot` and `point` a lamp at `light_x/y/z` of `light_intensity` W/sr, coloured
//! `sun_colour` (a spot aimed at `light_target_*` with cone `cone_inner`–`cone_outer`).
//! `tyndall validate` lists the lights and refuses one with a negative intensity, a zero or
//! negative range or a cone outside 0 ≤ inner ≤ outer, 0 < outer ≤ 90°.
//!
//! One model of the lights: the scene's lights are all it has. The built-in scenes have one,
//! their sun (a directional light named `sun`); a scene without a directional light has no sun,
//! and the nodes that need one (`Sky`, `RadialBlur`) choose a directional light by their own
//! `light` parameter and refuse, naming the scene's lights, when there is none.
//!
//! How far a light reaches: everywhere its own model lets it (a spot's cone, a lamp's `range`),
//! shadowed by every drawn object between it and the point, however far the medium extends past
//! the objects (`ShadowMap`: an occluder shadows everything behind it, at any distance). A scene
//! needs no floor under its fog to get the shadows of what hangs above it.
//!
//! Animation: a glTF file's animation channels on nodes (translation, rotation, scale; `STEP`,
//! `LINEAR` with slerped rotations, `CUBICSPLINE`) play, so the camera, the sun and meshes move
//! — in the shadow map and the G-buffer alike. Frame f is `f / fps` seconds, as Blender's glTF
//! exporter writes frame f (a 1–24 animation at 24 fps has keys from 1/24 s to 1 s), so
//! `--frames` and the editor's timeline count the DCC's frames; before the first key and after
//! the last the pose holds (and the node is not re-run: its cache key is the clamped time).
//! `animation` chooses which plays: empty = every animation of the file together (Blender's
//! exporter writes one per animated object: the camera's, the sun's, a lamp's…), else a name or
//! an index; `none` = the rest pose. Morph-target weights are not played. `tyndall validate`
//! lists the animations, their frame ranges and which play.
//!
//! Colour: a glTF file's base colours and light colours (linear Rec.709, as glTF defines them)
//! are converted to the graph's working space (`colour: (working_space: …)`) through the
//! evaluation's OpenColorIO config; the built-in scenes' colours and the `sun_colour` parameter
//! are the graph's own, already in the working space.
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
//! | `animation` | Text | "" | | glTF animations that play: empty = all, a name, an index, or `none` |
//! | `fps` | Float | 24 | 0.001…1000 frames/s | frame f is f / fps seconds of the glTF animation |
//! | `camera` | Enum | scene | scene, custom | use the scene's camera or the parameters |
//! | `cam_x`, `cam_y`, `cam_z` | Float | 8, 3, 9 | ±1e5 m | camera position |
//! | `target_x`, `target_y`, `target_z` | Float | 0, 1.5, 0 | ±1e5 m | point looked at |
//! | `fov` | Float | 45 | 1…170 ° | vertical field of view |
//! | `light` | Enum | scene | scene, custom | use the scene's lights, or one light from the parameters |
//! | `sun_azimuth` | Float | 30 | −720…720 ° | clockwise from +Z seen from above |
//! | `sun_elevation` | Float | 45 | −90…90 ° | above the horizon |
//! | `sun_colour` | Colour | (1, 0.95, 0.85, 1) | 0…1e6 | linear RGB (alpha unused) |
//! | `sun_intensity` | Float | 3 | 0…1e6 W/m² | irradiance on a surface facing the sun, multiplying the colour |
//! | `light_type` | Enum | directional | directional, spot, point | the custom light's kind (`light = custom`) |
//! | `light_x`, `light_y`, `light_z` | Float | 0, 5, 0 | ±1e5 m | a spot's or point light's position |
//! | `light_target_x`, `light_target_y`, `light_target_z` | Float | 0, 0, 0 | ±1e5 m | the point a spot aims at |
//! | `cone_inner`, `cone_outer` | Float | 15, 25 | 0…90 ° | a spot's cone half-angles: full inside `cone_inner`, none outside `cone_outer` |
//! | `light_intensity` | Float | 100 | 0…1e9 W/sr | a spot's or point light's radiant intensity, multiplying `sun_colour` |
//! | `light_range` | Float | 0 | 0…1e6 m | distance beyond which it gives nothing (0: unlimited) |

use std::path::Path;
use std::sync::Arc;

use glam::Vec3;

use tyndall_engine::colour::{convert_rgb, ColourCtx};
use tyndall_engine::eval::{
    file_stamp, KeyInput, NodeDecl, NodeError, NodeKind, PortValue, RunCtx,
};
use tyndall_engine::graph::{NodeSchema, ParamSpec, PortSpec, PortType};
use tyndall_engine::scene::{
    builtin, find_animation, load_gltf_asset, Builtin, GpuScene, Light, LightKind, Scene, Sun,
};

/// The `Scene` node kind.
pub struct SceneNode;

tyndall_engine::choice_enum! {
    /// Where the camera (or the sun) comes from.
    pub enum Source { Scene = "scene", Custom = "custom" }
}

tyndall_engine::choice_enum! {
    /// The kind of the custom light.
    pub enum LightType { Directional = "directional", Spot = "spot", Point = "point" }
}

#[rustfmt::skip]
tyndall_engine::params! {
    /// The node's parameters (the table above), read once per run.
    pub struct Params {
        name: Builtin = ParamSpec::choice("name", Builtin::NAMES, "torus", "Built-in scene used when `path` is empty."),
        path: String = ParamSpec::text("path", "", "glTF file (.gltf/.glb); overrides `name`."),
        seed: i64 = ParamSpec::int("seed", 1, 0, 2147483647, "", "Variation of the built-in scene."),
        animation: String = ParamSpec::text("animation", "", "glTF animations that play: empty = every animation of the file together, a name, an index, or `none` for the rest pose."),
        fps: f64 = ParamSpec::float("fps", 24.0, 0.001, 1000.0, "frames/s", "Frames per second of the glTF animation: frame f is f / fps seconds (as Blender's exporter writes it)."),
        camera: Source = ParamSpec::choice("camera", Source::NAMES, "scene", "Use the scene's camera, or the cam_*/target_*/fov parameters."),
        cam_x: f32 = ParamSpec::float("cam_x", 8.0, -1e5, 1e5, "m", "Camera position x (camera = custom)."),
        cam_y: f32 = ParamSpec::float("cam_y", 3.0, -1e5, 1e5, "m", "Camera position y (camera = custom)."),
        cam_z: f32 = ParamSpec::float("cam_z", 9.0, -1e5, 1e5, "m", "Camera position z (camera = custom)."),
        target_x: f32 = ParamSpec::float("target_x", 0.0, -1e5, 1e5, "m", "Point looked at, x (camera = custom)."),
        target_y: f32 = ParamSpec::float("target_y", 1.5, -1e5, 1e5, "m", "Point looked at, y (camera = custom)."),
        target_z: f32 = ParamSpec::float("target_z", 0.0, -1e5, 1e5, "m", "Point looked at, z (camera = custom)."),
        fov: f32 = ParamSpec::float("fov", 45.0, 1.0, 170.0, "°", "Vertical field of view (camera = custom)."),
        light: Source = ParamSpec::choice("light", Source::NAMES, "scene", "Use the scene's lights, or the one light light_type and the sun_*/light_* parameters describe."),
        sun_azimuth: f32 = ParamSpec::float("sun_azimuth", 30.0, -720.0, 720.0, "°", "Sun azimuth, clockwise from +Z seen from above (light = custom)."),
        sun_elevation: f32 = ParamSpec::float("sun_elevation", 45.0, -90.0, 90.0, "°", "Sun elevation above the horizon (light = custom)."),
        sun_colour: [f32; 4] = ParamSpec::colour("sun_colour", [1.0, 0.95, 0.85, 1.0], 0.0, 1e6, "linear RGB", "Sun colour (light = custom)."),
        sun_intensity: f32 = ParamSpec::float("sun_intensity", 3.0, 0.0, 1e6, "W/m²", "Sun irradiance on a surface facing it, multiplying the colour (light = custom); a glTF sun's lux are read as lux / 683."),
        light_type: LightType = ParamSpec::choice("light_type", LightType::NAMES, "directional", "Kind of the custom light (light = custom): the sun of sun_*, or a spot or point lamp."),
        light_x: f32 = ParamSpec::float("light_x", 0.0, -1e5, 1e5, "m", "Spot or point light position x (light = custom)."),
        light_y: f32 = ParamSpec::float("light_y", 5.0, -1e5, 1e5, "m", "Spot or point light position y (light = custom)."),
        light_z: f32 = ParamSpec::float("light_z", 0.0, -1e5, 1e5, "m", "Spot or point light position z (light = custom)."),
        light_target_x: f32 = ParamSpec::float("light_target_x", 0.0, -1e5, 1e5, "m", "Point a spot aims at, x (light = custom)."),
        light_target_y: f32 = ParamSpec::float("light_target_y", 0.0, -1e5, 1e5, "m", "Point a spot aims at, y (light = custom)."),
        light_target_z: f32 = ParamSpec::float("light_target_z", 0.0, -1e5, 1e5, "m", "Point a spot aims at, z (light = custom)."),
        cone_inner: f32 = ParamSpec::float("cone_inner", 15.0, 0.0, 90.0, "°", "Spot cone half-angle of full intensity (light = custom)."),
        cone_outer: f32 = ParamSpec::float("cone_outer", 25.0, 0.0, 90.0, "°", "Spot cone half-angle beyond which it gives nothing (light = custom); the intensity falls smoothly in between."),
        light_intensity: f32 = ParamSpec::float("light_intensity", 100.0, 0.0, 1e9, "W/sr", "Spot or point radiant intensity, multiplying sun_colour (light = custom); a glTF lamp's candela are read as cd / 683."),
        light_range: f32 = ParamSpec::float("light_range", 0.0, 0.0, 1e6, "m", "Distance beyond which the spot or point light gives nothing, with glTF's smooth window (0: unlimited)."),
    }
}

#[rustfmt::skip]
static DECL: NodeDecl = NodeDecl::new(NodeSchema {
    kind: "Scene",
    category: "Scene",
    doc: "A built-in procedural scene (torus, tree, window, fence, figure) or a glTF file, with camera and lights (sun, spot, point).",
    inputs: &[],
    outputs: &[PortSpec::output("scene", &[PortType::Scene], "Meshes, camera and lights.")],
    params: Params::SPECS,
})
.files(&[("path", tyndall_engine::eval::FileRole::Read)])
.colour();

impl NodeKind for SceneNode {
    fn decl(&self) -> &'static NodeDecl {
        &DECL
    }

    fn volatile_key(&self, key: &KeyInput) -> u64 {
        // An animated file makes the scene depend on the time: the key is the time clamped to
        // the animation's keys, so frames before the first key or after the last are reused.
        let Ok(p) = Params::from_params(key.params) else {
            return 0;
        };
        let moving = match animated_seconds(&p, key.time) {
            Ok(Some(seconds)) => (seconds as f64).to_bits() ^ 0x5ce4e,
            _ => 0,
        };
        // Objects naming OpenVDB files: the frame's file (a sequence follows the frame) and its
        // stamp (a re-baked cache is read again).
        let mut h = std::hash::DefaultHasher::new();
        if let Ok(Some((asset, _))) = chosen_animation(&p) {
            for file in asset.volume_files() {
                let frame_file = super::util::frame_path(file, None, key.time);
                std::hash::Hash::hash(&frame_file, &mut h);
                std::hash::Hash::hash(&file_stamp(Path::new(&frame_file)), &mut h);
            }
        }
        moving ^ std::hash::Hasher::finish(&h)
    }

    fn describe_files(
        &self,
        params: &std::collections::BTreeMap<String, tyndall_engine::graph::ParamValue>,
    ) -> Vec<String> {
        let Ok(p) = Params::from_params(params) else {
            return Vec::new();
        };
        let mut lines = match chosen_animation(&p) {
            Ok(None) => Vec::new(),
            Ok(Some((asset, playing))) => {
                let n = asset.animations.len();
                let plays = if playing.is_empty() {
                    "none (rest pose)".to_string()
                } else if playing.len() == n && n > 1 {
                    format!("all {n} together")
                } else {
                    let names: Vec<String> =
                        playing.iter().map(|i| format!("animation {i}")).collect();
                    names.join(", ")
                };
                let mut lines = vec![format!(
                    "{}: {n} animation{}; plays {plays}",
                    p.path,
                    if n == 1 { "" } else { "s" },
                )];
                lines.extend(asset.describe_animations(p.fps));
                lines
            }
            Err(e) => return vec![format!("error: {e}")],
        };
        match load(&p, 0.0, &Default::default()) {
            Ok(scene) => {
                if scene.lights.is_empty() {
                    lines.push("no lights".into());
                }
                for l in &scene.lights {
                    match l.problem() {
                        Some(problem) => lines.push(format!("error: {problem}")),
                        None => lines.push(l.describe()),
                    }
                }
            }
            Err(e) => lines.push(format!("error: {e}")),
        }
        lines
    }

    fn run(&self, ctx: &mut RunCtx) -> Result<(), NodeError> {
        let p = Params::from_ctx(ctx)?;
        let mut scene = load(&p, ctx.time, ctx.colour)?;
        for v in &mut scene.volumes {
            v.frame_file = super::util::frame_path(&v.file, None, ctx.time);
            v.stamp = file_stamp(Path::new(&v.frame_file));
        }
        if let Some(problem) = scene.lights.iter().find_map(Light::problem) {
            return Err(NodeError::Param {
                param: "path".into(),
                message: format!("{}: {problem}", p.path),
            });
        }
        let gpu_scene = GpuScene::upload(ctx.gpu, scene)?;
        ctx.set(
            "scene",
            PortValue::Other(PortType::Scene, Arc::new(gpu_scene)),
        );
        Ok(())
    }
}

/// A parsed glTF file and the indices of the animations that play.
type Chosen = (Arc<tyndall_engine::scene::GltfAsset>, Vec<usize>);

/// The glTF file and the animations `p` chooses (`None` for a built-in scene or an empty path).
fn chosen_animation(p: &Params) -> Result<Option<Chosen>, NodeError> {
    if p.path.is_empty() {
        return Ok(None);
    }
    let path_err = |message: String| NodeError::Param {
        param: "path".into(),
        message,
    };
    let asset = load_gltf_asset(Path::new(&p.path)).map_err(|e| path_err(e.to_string()))?;
    let playing =
        find_animation(&asset.animations, &p.animation).map_err(|e| NodeError::Param {
            param: "animation".into(),
            message: format!("{}: {e}", p.path),
        })?;
    Ok(Some((asset, playing)))
}

/// The animation time (seconds, clamped to the playing animations' keys) of frame `time`, or
/// `None` when nothing moves.
fn animated_seconds(p: &Params, time: f64) -> Result<Option<f32>, NodeError> {
    let Some((asset, playing)) = chosen_animation(p)? else {
        return Ok(None);
    };
    if !asset.moves(&playing) {
        return Ok(None);
    }
    let (lo, hi) = asset.range(&playing);
    Ok(Some(((time / p.fps) as f32).clamp(lo, hi)))
}

/// The built-in scene, or the glTF file posed at frame `time` with its colours in the working
/// space of `colour`, with the camera and lights the parameters override.
fn load(p: &Params, time: f64, colour: &ColourCtx) -> Result<Scene, NodeError> {
    let mut scene = match chosen_animation(p)? {
        None => builtin(p.name.name(), p.seed as u64).map_err(|e| NodeError::Param {
            param: "name".into(),
            message: e.to_string(),
        })?,
        Some((asset, playing)) => {
            let seconds = animated_seconds(p, time)?.unwrap_or(0.0);
            let mut scene = asset
                .pose(&playing, seconds)
                .map_err(|e| NodeError::Param {
                    param: "path".into(),
                    message: e.to_string(),
                })?;
            let to_working = colour.from_rec709().map_err(|e| NodeError::Param {
                param: "path".into(),
                message: format!("{}: its colours to the working space: {e}", p.path),
            })?;
            if let Some(processor) = to_working {
                scene.convert_colours(|rgb| convert_rgb(&processor, rgb));
            }
            scene
        }
    };
    if p.camera == Source::Custom {
        scene.camera.position = Vec3::new(p.cam_x, p.cam_y, p.cam_z);
        scene.camera.target = Vec3::new(p.target_x, p.target_y, p.target_z);
        scene.camera.fov_y = p.fov;
    }
    if p.light == Source::Custom {
        let c = p.sun_colour;
        let sun = Sun {
            azimuth: p.sun_azimuth,
            elevation: p.sun_elevation,
            colour: [c[0], c[1], c[2]],
            intensity: p.sun_intensity,
        };
        let position = Vec3::new(p.light_x, p.light_y, p.light_z);
        let target = Vec3::new(p.light_target_x, p.light_target_y, p.light_target_z);
        let kind = match p.light_type {
            // The sun of `sun_*` alone.
            LightType::Directional => {
                scene.lights = vec![Light::sun("sun", sun)];
                return Ok(scene);
            }
            LightType::Spot => LightKind::Spot {
                position,
                direction: (target - position).normalize_or(Vec3::NEG_Y),
                inner: p.cone_inner.to_radians(),
                outer: p.cone_outer.to_radians(),
            },
            LightType::Point => LightKind::Point { position },
        };
        scene.lights = vec![Light {
            name: p.light_type.name().to_string(),
            kind,
            colour: [c[0], c[1], c[2]],
            intensity: p.light_intensity,
            range: (p.light_range > 0.0).then_some(p.light_range),
        }];
        if let Some(problem) = scene.lights[0].problem() {
            return Err(NodeError::Param {
                param: "cone_outer".into(),
                message: problem,
            });
        }
    }
    Ok(scene)
}
