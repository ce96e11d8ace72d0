//! Animated glTF: a camera that dollies and turns and a sun that turns, in each of glTF's
//! interpolations, rendered through `Scene` → `GBuffer` at frames 1, 12 and 24. The expected
//! pose is computed here from the keys with glTF's formulas (Appendix C of the glTF 2.0 spec),
//! independently of the loader, and a marker cube's centroid must land within 1 px of where
//! that camera projects the marker's centre.

use crate::common;
use std::sync::Arc;

use base64::Engine;
use glam::{Quat, Vec3};
use tyndall::eval::{EvalOptions, Evaluator, Status, Target};

/// Frames per second of the files (the `Scene` default and Blender's).
const FPS: f32 = 24.0;
/// The marker's centre and half-size (m).
const MARKER: Vec3 = Vec3::new(0.3, 1.2, 0.0);
const HALF: f32 = 0.1;
/// Vertical field of view of the camera (rad).
const YFOV: f32 = 0.7;
const W: u32 = 240;
const H: u32 = 180;

/// A little glTF writer: one base64 buffer, one view and accessor per array.
#[derive(Default)]
struct Gltf {
    bin: Vec<u8>,
    views: Vec<serde_json::Value>,
    accessors: Vec<serde_json::Value>,
}

impl Gltf {
    fn floats(&mut self, data: &[f32], ty: &str, count: usize) -> usize {
        let offset = self.bin.len();
        for v in data {
            self.bin.extend_from_slice(&v.to_le_bytes());
        }
        self.views.push(
            serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4}),
        );
        let mut acc = serde_json::json!({"bufferView": self.views.len() - 1, "componentType": 5126, "count": count, "type": ty});
        if ty == "SCALAR" || ty == "VEC3" {
            let n = if ty == "SCALAR" { 1 } else { 3 };
            let (mut lo, mut hi) = (vec![f32::MAX; n], vec![f32::MIN; n]);
            for c in data.chunks(n) {
                for k in 0..n {
                    lo[k] = lo[k].min(c[k]);
                    hi[k] = hi[k].max(c[k]);
                }
            }
            acc["min"] = serde_json::json!(lo);
            acc["max"] = serde_json::json!(hi);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn indices(&mut self, data: &[u16]) -> usize {
        let offset = self.bin.len();
        for v in data {
            self.bin.extend_from_slice(&v.to_le_bytes());
        }
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views.push(
            serde_json::json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 2}),
        );
        self.accessors.push(serde_json::json!({"bufferView": self.views.len() - 1, "componentType": 5123, "count": data.len(), "type": "SCALAR"}));
        self.accessors.len() - 1
    }

    /// A box mesh `[lo, hi]` as (POSITION accessor, indices accessor).
    fn cuboid(&mut self, lo: Vec3, hi: Vec3) -> (usize, usize) {
        let mut p = Vec::new();
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            p.extend_from_slice(&c.to_array());
        }
        let ix: [u16; 36] = [
            0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4,
            6, 1, 3, 5, 3, 7, 5,
        ];
        (self.floats(&p, "VEC3", 8), self.indices(&ix))
    }
}

/// A channel's keys: frames and values (x, y, z[, w]); for `CUBICSPLINE` also the in- and
/// out-tangents of each key.
struct Keys {
    frames: Vec<f32>,
    values: Vec<[f32; 4]>,
    tangents: Vec<([f32; 4], [f32; 4])>,
}

fn camera_translation() -> Keys {
    Keys {
        frames: vec![1.0, 18.0, 24.0],
        values: vec![
            [0.0, 1.2, 8.0, 0.0],
            [0.5, 1.2, 5.0, 0.0],
            [0.8, 1.3, 4.0, 0.0],
        ],
        tangents: vec![
            ([0.0; 4], [0.6, 0.0, -2.0, 0.0]),
            ([0.4, 0.1, -3.0, 0.0], [0.4, 0.1, -3.0, 0.0]),
            ([0.2, 0.0, -1.0, 0.0], [0.0; 4]),
        ],
    }
}

fn rotation_keys(a: Quat, b: Quat) -> Keys {
    Keys {
        frames: vec![1.0, 24.0],
        values: vec![a.to_array(), b.to_array()],
        tangents: vec![([0.0; 4], [0.0; 4]), ([0.0; 4], [0.0; 4])],
    }
}

fn sun_rotation(azimuth: f32, elevation: f32) -> Quat {
    let (az, el) = (azimuth.to_radians(), elevation.to_radians());
    let to_sun = Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos());
    Quat::from_rotation_arc(Vec3::NEG_Z, -to_sun)
}

fn camera_rotation() -> Keys {
    rotation_keys(Quat::IDENTITY, Quat::from_rotation_y(8f32.to_radians()))
}

fn sun_keys() -> Keys {
    rotation_keys(sun_rotation(30.0, 60.0), sun_rotation(60.0, 30.0))
}

/// The expected value of `keys` at `frame` with interpolation `mode`, written out from the
/// glTF spec's formulas (held outside the keys; slerp for LINEAR rotations; Hermite for
/// CUBICSPLINE, normalised for rotations).
fn expected(keys: &Keys, mode: &str, frame: f32, rotation: bool) -> [f32; 4] {
    let t = frame / FPS;
    let times: Vec<f32> = keys.frames.iter().map(|f| f / FPS).collect();
    let n = times.len();
    if t <= times[0] {
        return keys.values[0];
    }
    if t >= times[n - 1] {
        return keys.values[n - 1];
    }
    let k = (0..n - 1).find(|k| t < times[k + 1]).unwrap();
    let td = times[k + 1] - times[k];
    let s = (t - times[k]) / td;
    let (v0, v1) = (keys.values[k], keys.values[k + 1]);
    match mode {
        "STEP" => v0,
        "LINEAR" if rotation => Quat::from_array(v0)
            .slerp(Quat::from_array(v1), s)
            .to_array(),
        "LINEAR" => std::array::from_fn(|i| v0[i] + (v1[i] - v0[i]) * s),
        _ => {
            let (b0, a1) = (keys.tangents[k].1, keys.tangents[k + 1].0);
            let h = [
                2.0 * s.powi(3) - 3.0 * s * s + 1.0,
                s.powi(3) - 2.0 * s * s + s,
                -2.0 * s.powi(3) + 3.0 * s * s,
                s.powi(3) - s * s,
            ];
            let p: [f32; 4] = std::array::from_fn(|i| {
                h[0] * v0[i] + h[1] * td * b0[i] + h[2] * v1[i] + h[3] * td * a1[i]
            });
            if rotation {
                Quat::from_array(p).normalize().to_array()
            } else {
                p
            }
        }
    }
}

fn sampler(g: &mut Gltf, keys: &Keys, mode: &str, vec4: bool) -> serde_json::Value {
    let times: Vec<f32> = keys.frames.iter().map(|f| f / FPS).collect();
    let input = g.floats(&times, "SCALAR", times.len());
    let n = if vec4 { 4 } else { 3 };
    let mut out = Vec::new();
    for (v, (a, b)) in keys.values.iter().zip(&keys.tangents) {
        if mode == "CUBICSPLINE" {
            out.extend_from_slice(&a[..n]);
            out.extend_from_slice(&v[..n]);
            out.extend_from_slice(&b[..n]);
        } else {
            out.extend_from_slice(&v[..n]);
        }
    }
    let count = out.len() / n;
    let output = g.floats(&out, if vec4 { "VEC4" } else { "VEC3" }, count);
    serde_json::json!({"input": input, "output": output, "interpolation": mode})
}

/// The test scene with every channel in `mode`; `target_node` overrides the camera
/// translation channel's node (a missing node for the bad-input test).
fn write_scene(dir: &std::path::Path, mode: &str, target_node: usize) -> std::path::PathBuf {
    let mut g = Gltf::default();
    let (ground_p, ground_i) = g.cuboid(Vec3::new(-10.0, -0.1, -10.0), Vec3::new(10.0, 0.0, 10.0));
    let (marker_p, marker_i) = g.cuboid(MARKER - HALF, MARKER + HALF);
    let samplers = vec![
        sampler(&mut g, &camera_translation(), mode, false),
        sampler(&mut g, &camera_rotation(), mode, true),
        sampler(&mut g, &sun_keys(), mode, true),
    ];
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 2049.0}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"name": "Ground", "mesh": 0},
            {"name": "Marker", "mesh": 1},
            {"name": "Camera", "camera": 0, "translation": [0.0, 1.2, 8.0]},
            {"name": "Sun", "extensions": {"KHR_lights_punctual": {"light": 0}}},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": YFOV, "znear": 0.05, "zfar": 100.0}}],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": ground_p}, "indices": ground_i, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": marker_p}, "indices": marker_i, "material": 1}]},
        ],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.2, 0.2, 1.0]}},
            {"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0]}},
        ],
        "animations": [{
            "name": "Shot",
            "samplers": samplers,
            "channels": [
                {"sampler": 0, "target": {"node": target_node, "path": "translation"}},
                {"sampler": 1, "target": {"node": 2, "path": "rotation"}},
                {"sampler": 2, "target": {"node": 3, "path": "rotation"}},
            ],
        }],
        "accessors": g.accessors,
        "bufferViews": g.views,
        "buffers": [{
            "byteLength": g.bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&g.bin)),
        }],
    });
    let path = dir.join(format!("shot_{}.gltf", mode.to_lowercase()));
    std::fs::write(&path, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    path
}

/// Where a camera at `position` with orientation `rotation` (looking down its local −Z, +Y up)
/// projects `p`, in pixels of a `W × H` image (x right, y down; pixel i covers [i, i + 1]).
fn project(position: Vec3, rotation: Quat, p: Vec3) -> (f32, f32) {
    let c = rotation.inverse() * (p - position);
    let t = (YFOV * 0.5).tan();
    let aspect = W as f32 / H as f32;
    let (x, y) = (c.x / -c.z / (t * aspect), c.y / -c.z / t);
    ((x + 1.0) * 0.5 * W as f32, (1.0 - y) * 0.5 * H as f32)
}

fn graph(path: &std::path::Path) -> String {
    format!(
        r#"(version: 2, nodes: {{
            "scene": (kind: "Scene", params: {{"path": "{}", "fps": 24.0}}),
            "gbuffer": (kind: "GBuffer"),
        }}, edges: [("scene.scene", "gbuffer.scene")])"#,
        path.display()
    )
}

#[test]
fn animated_camera_and_sun_follow_each_interpolation() {
    let Some(gpu) = common::gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let registry = Arc::new(tyndall::nodes::registry());
    for mode in ["STEP", "LINEAR", "CUBICSPLINE"] {
        let path = write_scene(dir.path(), mode, 2);
        let g = tyndall::graph::load_str(
            &graph(&path),
            std::path::Path::new("g.ron"),
            registry.catalog(),
        )
        .unwrap();
        let mut ev = Evaluator::new(registry.clone(), gpu.clone());
        let asset = tyndall::scene::parse_gltf(&path).unwrap();
        for frame in [1.0f32, 12.0, 24.0] {
            let opts = EvalOptions {
                size: (W, H),
                time: frame as f64,
                ..Default::default()
            };
            let target = [Target::Port("gbuffer".into(), "albedo".into())];
            let r = ev.evaluate(&g, &target, &opts).unwrap();
            let albedo = tyndall::eval::download(
                &gpu.recorder(),
                &r.outputs[&("gbuffer".into(), "albedo".into())],
            )
            .unwrap();
            let (mut sx, mut sy, mut n) = (0.0f64, 0.0f64, 0usize);
            for y in 0..H {
                for x in 0..W {
                    if albedo.pixel(x, y)[0] > 0.9 {
                        sx += x as f64 + 0.5;
                        sy += y as f64 + 0.5;
                        n += 1;
                    }
                }
            }
            assert!(n > 4, "{mode} frame {frame}: marker not seen ({n} px)");
            let got = ((sx / n as f64) as f32, (sy / n as f64) as f32);
            let pos = Vec3::from_slice(&expected(&camera_translation(), mode, frame, false)[..3]);
            let rot = Quat::from_array(expected(&camera_rotation(), mode, frame, true));
            let want = project(pos, rot, MARKER);
            let err = ((got.0 - want.0).powi(2) + (got.1 - want.1).powi(2)).sqrt();
            eprintln!("{mode} frame {frame}: {err:.3} px ({n} px marker)");
            assert!(
                err <= 1.0,
                "{mode} frame {frame}: marker at {got:?}, the camera projects it to {want:?} ({err:.2} px)"
            );
            // The sun turns: the posed scene's sun points where the expected rotation does.
            let scene = asset.pose(&[0], frame / FPS).unwrap();
            let q = Quat::from_array(expected(&sun_keys(), mode, frame, true));
            let to_sun = -(q * Vec3::NEG_Z);
            let angle = scene
                .find_sun("")
                .expect("sun")
                .to_sun()
                .angle_between(to_sun)
                .to_degrees();
            assert!(angle < 0.01, "{mode} frame {frame}: sun {angle}° off");
            assert_eq!(
                scene.find_sun("").expect("sun").intensity,
                3.0,
                "2049 lux = 3 W/m²"
            );
        }
        // Frame 12 tells the modes apart (the keys are at 1, 18 and 24).
        let at12 = expected(&camera_translation(), mode, 12.0, false);
        match mode {
            "STEP" => assert_eq!(at12[2], 8.0),
            _ => assert!(at12[2] < 7.0, "{mode}: {at12:?}"),
        }
        // After the last key the pose holds, so the scene is not posed again.
        let opts = EvalOptions {
            size: (W, H),
            time: 30.0,
            ..Default::default()
        };
        let r = ev
            .evaluate(
                &g,
                &[Target::Port("gbuffer".into(), "albedo".into())],
                &opts,
            )
            .unwrap();
        assert_eq!(
            r.stats.status("scene"),
            Some(Status::Reused),
            "{mode}: frame 30 = frame 24"
        );
    }
}

#[test]
fn animation_on_a_missing_node_or_a_missing_name_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(dir.path(), "LINEAR", 9);
    let e = tyndall::scene::parse_gltf(&path).unwrap_err().to_string();
    assert!(
        e.contains("animation 'Shot' channel 0 targets node 9, but the file has 4 nodes"),
        "{e}"
    );
    let path = write_scene(dir.path(), "LINEAR", 2);
    let asset = tyndall::scene::parse_gltf(&path).unwrap();
    let e = tyndall::scene::find_animation(&asset.animations, "Walk").unwrap_err();
    assert!(
        e.contains("no animation 'Walk'") && e.contains("0 'Shot'"),
        "{e}"
    );
    let lines = asset.describe_animations(24.0);
    assert_eq!(lines.len(), 1);
    assert!(lines[0].contains("frames 1–24 at 24 fps"), "{}", lines[0]);
}

/// `tests/fixtures/animated_shot.gltf` (the README's `tyndall validate` example) is this
/// file's LINEAR scene; `TYNDALL_BLESS=1` rewrites it.
#[test]
fn committed_animated_fixture_is_the_linear_scene() {
    let dir = tempfile::tempdir().unwrap();
    let made = std::fs::read_to_string(write_scene(dir.path(), "LINEAR", 2)).unwrap();
    let fixture =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/animated_shot.gltf");
    if std::env::var("TYNDALL_BLESS").is_ok_and(|v| v == "1") {
        std::fs::write(&fixture, &made).unwrap();
    }
    let committed = std::fs::read_to_string(&fixture).expect("the fixture");
    assert_eq!(
        made, committed,
        "TYNDALL_BLESS=1 cargo test --test evaluation animation:: rewrites it"
    );
}

/// A mesh's animation moves it in the posed scene, and so in the G-buffer and the shadow map:
/// the same file with the dolly channel on the marker instead of the camera.
#[test]
fn an_animated_mesh_moves_in_the_gbuffer_and_the_shadow_map() {
    let Some(gpu) = common::gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let path = write_scene(dir.path(), "LINEAR", 1); // node 1: the marker
    let asset = tyndall::scene::parse_gltf(&path).unwrap();
    let marker = |frame: f32| {
        let s = asset.pose(&[0], frame / FPS).unwrap();
        let o = s.objects.iter().find(|o| o.name == "Marker").unwrap();
        o.positions.iter().copied().sum::<Vec3>() / o.positions.len() as f32
    };
    // The channel's translation replaces the node's rest translation (none): the marker's
    // centre is its mesh centre plus the keyed translation.
    let (k1, k24) = (
        Vec3::from_slice(&camera_translation().values[0][..3]),
        Vec3::from_slice(&camera_translation().values[2][..3]),
    );
    assert!((marker(1.0) - (MARKER + k1)).length() < 1e-4);
    assert!((marker(24.0) - (MARKER + k24)).length() < 1e-4);
    let registry = Arc::new(tyndall::nodes::registry());
    let text = graph(&path).replace(
        r#""gbuffer": (kind: "GBuffer"),"#,
        r#""gbuffer": (kind: "GBuffer"), "shadow": (kind: "ShadowMap", params: {"resolution": 256}),
           "cast": (kind: "GBuffer", params: {"method": "ray_cast"}),"#,
    ).replace(r#"edges: [("scene.scene", "gbuffer.scene")]"#, r#"edges: [("scene.scene", "gbuffer.scene"), ("scene.scene", "shadow.scene"), ("scene.scene", "cast.scene")]"#);
    let g =
        tyndall::graph::load_str(&text, std::path::Path::new("g.ron"), registry.catalog()).unwrap();
    let at = |ev: &mut Evaluator, frame: f64| {
        let opts = EvalOptions {
            size: (W, H),
            time: frame,
            ..Default::default()
        };
        let targets = [
            Target::Port("gbuffer".into(), "depth".into()),
            Target::Port("shadow".into(), "map".into()),
            Target::Port("cast".into(), "depth".into()),
            Target::Port("scene".into(), "scene".into()),
        ];
        let r = ev.evaluate(&g, &targets, &opts).unwrap();
        let value = |n: &str, p: &str| r.outputs[&(n.to_string(), p.to_string())].clone();
        let read =
            |n: &str, p: &str| tyndall::eval::download(&gpu.recorder(), &value(n, p)).unwrap();
        let scene = match value("scene", "scene") {
            tyndall::eval::PortValue::Other(_, s) => {
                s.downcast::<tyndall::scene::GpuScene>().unwrap()
            }
            other => panic!("{other:?}"),
        };
        (
            read("gbuffer", "depth"),
            read("shadow", "map"),
            read("cast", "depth"),
            scene,
        )
    };
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    let (d1, s1, _, scene1) = at(&mut ev, 1.0);
    let (d24, s24, cast24, scene24) = at(&mut ev, 24.0);
    assert_ne!(d1.data, d24.data, "the G-buffer sees the marker move");
    assert_ne!(s1.data, s24.data, "the shadow map sees the marker move");
    // The marker moves by its placement: the meshes uploaded for frame 1 draw frame 24.
    let placed = |s: &tyndall::scene::GpuScene, name: &str| {
        s.scene
            .objects
            .iter()
            .find(|o| o.name == name)
            .unwrap()
            .placement
            .is_some()
    };
    assert!(placed(&scene24, "Marker") && !placed(&scene24, "Ground"));
    assert!(
        scene24.geometry_reused,
        "frame 24 uploaded its meshes again"
    );
    drop(scene1);
    // Placed on the GPU where the CPU places it: the ray cast (world-space triangles posed on
    // the CPU) sees the same picture, but for silhouette texels (as tests/nodes/ray_cast.rs).
    let apart = d24
        .data
        .iter()
        .zip(&cast24.data)
        .filter(|(a, b)| (*a - *b).abs() > 1e-2 * a.abs().max(1.0))
        .count();
    assert!(apart * 500 <= (W * H) as usize, "{apart} pixels apart");
    // Frame 24 alone, in a new evaluator, is the same picture bit for bit.
    let (alone_d, alone_s, _, _) = at(&mut Evaluator::new(registry, gpu.clone()), 24.0);
    assert_eq!(alone_d.data, d24.data);
    assert_eq!(alone_s.data, s24.data);
}

/// A shot as Blender's exporter writes it with its defaults: one animation per animated object
/// (`CameraAction`, `SunAction`) and lamps as `KHR_lights_punctual` spot and point lights.
fn write_blender_shot(dir: &std::path::Path) -> std::path::PathBuf {
    let mut g = Gltf::default();
    let (ground_p, ground_i) = g.cuboid(Vec3::new(-10.0, -0.1, -10.0), Vec3::new(10.0, 0.0, 10.0));
    let camera = sampler(&mut g, &camera_translation(), "LINEAR", false);
    let sun = sampler(&mut g, &sun_keys(), "LINEAR", true);
    let down = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "intensity": 2049.0},
            {"type": "spot", "name": "Spot.001", "intensity": 683.0 * 50.0, "color": [1.0, 0.5, 0.25], "range": 20.0,
             "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.4}},
            {"type": "point", "intensity": 683.0 * 10.0},
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4]}],
        "nodes": [
            {"name": "Ground", "mesh": 0},
            {"name": "Camera", "camera": 0, "translation": [0.0, 1.2, 8.0]},
            {"name": "Sun", "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "Spot", "translation": [1.0, 5.0, 0.0], "rotation": down.to_array(),
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"name": "Lamp", "translation": [-2.0, 1.5, 0.5], "extensions": {"KHR_lights_punctual": {"light": 2}}},
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": YFOV, "znear": 0.05, "zfar": 100.0}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": ground_p}, "indices": ground_i}]}],
        "animations": [
            {"name": "CameraAction", "samplers": [camera], "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}]},
            {"name": "SunAction", "samplers": [sun], "channels": [{"sampler": 0, "target": {"node": 2, "path": "rotation"}}]},
        ],
        "accessors": g.accessors,
        "bufferViews": g.views,
        "buffers": [{
            "byteLength": g.bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&g.bin)),
        }],
    });
    let path = dir.join("blender_shot.gltf");
    std::fs::write(&path, serde_json::to_string_pretty(&doc).unwrap()).unwrap();
    path
}

/// By default every animation of the file plays (the camera dollies *and* the sun turns), a
/// name plays one; every light is read with Blender's units (lux / 683 = W/m², cd / 683 = W/sr),
/// its cone, range and placement from its node; `ShadowMap`'s `light` finds them by name or
/// index, and names them when it finds none.
#[test]
fn a_blender_shot_plays_every_animation_and_reads_every_light() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_blender_shot(dir.path());
    let asset = tyndall::scene::parse_gltf(&path).unwrap();
    let all = tyndall::scene::find_animation(&asset.animations, "").unwrap();
    assert_eq!(all, vec![0, 1]);
    assert_eq!(
        tyndall::scene::find_animation(&asset.animations, "SunAction").unwrap(),
        vec![1]
    );
    assert!(tyndall::scene::find_animation(&asset.animations, "none")
        .unwrap()
        .is_empty());
    let t = 24.0 / FPS;
    let both = asset.pose(&all, t).unwrap();
    let camera_only = asset.pose(&[0], t).unwrap();
    let rest = asset.pose(&[], t).unwrap();
    let k = camera_translation().values[2];
    assert!((both.camera.position - Vec3::new(k[0], k[1], k[2])).length() < 1e-4);
    assert_eq!(both.camera.position, camera_only.camera.position);
    assert_ne!(both.camera.position, rest.camera.position);
    assert_ne!(
        both.find_sun("").expect("sun"),
        camera_only.find_sun("").expect("sun"),
        "the sun's own animation plays too"
    );

    let lights = &both.lights;
    let names: Vec<&str> = lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["Sun", "Spot", "Lamp"], "node order");
    assert_eq!(lights[0].intensity, 3.0, "2049 lux = 3 W/m²");
    assert_eq!(both.find_sun("").expect("sun"), lights[0].as_sun().unwrap());
    let spot = &lights[1];
    assert!((spot.intensity - 50.0).abs() < 1e-4, "cd / 683 = W/sr");
    assert_eq!(spot.colour, [1.0, 0.5, 0.25]);
    assert_eq!(spot.range, Some(20.0));
    match spot.kind {
        tyndall::scene::LightKind::Spot {
            position,
            direction,
            inner,
            outer,
        } => {
            assert!((position - Vec3::new(1.0, 5.0, 0.0)).length() < 1e-5);
            assert!((direction - Vec3::NEG_Y).length() < 1e-5, "{direction}");
            assert_eq!((inner, outer), (0.2, 0.4));
        }
        k => panic!("{k:?}"),
    }
    assert!(
        matches!(lights[2].kind, tyndall::scene::LightKind::Point { position } if (position - Vec3::new(-2.0, 1.5, 0.5)).length() < 1e-5)
    );
    assert_eq!(both.find_light("").unwrap().name, "Sun");
    assert_eq!(both.find_light("2").unwrap().name, "Lamp");
    assert_eq!(both.find_light("Spot").unwrap().type_name(), "spot");
    let e = both.find_light("Moon").unwrap_err();
    assert!(
        e.contains("no light 'Moon'")
            && e.contains("1 'Spot' (spot)")
            && e.contains("2 'Lamp' (point)"),
        "{e}"
    );
}

/// `tyndall validate` lists the lights and what plays, and refuses a light it cannot use with
/// the node and the value (exit 2).
#[test]
fn validate_lists_lights_and_refuses_a_bad_cone() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_blender_shot(dir.path());
    let graph = dir.path().join("shot.ron");
    std::fs::write(
        &graph,
        r#"(version: 2, nodes: {"scene": (kind: "Scene", params: {"path": "blender_shot.gltf"})}, edges: [])"#,
    )
    .unwrap();
    let run = || {
        std::process::Command::new(env!("CARGO_BIN_EXE_tyndall"))
            .args(["validate", &graph.display().to_string()])
            .output()
            .unwrap()
    };
    let o = run();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{out}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(out.contains("plays all 2 together"), "{out}");
    assert!(out.contains("light 'Spot': spot, 50"), "{out}");
    assert!(out.contains("light 'Lamp': point, 10"), "{out}");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("\"innerConeAngle\": 0.2", "\"innerConeAngle\": 0.6");
    std::fs::write(&path, text).unwrap();
    let o = run();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("node 'scene'")
            && err.contains("light 'Spot'")
            && err.contains("inner 34.377°"),
        "{err}"
    );
}
