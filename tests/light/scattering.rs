//! Scenes, shadow maps, G-buffers and single scattering: GPU against the CPU reference, an
//! analytic slit, and numerical stability at the extremes (SPEC §3, issue: scattering).

use crate::common;
use std::collections::BTreeMap;
use std::sync::Arc;

use glam::{Mat4, Vec3};
use tyndall::eval::{download, EvalOptions, Evaluator, Matrices, PortValue, Target};
use tyndall::graph::{Graph, ParamValue};
use tyndall::io::Raster;
use tyndall::nodes::algorithms::shader_lib::{decay_integral, henyey_greenstein};
use tyndall::nodes::single_scattering::{
    epipolar_reference, reference_pixel, EpiKnobs, Params as ScatteringParams, ScatterParams,
};

/// What a scattering evaluation produced, read back.
pub(crate) struct Run {
    pub(crate) shadow: Raster,
    pub(crate) light: Matrices,
    pub(crate) depth: Raster,
    pub(crate) camera: Matrices,
    pub(crate) vis: Raster,
    pub(crate) inscatter: Raster,
    pub(crate) transmittance: Raster,
}

/// Parameter list of one node.
type Params = Vec<(&'static str, ParamValue)>;

/// A stability case: name, Scene parameters, SingleScattering parameters.
type Case = (&'static str, Params, Params);

fn p(v: f64) -> ParamValue {
    ParamValue::Float(v)
}

/// Scene → ShadowMap → GBuffer → SingleScattering with the given parameters.
pub(crate) fn run_scene(
    gpu: &Arc<tyndall::gpu::Gpu>,
    scene: &[(&str, ParamValue)],
    map: i64,
    size: (u32, u32),
    scatter: &[(&str, ParamValue)],
) -> Run {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    for (id, kind) in [
        ("scene", "Scene"),
        ("shadow", "ShadowMap"),
        ("gbuffer", "GBuffer"),
        ("scatter", "SingleScattering"),
    ] {
        g.insert_node(
            &cat,
            tyndall::graph::Node {
                id: id.into(),
                kind: kind.into(),
                params: BTreeMap::new(),
                keys: BTreeMap::new(),
                pos: None,
                data: None,
            },
        )
        .expect("node");
    }
    for (a, b) in [
        ("scene.scene", "shadow.scene"),
        ("scene.scene", "gbuffer.scene"),
        ("shadow.map", "scatter.shadow"),
        ("gbuffer.depth", "scatter.depth"),
        ("scene.scene", "scatter.scene"), // only read with bounds = tagged
    ] {
        g.connect(&cat, a, b).expect("edge");
    }
    for (k, v) in scene {
        g.set_param(&cat, "scene", k, v.clone())
            .expect("scene param");
    }
    g.set_param(&cat, "shadow", "resolution", ParamValue::Int(map))
        .expect("res");
    for (k, v) in scatter {
        g.set_param(&cat, "scatter", k, v.clone())
            .expect("scatter param");
    }
    let targets: Vec<Target> = [
        ("shadow", "map"),
        ("gbuffer", "depth"),
        ("scatter", "visibility"),
        ("scatter", "inscatter"),
        ("scatter", "transmittance"),
    ]
    .iter()
    .map(|(n, p)| Target::Port(n.to_string(), p.to_string()))
    .collect();
    let mut ev = Evaluator::new(registry, gpu.clone());
    let r = ev
        .evaluate(
            &g,
            &targets,
            &EvalOptions {
                size,
                ..Default::default()
            },
        )
        .expect("evaluate");
    let get = |n: &str, p: &str| r.outputs[&(n.to_string(), p.to_string())].clone();
    let (light, camera) = match (get("shadow", "map"), get("gbuffer", "depth")) {
        (PortValue::ShadowMap(_, l), PortValue::Depth(_, c)) => (l, c),
        _ => panic!("port types"),
    };
    let dl = |v: PortValue| download(&gpu.recorder(), &v).expect("download");
    Run {
        shadow: dl(get("shadow", "map")),
        light,
        depth: dl(get("gbuffer", "depth")),
        camera,
        vis: dl(get("scatter", "visibility")),
        inscatter: dl(get("scatter", "inscatter")),
        transmittance: dl(get("scatter", "transmittance")),
    }
}

/// The node's defaults (σt 0.08, ρ 0.9, g 0.5, bias 0.002, exact MinMax) with `steps` samples
/// per ray and `jitter`, as a run of the node would read them.
fn medium(steps: u32, jitter: f32) -> ScatteringParams {
    ScatteringParams::with_overrides(&[
        ("steps", ParamValue::Int(steps.into())),
        ("jitter", ParamValue::Float(jitter.into())),
    ])
    .expect("declared parameters")
}

pub(crate) fn assert_finite(r: &Run, what: &str) {
    for (name, img) in [
        ("visibility", &r.vis),
        ("inscatter", &r.inscatter),
        ("transmittance", &r.transmittance),
    ] {
        assert!(
            img.data.iter().all(|v| v.is_finite()),
            "{what}: non-finite {name}"
        );
    }
    assert!(
        r.vis.data.iter().all(|v| (0.0..=1.0).contains(v)),
        "{what}: V̄ outside [0, 1]"
    );
}

/// Compare a brute-force run with the CPU reference, pixel by pixel: V̄ within 2 flips of one
/// step, in-scatter to 1e-4 relative plus `slack(channel, depth)` where V̄ agrees,
/// transmittance to 1e-6 plus `slack(3, depth)`. Returns the number of pixels whose V̄ differs
/// and the reference transmittance of every pixel.
pub(crate) fn compare_brute_force(
    r: &Run,
    params: &ScatterParams,
    steps: i64,
    slack: impl Fn(usize, f32) -> f32,
) -> (usize, Vec<f32>) {
    let (w, h) = (r.depth.width, r.depth.height);
    let mut differing = 0;
    let mut transmittance = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let depth = r.depth.pixel(x, y)[0];
            let (v, ins, t) = reference_pixel(params, &r.shadow, depth, x, y, w, h);
            let gv = r.vis.pixel(x, y)[0];
            assert!(
                (gv - v).abs() <= 2.0 / steps as f32 + 1e-6,
                "V̄ at ({x},{y}): gpu {gv} cpu {v}"
            );
            if gv != v {
                differing += 1;
            } else {
                for (c, (g, want)) in r.inscatter.pixel(x, y).iter().zip(ins).enumerate() {
                    assert!(
                        (g - want).abs() <= 1e-4 * want.abs() + 1e-7 + slack(c, depth),
                        "inscatter at ({x},{y}): {g} vs {want}"
                    );
                }
            }
            assert!((r.transmittance.pixel(x, y)[0] - t).abs() <= 1e-6 + slack(3, depth));
            transmittance.push(t);
        }
    }
    (differing, transmittance)
}

/// GPU brute force against the CPU reference on the same shadow map and depth. Both evaluate
/// the same f32 formulas, but matrix products may round differently (fused multiply-adds on the
/// GPU), so a sample lying within rounding of a texel edge or of the depth test can flip: each
/// flip changes V̄ by 1/steps. We allow up to 2 flips on a pixel and flips on at most 2% of
/// pixels; in-scatter must then agree to 1e-4 relative where V̄ agrees.
#[test]
fn brute_force_matches_cpu_reference() {
    let gpu = require_gpu!();
    let steps = 64;
    let r = run_scene(
        &gpu,
        &[("name", ParamValue::Enum("tree".into()))],
        256,
        (64, 36),
        &[("steps", ParamValue::Int(steps)), ("jitter", p(0.5))],
    );
    let params = ScatterParams::new(&r.camera, &r.light, &medium(steps as u32, 0.5));
    let (w, h) = (r.depth.width, r.depth.height);
    let (differing, _) = compare_brute_force(&r, &params, steps, |_, _| 0.0);
    assert!(
        differing * 50 <= (w * h) as usize,
        "{differing} of {} pixels differ",
        w * h
    );
    assert!(
        r.vis.data.iter().any(|v| *v < 0.95),
        "the view should cross shadows"
    );
}

/// MinMax computes the limit of brute force as steps → ∞: compare with the CPU reference at
/// 8192 steps, whose own error is at most (number of light/shadow transitions) / 8192 per pixel.
#[test]
fn min_max_matches_dense_cpu_reference() {
    let gpu = require_gpu!();
    let r = run_scene(
        &gpu,
        &[("name", ParamValue::Enum("tree".into()))],
        256,
        (48, 27),
        &[("method", ParamValue::Enum("MinMax".into()))],
    );
    let params = ScatterParams::new(&r.camera, &r.light, &medium(8192, 0.0));
    let (w, h) = (r.depth.width, r.depth.height);
    let mut sum = 0.0;
    for y in 0..h {
        for x in 0..w {
            let (v, _, _) = reference_pixel(&params, &r.shadow, r.depth.pixel(x, y)[0], x, y, w, h);
            let d = (r.vis.pixel(x, y)[0] - v).abs();
            assert!(
                d <= 0.005,
                "({x},{y}): MinMax {} vs 8192 steps {v}",
                r.vis.pixel(x, y)[0]
            );
            sum += d;
        }
    }
    assert!(
        sum / ((w * h) as f32) <= 5e-4,
        "mean error {}",
        sum / ((w * h) as f32)
    );
    assert_finite(&r, "MinMax");
}

/// Exact V̄ of the slit scene: piecewise-constant visibility between the ray's crossings of the
/// box faces, the slit edges and the occluder depth.
fn analytic_slit(eye: Vec3, dir: Vec3, s: f32, bias: f32) -> f32 {
    let mut cuts = vec![0.0f32, s];
    for (axis, planes) in [
        (0usize, vec![-1.0f32, -0.25, 0.25, 1.0]),
        (1, vec![-1.0, 1.0]),
        (2, vec![0.0, 0.5 + bias, 1.0]),
    ] {
        for plane in planes {
            if dir[axis].abs() > 1e-9 {
                let t = (plane - eye[axis]) / dir[axis];
                if t > 0.0 && t < s {
                    cuts.push(t);
                }
            }
        }
    }
    cuts.sort_by(f32::total_cmp);
    // Outside the map's footprint nothing casts a shadow; inside it the plane shadows every
    // point behind it, at any depth (past the map's range z ≤ 1 too: issue #60).
    let lit = |q: Vec3| {
        let outside = q.x < -1.0 || q.x >= 1.0 || q.y <= -1.0 || q.y > 1.0;
        outside || q.z <= 0.5 + bias || (-0.25..0.25).contains(&q.x)
    };
    let mut sum = 0.0;
    for w in cuts.windows(2) {
        if lit(eye + dir * (0.5 * (w[0] + w[1]))) {
            sum += w[1] - w[0];
        }
    }
    sum / s
}

/// An occluder plane at light depth 0.5 with a slit |x| < 0.25, light matrices identity (light
/// clip space = world space), seen by a camera whose rays cross the slit's shadow edges.
#[test]
fn slit_matches_the_analytic_visibility() {
    let gpu = require_gpu!();
    let n = 256;
    let mut map = Raster::new(n, n, 1, 0.5);
    for y in 0..n {
        for x in 96..160 {
            // u ∈ [0.375, 0.625): world x ∈ [−0.25, 0.25), no occluder.
            map.data[(y * n + x) as usize] = tyndall::eval::SHADOW_CLEAR;
        }
    }
    let eye = Vec3::new(-0.8, 0.05, 0.9);
    let view = glam::camera::rh::view::look_at_mat4(eye, Vec3::new(0.8, 0.1, 0.65), Vec3::Y);
    let proj = glam::camera::rh::proj::directx::perspective(50f32.to_radians(), 1.0, 0.01, 10.0);
    let camera = Matrices {
        view: view.to_cols_array_2d(),
        proj: proj.to_cols_array_2d(),
        far: 10.0,
        radiance: [0.0; 3],
        local: None,
    };
    let (w, h) = (16u32, 16u32);
    let mut depth = Raster::new(w, h, 1, 0.0);
    for (i, v) in depth.data.iter_mut().enumerate() {
        *v = 1.2 + 0.3 * (i % 7) as f32 / 7.0;
    }
    let light = Matrices::default();
    let inv = (proj * view).inverse();
    for (method, steps, tol) in [("MinMax", 1i64, 1e-4f32), ("BruteForce", 4096, 1e-3)] {
        let out = common::run_node(
            &gpu,
            "SingleScattering",
            &[
                ("method", ParamValue::Enum(method.into())),
                ("steps", ParamValue::Int(steps)),
                ("bias", p(0.0)),
            ],
            vec![
                (
                    "shadow",
                    PortValue::ShadowMap(
                        Arc::new(gpu.upload(n, n, 1, &map.data).expect("map")),
                        light,
                    ),
                ),
                (
                    "depth",
                    PortValue::Depth(
                        Arc::new(gpu.upload(w, h, 1, &depth.data).expect("depth")),
                        camera,
                    ),
                ),
            ],
            &["visibility"],
            (w, h),
        )
        .expect("evaluate");
        let mut worst = 0.0f32;
        let mut spread = (1.0f32, 0.0f32);
        for y in 0..h {
            for x in 0..w {
                let dir = tyndall::eval::pixel_ray(inv, eye, x, y, w, h);
                let s = depth.pixel(x, y)[0];
                let want = analytic_slit(eye, dir, s, 0.0);
                let got = out["visibility"].pixel(x, y)[0];
                worst = worst.max((got - want).abs());
                spread = (spread.0.min(want), spread.1.max(want));
            }
        }
        assert!(worst <= tol, "{method}: worst error {worst}");
        assert!(
            spread.0 < 0.5 && spread.1 > 0.5,
            "the rays should cross light and shadow: {spread:?}"
        );
    }
}

fn synthetic(gpu: &Arc<tyndall::gpu::Gpu>, fill: f32, method: &str, steps: i64) -> Raster {
    let n = 64;
    let map = Raster::new(n, n, 1, fill);
    let eye = Vec3::new(-0.5, 0.0, 0.2);
    let view = glam::camera::rh::view::look_at_mat4(eye, Vec3::new(0.5, 0.2, 0.6), Vec3::Y);
    let proj = glam::camera::rh::proj::directx::perspective(40f32.to_radians(), 1.0, 0.01, 10.0);
    let camera = Matrices {
        view: view.to_cols_array_2d(),
        proj: proj.to_cols_array_2d(),
        far: 10.0,
        radiance: [0.0; 3],
        local: None,
    };
    let depth = Raster::new(8, 8, 1, 0.6); // every ray stays inside the light box, above depth 0
    common::run_node(
        gpu,
        "SingleScattering",
        &[
            ("method", ParamValue::Enum(method.into())),
            ("steps", ParamValue::Int(steps)),
            ("bias", p(0.0)),
        ],
        vec![
            (
                "shadow",
                PortValue::ShadowMap(
                    Arc::new(gpu.upload(n, n, 1, &map.data).expect("map")),
                    Matrices::default(),
                ),
            ),
            (
                "depth",
                PortValue::Depth(
                    Arc::new(gpu.upload(8, 8, 1, &depth.data).expect("depth")),
                    camera,
                ),
            ),
        ],
        &["visibility"],
        (8, 8),
    )
    .expect("evaluate")
    .remove("visibility")
    .expect("visibility")
}

#[test]
fn empty_map_is_fully_lit_and_full_map_fully_shadowed_exactly() {
    let gpu = require_gpu!();
    for (method, steps) in [
        ("BruteForce", 1),
        ("BruteForce", 97),
        ("MinMax", 1),
        ("Epipolar", 1),
    ] {
        assert!(
            synthetic(&gpu, 1.0, method, steps)
                .data
                .iter()
                .all(|v| *v == 1.0),
            "{method} {steps}: empty map"
        );
        assert!(
            synthetic(&gpu, 0.0, method, steps)
                .data
                .iter()
                .all(|v| *v == 0.0),
            "{method} {steps}: full map"
        );
    }
}

#[test]
fn scattering_factor_limits() {
    assert_eq!(decay_integral(7.5, 0.0), 7.5, "σt = 0: the integral is L·s");
    assert!((decay_integral(7.5, 1e-9) - 7.5).abs() < 1e-5);
    assert!((decay_integral(2.0, 1e4) - 1e-4).abs() < 1e-9);
    let mid = decay_integral(2.0, 0.5);
    assert!((mid - (1.0 - (-1.0f32).exp()) / 0.5).abs() < 1e-6);
}

/// σt at 0 and 1e4, g at ±0.999, light parallel to the view (both ways), camera inside an
/// occluder, sky pixels, one step: everything finite, V̄ in [0, 1], and MinMax close to brute
/// force at 2048 steps. Midpoint sampling misjudges at most half an interval per light/shadow
/// boundary the ray crosses; rays through the tree's canopy cross up to ~16, so the bound is
/// 16 · 1/(2 · 2048).
#[test]
fn extremes_stay_finite_and_methods_agree() {
    let gpu = require_gpu!();
    let tree = ("name", ParamValue::Enum("tree".into()));
    let custom_cam = |pos: Vec3, target: Vec3| -> Vec<(&'static str, ParamValue)> {
        vec![
            ("name", ParamValue::Enum("figure".into())),
            ("camera", ParamValue::Enum("custom".into())),
            ("cam_x", p(pos.x as f64)),
            ("cam_y", p(pos.y as f64)),
            ("cam_z", p(pos.z as f64)),
            ("target_x", p(target.x as f64)),
            ("target_y", p(target.y as f64)),
            ("target_z", p(target.z as f64)),
        ]
    };
    // The figure scene's sun: azimuth 190°, elevation 30°.
    let to_sun = {
        let (az, el) = (190f32.to_radians(), 30f32.to_radians());
        Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos())
    };
    let eye = Vec3::new(0.0, 1.5, 4.0);
    let cases: Vec<Case> = vec![
        ("sigma_t = 0", vec![tree.clone()], vec![("sigma_t", p(0.0))]),
        (
            "sigma_t = 1e4",
            vec![tree.clone()],
            vec![("sigma_t", p(1e4))],
        ),
        ("g = 0.999", vec![tree.clone()], vec![("g", p(0.999))]),
        ("g = -0.999", vec![tree.clone()], vec![("g", p(-0.999))]),
        ("looking at the sun", custom_cam(eye, eye + to_sun), vec![]),
        (
            "sun behind the camera",
            custom_cam(eye, eye - to_sun),
            vec![],
        ),
        (
            "camera inside the figure",
            custom_cam(Vec3::new(0.0, 1.75, 0.0), Vec3::new(0.0, 1.0, 5.0)),
            vec![],
        ),
    ];
    for (what, scene, extra) in cases {
        let mut brute = extra.clone();
        brute.push(("steps", ParamValue::Int(2048)));
        let mut fast = extra.clone();
        fast.push(("method", ParamValue::Enum("MinMax".into())));
        let a = run_scene(&gpu, &scene, 512, (24, 16), &brute);
        let b = run_scene(&gpu, &scene, 512, (24, 16), &fast);
        assert_finite(&a, what);
        assert_finite(&b, what);
        let d = common::max_abs_diff(&a.vis, &b.vis);
        assert!(
            d <= 16.0 / (2.0 * 2048.0),
            "{what}: MinMax differs from 2048 steps by {d}"
        );
        if what == "sigma_t = 0" {
            assert!(
                a.inscatter.data.iter().all(|v| *v == 0.0 || *v == 1.0),
                "σt = 0 scatters nothing"
            );
            assert!(a.transmittance.data.iter().all(|v| *v == 1.0));
        }
        if what == "sigma_t = 1e4" {
            assert!(a.transmittance.data.iter().all(|v| *v == 0.0 || *v < 1e-30));
        }
        if what == "camera inside the figure" {
            assert!(a.vis.data.iter().any(|v| *v < 1.0));
        }
    }
    // Sky pixels: the default views of the built-in scenes all show sky (depth = far).
    let r = run_scene(
        &gpu,
        &[tree],
        256,
        (24, 16),
        &[("steps", ParamValue::Int(1))],
    );
    assert_finite(&r, "one step");
    assert!(r.depth.data.contains(&60.0), "no sky pixel in view");
}

#[test]
fn largest_allowed_shadow_map() {
    let gpu = require_gpu!();
    let largest = gpu.limits.max_texture_dimension_2d.min(16384) as i64;
    let scene = [("name", ParamValue::Enum("figure".into()))];
    let a = run_scene(
        &gpu,
        &scene,
        largest,
        (16, 9),
        &[("steps", ParamValue::Int(256))],
    );
    let b = run_scene(
        &gpu,
        &scene,
        largest,
        (16, 9),
        &[("method", ParamValue::Enum("MinMax".into()))],
    );
    assert_finite(&a, "largest map, brute force");
    assert_finite(&b, "largest map, MinMax");
    assert!(common::max_abs_diff(&a.vis, &b.vis) <= 4.0 / 256.0);
    // A request beyond the device limit is refused, naming the limit.
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let s = g.add_node(&cat, "Scene").expect("scene");
    let m = g.add_node(&cat, "ShadowMap").expect("map");
    g.connect(&cat, &format!("{s}.scene"), &format!("{m}.scene"))
        .expect("edge");
    if gpu.limits.max_texture_dimension_2d < 16384 {
        g.set_param(&cat, &m, "resolution", ParamValue::Int(16384))
            .expect("param");
        let err = Evaluator::new(registry, gpu.clone())
            .evaluate(
                &g,
                &[Target::Port(m.clone(), "map".into())],
                &EvalOptions::default(),
            )
            .expect_err("beyond the limit");
        assert!(
            err.to_string()
                .contains(&gpu.limits.max_texture_dimension_2d.to_string()),
            "{err}"
        );
    }
}

#[test]
fn gltf_fixture_loads_camera_light_tags_and_renders() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/scene.gltf");
    let scene = tyndall::scene::load_gltf(&path).expect("load");
    assert_eq!(scene.objects.len(), 3);
    assert!((scene.camera.fov_y - 50.0).abs() < 1e-3);
    assert!((scene.camera.position - Vec3::new(1.5, 1.6, 7.0)).length() < 1e-4);
    let fwd = (scene.camera.target - scene.camera.position).normalize();
    assert!(
        (fwd - Vec3::new(-1.5, 0.4, -7.0).normalize()).length() < 1e-4,
        "{fwd}"
    );
    let to_sun = scene.find_sun("").expect("sun").to_sun();
    assert!(
        (to_sun + Vec3::new(0.2, -0.55, 1.0).normalize()).length() < 1e-4,
        "{to_sun}"
    );
    assert_eq!(scene.find_sun("").expect("sun").intensity, 3.0);
    assert!(
        scene
            .objects
            .iter()
            .filter(|o| o.tags.contains(&"occluder".to_string()))
            .count()
            == 2
    );
    let err =
        tyndall::scene::load_gltf(std::path::Path::new("/nonexistent.gltf")).expect_err("missing");
    assert!(err.to_string().contains("/nonexistent.gltf"));
}

#[test]
fn builtin_scenes_are_deterministic_and_distinct_per_seed() {
    for name in tyndall::scene::BUILTIN_SCENES {
        let a = tyndall::scene::builtin(name, 7).expect("build");
        assert_eq!(
            a,
            tyndall::scene::builtin(name, 7).expect("build"),
            "{name} is not deterministic"
        );
        assert!(a.triangles() > 0);
        assert!(a
            .objects
            .iter()
            .all(|o| o.positions.iter().all(|p| p.is_finite())));
    }
    let a = tyndall::scene::builtin("tree", 1).expect("tree");
    let b = tyndall::scene::builtin("tree", 2).expect("tree");
    assert_ne!(a, b, "the seed should vary the tree");
    assert!(tyndall::scene::builtin("nope", 1).is_err());
}

#[test]
fn shadow_map_fits_the_scene_bounds_and_filters_tags() {
    let gpu = require_gpu!();
    let all = run_scene(
        &gpu,
        &[("name", ParamValue::Enum("tree".into()))],
        128,
        (8, 8),
        &[],
    );
    // Depths within the fitted range, or clear where nothing was drawn.
    assert!(all
        .shadow
        .data
        .iter()
        .all(|v| (0.0..=1.0).contains(v) || *v == tyndall::eval::SHADOW_CLEAR));
    assert!(
        all.shadow.data.iter().any(|v| *v < 0.5),
        "the canopy should be near the light"
    );
    // The light box is fitted to the scene's bounds: their corners span depth 0 to 1 (up to
    // the 1e-3 margin) and the map's extent.
    let scene = tyndall::scene::builtin("tree", 1).expect("tree");
    let (view, proj) =
        tyndall::scene::fit_light(scene.find_sun("").expect("sun").to_sun(), scene.bounds());
    let (lo, hi) = scene.bounds();
    let (mut zmin, mut zmax) = (f32::MAX, f32::MIN);
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let q = (proj * view).project_point3(c);
        assert!(
            q.x.abs() <= 1.0 && q.y.abs() <= 1.0,
            "corner {c} outside the map: {q}"
        );
        zmin = zmin.min(q.z);
        zmax = zmax.max(q.z);
    }
    assert!(
        (0.0..0.01).contains(&zmin) && zmax <= 1.0 && zmax > 0.99,
        "depth span {zmin}..{zmax}"
    );
    let m = Mat4::from_cols_array_2d(&all.light.proj) * Mat4::from_cols_array_2d(&all.light.view);
    assert!(m.is_finite());
    // Tag filters: only the foliage, or everything but the foliage.
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let map_with = |include: &str, exclude: &str| -> Raster {
        let mut g = Graph::new();
        let sc = g.add_node(&cat, "Scene").expect("scene");
        g.set_param(&cat, &sc, "name", ParamValue::Enum("tree".into()))
            .expect("name");
        let sm = g.add_node(&cat, "ShadowMap").expect("map");
        g.set_param(&cat, &sm, "resolution", ParamValue::Int(128))
            .expect("res");
        g.set_param(&cat, &sm, "include", ParamValue::Text(include.into()))
            .expect("include");
        g.set_param(&cat, &sm, "exclude", ParamValue::Text(exclude.into()))
            .expect("exclude");
        g.connect(&cat, &format!("{sc}.scene"), &format!("{sm}.scene"))
            .expect("edge");
        let r = Evaluator::new(registry.clone(), gpu.clone())
            .evaluate(
                &g,
                &[Target::Port(sm.clone(), "map".into())],
                &EvalOptions::default(),
            )
            .expect("map");
        download(&gpu.recorder(), &r.outputs[&(sm, "map".to_string())]).expect("download")
    };
    let foliage = map_with("foliage", "");
    let rest = map_with("", "foliage");
    let empty = |r: &Raster| {
        r.data
            .iter()
            .filter(|v| tyndall::eval::is_clear(**v))
            .count()
    };
    assert!(
        empty(&foliage) > empty(&all.shadow),
        "without the ground, more texels stay empty"
    );
    for i in 0..all.shadow.data.len() {
        // Everything = the nearer of the two partial maps.
        assert_eq!(
            all.shadow.data[i],
            foliage.data[i].min(rest.data[i]),
            "texel {i}"
        );
    }
}

/// Rasterisation against CPU maths: in the torus scene every shadow-map texel holds the ground
/// plane's light-space depth (computed on the CPU from the light matrices) unless the torus is
/// nearer, and likewise every G-buffer pixel holds the analytic distance to the ground unless
/// the torus or the sky is seen. Rasterisation interpolates depth in f32 across large triangles,
/// so values agree within 1e-4 (light depth) and 1e-3 m (distance, about 10 m away).
#[test]
fn shadow_map_and_gbuffer_match_the_ground_plane_analytically() {
    let gpu = require_gpu!();
    let r = run_scene(
        &gpu,
        &[("name", ParamValue::Enum("torus".into()))],
        128,
        (64, 36),
        &[],
    );
    let lvp = r.light.view_proj();
    let inv = lvp.inverse();
    let (mut ground, mut nearer) = (0, 0);
    for y in 0..128u32 {
        for x in 0..128u32 {
            let (nx, ny) = (
                (x as f32 + 0.5) / 128.0 * 2.0 - 1.0,
                1.0 - (y as f32 + 0.5) / 128.0 * 2.0,
            );
            let a = inv.project_point3(Vec3::new(nx, ny, 0.0));
            let b = inv.project_point3(Vec3::new(nx, ny, 1.0));
            // Where the light ray through the texel meets y = 0; orthographic depth runs linearly
            // from 0 at a to 1 at b, so t is also the expected depth.
            let t = a.y / (a.y - b.y);
            let p = a + (b - a) * t;
            // Outside the 20 m ground square nothing is drawn unless the torus is: clear.
            let want = if p.x.abs() <= 10.0 && p.z.abs() <= 10.0 {
                t
            } else {
                tyndall::eval::SHADOW_CLEAR
            };
            let got = r.shadow.pixel(x, y)[0];
            assert!(
                got <= want + 1e-4,
                "texel ({x},{y}): {got} behind the ground {want}"
            );
            if (got - want).abs() <= 1e-4 {
                ground += 1;
            } else {
                nearer += 1;
            }
        }
    }
    assert!(
        ground > 128 * 128 * 3 / 4 && nearer > 100,
        "ground {ground}, torus {nearer}"
    );
    let vp = r.camera.view_proj();
    let inv = vp.inverse();
    let eye = r.camera.eye();
    let (mut hits, mut other) = (0, 0);
    for y in 0..36u32 {
        for x in 0..64u32 {
            let ndc = Vec3::new(
                (x as f32 + 0.5) / 64.0 * 2.0 - 1.0,
                1.0 - (y as f32 + 0.5) / 36.0 * 2.0,
                1.0,
            );
            let dir = (inv.project_point3(ndc) - eye).normalize();
            let got = r.depth.pixel(x, y)[0];
            let t = -eye.y / dir.y;
            let p = eye + dir * t;
            let on_ground =
                dir.y < 0.0 && p.x.abs() <= 10.0 && p.z.abs() <= 10.0 && t < r.camera.far;
            if on_ground && (got - t).abs() <= 1e-3 {
                hits += 1;
            } else {
                assert!(
                    !on_ground || got < t,
                    "pixel ({x},{y}): {got} beyond the ground at {t}"
                );
                other += 1;
            }
        }
    }
    assert!(
        hits > 64 * 36 / 3 && other > 0,
        "ground pixels {hits}, others {other}"
    );
}

// ---- Bounded media and light-path extinction ---------------------------------------------

fn v3(v: [f64; 3]) -> ParamValue {
    ParamValue::Vec3(v)
}

fn en(v: &str) -> ParamValue {
    ParamValue::Enum(v.into())
}

/// A box around the tree's canopy and trunk, smaller than the view, so rays enter and leave it.
const TREE_BOX: ([f64; 3], [f64; 3]) = ([-3.0, 0.0, -3.0], [3.0, 7.0, 3.0]);

fn bounded(extra: &[(&'static str, ParamValue)]) -> Params {
    let mut v = vec![
        ("bounds", en("box")),
        ("box_min", v3(TREE_BOX.0)),
        ("box_max", v3(TREE_BOX.1)),
        ("light_extinction", en("on")),
    ];
    v.extend(extra.iter().cloned());
    v
}

fn tree_box() -> Option<(Vec3, Vec3)> {
    let f = |v: [f64; 3]| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
    Some((f(TREE_BOX.0), f(TREE_BOX.1)))
}

/// How far the in-scatter may move when the ends of the view ray's stretch in the box move: the
/// view ray comes out of the f32 inverse view-projection (far point ÷ w) good to ~1e-6 relative
/// and rounded differently on the GPU (fused multiply-adds) and the CPU; where it meets a face
/// at a shallow angle an end moves up to ~10× that along the ray (measured: 4e-5 m at 7.4 m, a
/// 0.13 m chord across a box corner). Allow each end 1e-5 of the depth `s`, times the largest
/// integrand, E σt ρ max f (weights are at most 1).
fn chord_slack(radiance: f32, sigma: f32, albedo: f32, g: f32, s: f32) -> f32 {
    let max_phase = henyey_greenstein(g, 1.0).max(henyey_greenstein(g, -1.0));
    radiance * sigma * albedo * max_phase * 2.0 * 1e-5 * s
}

/// Bounded medium with light extinction: GPU brute force against the CPU reference, with the
/// tolerances (and their reasons) of `brute_force_matches_cpu_reference`, plus [`chord_slack`]
/// for where the box cuts the ray.
#[test]
fn bounded_medium_with_light_extinction_matches_cpu_reference() {
    let gpu = require_gpu!();
    let steps = 64;
    let r = run_scene(
        &gpu,
        &[("name", en("tree"))],
        256,
        (64, 36),
        &bounded(&[("steps", ParamValue::Int(steps)), ("jitter", p(0.5))]),
    );
    let params = ScatterParams::new(&r.camera, &r.light, &medium(steps as u32, 0.5))
        .with_bounds(tree_box(), true);
    let (w, h) = (r.depth.width, r.depth.height);
    let slack = |c: usize, depth: f32| match c {
        // e^{−σt L}: L moves by up to 2e-5 s (see chord_slack).
        3 => 0.08 * 2e-5 * depth,
        c => chord_slack(r.light.radiance[c], 0.08, 0.9, 0.5, depth),
    };
    let (differing, transmittance) = compare_brute_force(&r, &params, steps, slack);
    let misses: Vec<usize> = (0..transmittance.len())
        .filter(|i| transmittance[*i] == 1.0)
        .collect();
    // Where the view ray misses the box nothing scatters.
    for i in &misses {
        assert!(r.inscatter.data[i * 4..i * 4 + 3].iter().all(|c| *c == 0.0));
    }
    let (outside, inside) = (misses.len(), transmittance.len() - misses.len());
    assert!(
        differing * 50 <= (w * h) as usize,
        "{differing} pixels differ"
    );
    assert!(
        outside > 0 && inside > 0,
        "the box should cover part of the view"
    );
}

/// MinMax integrates its lit stretches exactly; 8192 brute-force steps approach the same value
/// (each light/shadow transition misjudges at most half a step's weight).
#[test]
fn bounded_min_max_matches_dense_cpu_reference() {
    let gpu = require_gpu!();
    let r = run_scene(
        &gpu,
        &[("name", en("tree"))],
        256,
        (48, 27),
        &bounded(&[("method", en("MinMax"))]),
    );
    let params =
        ScatterParams::new(&r.camera, &r.light, &medium(8192, 0.0)).with_bounds(tree_box(), true);
    let (w, h) = (r.depth.width, r.depth.height);
    let peak = r.inscatter.data.iter().cloned().fold(0.0f32, f32::max);
    assert!(peak > 0.0);
    let mut sum = 0.0;
    for y in 0..h {
        for x in 0..w {
            let (_, ins, _) =
                reference_pixel(&params, &r.shadow, r.depth.pixel(x, y)[0], x, y, w, h);
            for (g, want) in r.inscatter.pixel(x, y).iter().zip(ins) {
                let d = (g - want).abs() / peak;
                assert!(d <= 0.005, "({x},{y}): MinMax {g} vs 8192 steps {want}");
                sum += d;
            }
        }
    }
    assert!(
        sum / (3 * w * h) as f32 <= 5e-4,
        "mean error {}",
        sum / (3 * w * h) as f32
    );
    assert_finite(&r, "bounded MinMax");
}

/// An independent check of the bounded integral: no shadow reaches the box (the torus scene,
/// a box beside the torus), so V = 1 and the in-scatter is E σt ρ f ∫ e^{−σt (t − t0)} e^{−σt ℓ(t)}
/// dt, which the test computes itself in f64 — in closed form for a sun straight overhead
/// (ℓ = top − y(t), linear), and by 20 000-point Simpson quadrature with ℓ found by a ray–box
/// exit for a slanted sun (ℓ switches faces along the ray). Both methods must agree to 2e-4
/// relative (f32 sums of up to 128 exponentials, each within a few ulp).
#[test]
fn box_medium_matches_the_analytic_integral() {
    let gpu = require_gpu!();
    let (lo, hi) = (Vec3::new(5.0, 0.5, -2.0), Vec3::new(9.0, 4.0, 2.0));
    let eye = Vec3::new(7.0, 2.0, 9.0);
    let (sigma, albedo, g) = (0.3f64, 0.9f64, 0.4f32);
    for (elevation, azimuth) in [(90.0, 0.0), (50.0, 100.0)] {
        let scene = vec![
            ("name", en("torus")),
            ("camera", en("custom")),
            ("cam_x", p(eye.x as f64)),
            ("cam_y", p(eye.y as f64)),
            ("cam_z", p(eye.z as f64)),
            ("target_x", p(7.0)),
            ("target_y", p(2.3)),
            ("target_z", p(0.0)),
            ("fov", p(30.0)),
            ("light", en("custom")),
            ("sun_elevation", p(elevation)),
            ("sun_azimuth", p(azimuth)),
        ];
        for method in ["MinMax", "BruteForce"] {
            let r = run_scene(
                &gpu,
                &scene,
                512,
                (20, 12),
                &[
                    ("bounds", en("box")),
                    ("box_min", v3([5.0, 0.5, -2.0])),
                    ("box_max", v3([9.0, 4.0, 2.0])),
                    ("light_extinction", en("on")),
                    ("sigma_t", p(sigma)),
                    ("albedo", p(albedo)),
                    ("g", p(g as f64)),
                    ("method", en(method)),
                ],
            );
            let to_sun = r.light.backward().as_dvec3();
            let inv = r.camera.view_proj().inverse();
            let (w, h) = (r.vis.width, r.vis.height);
            let mut checked = 0;
            for y in 0..h {
                for x in 0..w {
                    let ndc = glam::Vec4::new(
                        (x as f32 + 0.5) / w as f32 * 2.0 - 1.0,
                        1.0 - (y as f32 + 0.5) / h as f32 * 2.0,
                        1.0,
                        1.0,
                    );
                    let far = inv * ndc;
                    let dir = (far.truncate() / far.w - r.camera.eye()).normalize();
                    let s = r.depth.pixel(x, y)[0] as f64;
                    let (e, d) = (r.camera.eye().as_dvec3(), dir.as_dvec3());
                    let Some((t0, t1)) = slab(e, d, lo.as_dvec3(), hi.as_dvec3(), s) else {
                        assert_eq!(r.inscatter.pixel(x, y)[0], 0.0, "({x},{y}) misses the box");
                        continue;
                    };
                    let ell = |t: f64| {
                        let q = e + d * t;
                        slab(q, to_sun, lo.as_dvec3(), hi.as_dvec3(), f64::INFINITY)
                            .map_or(0.0, |(_, out)| out)
                    };
                    let f = |t: f64| (-sigma * ((t - t0) + ell(t))).exp();
                    let integral = if elevation == 90.0 {
                        // ℓ(t) = hi.y − (e.y + d.y t): the exponent is linear in t.
                        let m = sigma * (1.0 - d.y);
                        f(t0) * (1.0 - (-m * (t1 - t0)).exp()) / m
                    } else {
                        simpson(f, t0, t1, 20_000)
                    };
                    let phase = henyey_greenstein(g, dir.dot(r.light.backward())) as f64;
                    for c in 0..3 {
                        let want = r.light.radiance[c] as f64 * sigma * albedo * phase * integral;
                        let got = r.inscatter.pixel(x, y)[c] as f64;
                        let slack = chord_slack(
                            r.light.radiance[c],
                            sigma as f32,
                            albedo as f32,
                            g,
                            s as f32,
                        );
                        assert!(
                            (got - want).abs() <= 2e-4 * want.abs() + slack as f64,
                            "{method} sun {elevation}°: ({x},{y}) channel {c}: {got} vs {want}"
                        );
                    }
                    assert!(r.vis.pixel(x, y)[0] == 1.0, "a shadow reached the box");
                    checked += 1;
                }
            }
            assert!(
                checked > (w * h) as usize / 4,
                "{checked} pixels cross the box"
            );
        }
    }
}

/// The part of [0, s] of the ray e + d·t inside the box, in f64 (None: it misses).
fn slab(
    e: glam::DVec3,
    d: glam::DVec3,
    lo: glam::DVec3,
    hi: glam::DVec3,
    s: f64,
) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, s);
    for k in 0..3 {
        if d[k].abs() < 1e-12 {
            if e[k] < lo[k] || e[k] > hi[k] {
                return None;
            }
        } else {
            let (a, b) = ((lo[k] - e[k]) / d[k], (hi[k] - e[k]) / d[k]);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
        }
    }
    (t1 > t0).then_some((t0, t1))
}

fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let hstep = (b - a) / n as f64;
    let mut sum = f(a) + f(b);
    for i in 1..n {
        sum += f(a + i as f64 * hstep) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * hstep / 3.0
}

/// σt at 0 and 1e4 with bounds and light extinction on; the camera outside the box, inside it
/// and on its boundary; a box of zero volume; rays parallel to box faces (a camera looking
/// straight along −z, odd image size): everything finite, V̄ in [0, 1], and MinMax close to
/// 2048 brute-force steps (the bound of `extremes_stay_finite_and_methods_agree`).
#[test]
fn bounded_extremes_stay_finite() {
    let gpu = require_gpu!();
    let cam = |pos: [f64; 3], target: [f64; 3]| -> Params {
        vec![
            ("name", en("tree")),
            ("camera", en("custom")),
            ("cam_x", p(pos[0])),
            ("cam_y", p(pos[1])),
            ("cam_z", p(pos[2])),
            ("target_x", p(target[0])),
            ("target_y", p(target[1])),
            ("target_z", p(target[2])),
        ]
    };
    let outside = cam([9.0, 2.2, 9.5], [0.0, 3.5, 0.0]);
    let inside = cam([1.0, 3.0, 1.0], [-2.0, 4.0, -2.0]);
    let on_face = cam([3.0, 3.0, 0.0], [-2.0, 4.0, 0.5]);
    let axis = cam([0.0, 3.0, 9.0], [0.0, 3.0, 0.0]);
    let flat = vec![("box_max", v3([3.0, 0.0, 3.0]))]; // zero volume: y from 0 to 0
    let cases: Vec<(&str, Params, Params)> = vec![
        (
            "sigma_t = 0",
            outside.clone(),
            bounded(&[("sigma_t", p(0.0))]),
        ),
        (
            "sigma_t = 1e4",
            outside.clone(),
            bounded(&[("sigma_t", p(1e4))]),
        ),
        ("camera inside", inside, bounded(&[])),
        ("camera on a face", on_face, bounded(&[])),
        ("rays along the z faces", axis, bounded(&[])),
        ("zero-volume box", outside.clone(), bounded(&flat)),
        (
            "extinction off",
            outside,
            bounded(&[("light_extinction", en("off"))]),
        ),
    ];
    for (what, scene, extra) in cases {
        let mut brute = extra.clone();
        brute.push(("steps", ParamValue::Int(2048)));
        let mut fast = extra.clone();
        fast.push(("method", en("MinMax")));
        let a = run_scene(&gpu, &scene, 512, (25, 15), &brute);
        let b = run_scene(&gpu, &scene, 512, (25, 15), &fast);
        assert_finite(&a, what);
        assert_finite(&b, what);
        let d = common::max_abs_diff(&a.vis, &b.vis);
        assert!(
            d <= 16.0 / (2.0 * 2048.0),
            "{what}: MinMax differs from 2048 steps by {d}"
        );
        let peak = a
            .inscatter
            .data
            .iter()
            .cloned()
            .fold(0.0f32, f32::max)
            .max(1e-30);
        let di = common::max_abs_diff(&a.inscatter, &b.inscatter) / peak;
        assert!(di <= 0.01, "{what}: in-scatter differs by {di} of its peak");
        match what {
            "sigma_t = 0" | "zero-volume box" => {
                assert!(a.transmittance.data.iter().all(|v| *v == 1.0), "{what}");
                assert!(
                    a.inscatter.data.chunks(4).all(|c| c[..3] == [0.0; 3]),
                    "{what}: nothing may scatter"
                );
            }
            "camera inside" => assert!(a.transmittance.data.iter().all(|v| *v < 1.0)),
            _ => {}
        }
    }
}

/// Light extinction needs bounds; `tagged` needs a scene with a `medium` object.
#[test]
fn bounded_medium_errors_name_the_parameter() {
    let gpu = require_gpu!();
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let text = |scatter: &str| {
        format!(
            "(version: 2, nodes: {{\"scene\": (kind: \"Scene\"), \"shadow\": (kind: \"ShadowMap\", params: {{\"resolution\": 64}}), \"gbuffer\": (kind: \"GBuffer\"), \"scatter\": (kind: \"SingleScattering\", params: {{{scatter}}})}}, edges: [(\"scene.scene\", \"shadow.scene\"), (\"scene.scene\", \"gbuffer.scene\"), (\"shadow.map\", \"scatter.shadow\"), (\"gbuffer.depth\", \"scatter.depth\"), (\"scene.scene\", \"scatter.scene\")])"
        )
    };
    for (params, words) in [
        (
            "\"light_extinction\": \"on\"",
            &["scatter", "light_extinction", "bounds"][..],
        ),
        (
            "\"bounds\": \"tagged\"",
            &["scatter", "scene", "medium"][..],
        ),
        (
            "\"bounds\": \"box\", \"box_min\": [0, 0, 0], \"box_max\": [1, -1, 1]",
            &["scatter", "box_max"][..],
        ),
    ] {
        let g = tyndall::graph::load_str(&text(params), std::path::Path::new("e.ron"), &cat)
            .expect("graph");
        let mut ev = Evaluator::new(registry.clone(), gpu.clone());
        let err = ev
            .evaluate(
                &g,
                &[Target::Port("scatter".into(), "inscatter".into())],
                &EvalOptions {
                    size: (8, 8),
                    ..Default::default()
                },
            )
            .expect_err(params)
            .to_string();
        for w in words {
            assert!(err.contains(w), "{params}: '{w}' missing from: {err}");
        }
    }
}

/// A glTF object tagged `medium` is not drawn; its bounds are the scene's medium, and
/// `bounds = tagged` renders exactly what `bounds = box` with those corners renders.
#[test]
fn tagged_medium_from_gltf_equals_the_same_box() {
    let gpu = require_gpu!();
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/medium_scene.gltf");
    let scene = tyndall::scene::load_gltf(&path).expect("load");
    assert_eq!(scene.objects.len(), 3, "the medium box is not drawn");
    assert!(scene
        .objects
        .iter()
        .all(|o| !o.tags.iter().any(|t| t == "medium")));
    assert_eq!(
        scene.medium,
        Some((Vec3::new(-4.0, 0.0, -1.0), Vec3::new(4.0, 4.0, 5.0)))
    );
    assert_eq!(
        scene.find_sun("").expect("sun").intensity,
        3.0,
        "2049 lux = 3 W/m²"
    );
    let gltf = [("path", ParamValue::Text(path.display().to_string()))];
    let common = [("light_extinction", en("on")), ("method", en("MinMax"))];
    let mut tagged = vec![("bounds", en("tagged"))];
    tagged.extend(common.iter().cloned());
    let mut boxed = vec![
        ("bounds", en("box")),
        ("box_min", v3([-4.0, 0.0, -1.0])),
        ("box_max", v3([4.0, 4.0, 5.0])),
    ];
    boxed.extend(common.iter().cloned());
    let a = run_scene(&gpu, &gltf, 256, (32, 18), &tagged);
    let b = run_scene(&gpu, &gltf, 256, (32, 18), &boxed);
    assert_eq!(a.inscatter, b.inscatter);
    assert_eq!(a.transmittance, b.transmittance);
    assert!(a.inscatter.data.iter().any(|v| *v > 0.0));
}

// ---- Method Epipolar ---------------------------------------------------------------------

fn int(v: i64) -> ParamValue {
    ParamValue::Int(v)
}

/// SingleScattering parameters of method Epipolar with these knobs.
fn epipolar(k: EpiKnobs) -> Params {
    vec![
        ("method", en("Epipolar")),
        ("epi_slices", int(k.slices as i64)),
        ("epi_samples", int(k.samples as i64)),
        ("epi_threshold", p(k.threshold as f64)),
        ("tree_level", int(k.tree_level as i64)),
    ]
}

fn rmse(a: &Raster, b: &Raster) -> f64 {
    let sq: f64 = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum();
    (sq / a.data.len() as f64).sqrt()
}

/// The tree scene seen by a custom camera at the scene camera's position, looking along `look`
/// (e.g. towards the sun: the epipole at the image centre).
fn tree_looking(look: impl Fn(Vec3) -> Vec3) -> Params {
    let gpu = tyndall::gpu::Gpu::shared().expect("gpu");
    let r = run_scene(&gpu, &[("name", en("tree"))], 64, (8, 8), &[]);
    let eye = r.camera.eye();
    let target = eye + look(r.light.backward()) * 10.0;
    vec![
        ("name", en("tree")),
        ("camera", en("custom")),
        ("cam_x", p(eye.x as f64)),
        ("cam_y", p(eye.y as f64)),
        ("cam_z", p(eye.z as f64)),
        ("target_x", p(target.x as f64)),
        ("target_y", p(target.y as f64)),
        ("target_z", p(target.z as f64)),
    ]
}

/// The GPU's Epipolar V̄ equals its CPU reference (`epipolar_reference`: the same slices,
/// trees, samples, interpolation and fall-back, in Rust) with the epipole off screen (the tree's
/// camera), on screen (looking at the sun) and behind the camera, exact and with estimated tree
/// levels. A pixel may flip between interpolation and fall-back where a depth difference lies
/// within rounding of the threshold, so up to 1 % of pixels may differ by more than 1e-3.
#[test]
fn epipolar_matches_its_cpu_reference() {
    let gpu = require_gpu!();
    let cases: [(&str, Params, u32); 4] = [
        ("scene camera", vec![("name", en("tree"))], 0),
        ("towards the sun", tree_looking(|s| s), 0),
        ("away from the sun", tree_looking(|s| -s), 0),
        ("estimated tree levels", vec![("name", en("tree"))], 3),
    ];
    for (what, scene, tree_level) in cases {
        let knobs = EpiKnobs {
            slices: 48,
            samples: 24,
            threshold: 0.02,
            tree_level,
        };
        let r = run_scene(&gpu, &scene, 256, (64, 36), &epipolar(knobs));
        let params = ScatterParams::new(&r.camera, &r.light, &medium(1, 0.0));
        let cpu = epipolar_reference(&params, &r.shadow, &r.depth, knobs);
        let diffs: Vec<f32> = r
            .vis
            .data
            .iter()
            .zip(&cpu)
            .map(|(a, b)| (a - b).abs())
            .collect();
        let off = diffs.iter().filter(|d| **d > 1e-3).count();
        let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
        assert!(
            off * 100 <= diffs.len(),
            "{what}: {off} of {} pixels differ by more than 1e-3",
            diffs.len()
        );
        assert!(mean <= 2e-4, "{what}: mean difference {mean}");
        assert_finite(&r, what);
    }
}

/// At its finest setting Epipolar converges to the brute-force limit: RMSE ≤ 1e-3 against 4096
/// steps (the issue's bound; 4096 steps is itself within ~3e-4 of the limit on this map).
#[test]
fn epipolar_finest_setting_converges_to_brute_force() {
    let gpu = require_gpu!();
    let scene = [("name", en("tree"))];
    let size = (96, 54);
    let reference = run_scene(
        &gpu,
        &scene,
        1024,
        size,
        &[("method", en("BruteForce")), ("steps", int(4096))],
    );
    let finest = EpiKnobs {
        slices: 2048,
        samples: 1024,
        threshold: 0.005,
        tree_level: 0,
    };
    let coarse = EpiKnobs {
        slices: 16,
        samples: 8,
        threshold: 1.0,
        tree_level: 6,
    };
    let fine = rmse(
        &run_scene(&gpu, &scene, 1024, size, &epipolar(finest)).vis,
        &reference.vis,
    );
    let rough = rmse(
        &run_scene(&gpu, &scene, 1024, size, &epipolar(coarse)).vis,
        &reference.vis,
    );
    assert!(fine <= 1e-3, "finest setting: RMSE {fine}");
    assert!(
        rough > fine,
        "the knobs trade accuracy: coarse {rough} vs finest {fine}"
    );
}

/// Epipolar with a bounded medium and light extinction, and on a manipulated (closed) map,
/// agrees with MinMax (exact) on the same inputs. On the closed map V̄ is within the bench's
/// target (RMSE 0.005). In the box the in-scatter is (RMSE ≤ 0.5 % of its peak; measured 0.2 %);
/// V̄ itself is allowed 0.02 (measured 0.013): rays grazing the box's top face have short
/// stretches in the medium whose average visibility changes faster across pixels than depth or
/// medium length tell, and carry little in-scatter.
#[test]
fn epipolar_works_with_bounded_media_and_manipulated_maps() {
    let gpu = require_gpu!();
    let knobs = EpiKnobs {
        slices: 256,
        samples: 128,
        threshold: 0.02,
        tree_level: 0,
    };
    let (lo, hi) = tree_box().expect("box");
    let bounds = vec![
        ("bounds", en("box")),
        ("box_min", v3([lo.x as f64, lo.y as f64, lo.z as f64])),
        ("box_max", v3([hi.x as f64, hi.y as f64, hi.z as f64])),
        ("light_extinction", en("on")),
        ("sigma_t", p(0.3)),
    ];
    let scene = [("name", en("tree"))];
    let mut epi = epipolar(knobs);
    epi.extend(bounds.clone());
    let mut exact = vec![("method", en("MinMax"))];
    exact.extend(bounds);
    let a = run_scene(&gpu, &scene, 512, (128, 72), &epi);
    let b = run_scene(&gpu, &scene, 512, (128, 72), &exact);
    let vis = rmse(&a.vis, &b.vis);
    let peak = b.inscatter.data.iter().cloned().fold(0.0f32, f32::max) as f64;
    let ins = rmse(&a.inscatter, &b.inscatter) / peak;
    assert!(vis <= 0.02, "bounded V̄ RMSE {vis}");
    assert!(ins <= 0.005, "bounded in-scatter RMSE / peak {ins}");
    assert_finite(&a, "bounded");

    // A closed map: shadow → Closure2D → both methods.
    let graph = |method: &str| {
        format!(
            r#"(
    version: 2,
    nodes: {{
        "scene": (kind: "Scene", params: {{"name": "tree"}}),
        "shadow": (kind: "ShadowMap", params: {{"resolution": 512}}),
        "close": (kind: "Closure2D", params: {{"radius": 6.0}}),
        "gbuffer": (kind: "GBuffer"),
        "scatter": (kind: "SingleScattering", params: {{"method": "{method}", "epi_slices": 256, "epi_samples": 128}}),
    }},
    edges: [
        ("scene.scene", "shadow.scene"),
        ("scene.scene", "gbuffer.scene"),
        ("shadow.map", "close.map"),
        ("close.map", "scatter.shadow"),
        ("gbuffer.depth", "scatter.depth"),
    ],
)"#
        )
    };
    let run = |method: &str| {
        common::eval_ron(
            &gpu,
            &graph(method),
            &[("scatter", "visibility")],
            (128, 72),
        )
        .read("scatter", "visibility")
    };
    let closed = rmse(&run("Epipolar"), &run("MinMax"));
    assert!(closed <= 0.005, "closed map V̄ RMSE {closed}");
}

/// Stability: the sun on the view axis (epipole at the image centre, exactly on a pixel centre
/// for an odd size and on a pixel corner for an even one), behind the camera, at right angles to
/// the view axis (epipole at infinity), far off screen, a one-pixel-wide, one-pixel-high and
/// one-pixel image: every output finite, V̄ in [0, 1], and V̄ close to MinMax (RMSE ≤ 0.02 at
/// these tiny sizes, where a few slices span the whole image). Empty and fully occluded maps:
/// `empty_map_is_fully_lit_and_full_map_fully_shadowed_exactly`.
#[test]
fn epipolar_stability_at_the_epipole_extremes() {
    let gpu = require_gpu!();
    let knobs = EpiKnobs {
        slices: 64,
        samples: 32,
        threshold: 0.02,
        tree_level: 0,
    };
    let towards = tree_looking(|s| s);
    let away = tree_looking(|s| -s);
    // The sun in the image plane (epipole at infinity: slices parallel) and 63° off the view
    // axis (epipole far off screen).
    let across = |s: Vec3| s.cross(Vec3::Y).normalize();
    let right_angle = tree_looking(across);
    let far_off = tree_looking(|s| (s + 2.0 * across(s)).normalize());
    let cases: [(&str, &Params, (u32, u32)); 8] = [
        ("epipole on a pixel centre", &towards, (33, 19)),
        ("epipole on a pixel corner", &towards, (32, 18)),
        ("sun behind the camera", &away, (33, 19)),
        (
            "sun at right angles to the view axis",
            &right_angle,
            (48, 27),
        ),
        ("sun far off screen", &far_off, (48, 27)),
        ("one pixel wide", &towards, (1, 24)),
        ("one pixel high", &away, (24, 1)),
        ("one pixel", &towards, (1, 1)),
    ];
    for (what, scene, size) in cases {
        let a = run_scene(&gpu, scene, 256, size, &epipolar(knobs));
        assert_finite(&a, what);
        assert!(
            a.vis.data.iter().all(|v| (0.0..=1.0).contains(v)),
            "{what}: V̄ outside [0, 1]"
        );
        let b = run_scene(&gpu, scene, 256, size, &[("method", en("MinMax"))]);
        let e = rmse(&a.vis, &b.vis);
        assert!(e <= 0.02, "{what}: RMSE against MinMax {e}");
    }
}

/// Epipolar's fall-back pass is sized on the GPU (an indirect dispatch from the list's length):
/// the node reads nothing back (it read the 4-byte count before).
#[test]
fn epipolar_reads_nothing_back() {
    let gpu = require_gpu!();
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/tree.ron");
    let mut g = tyndall::graph::load_file(&path, &cat).expect("graph");
    g.set_param(
        &cat,
        "scatter",
        "method",
        ParamValue::Enum("Epipolar".into()),
    )
    .expect("method");
    let mut ev = Evaluator::new(registry, gpu.clone());
    let before = gpu.thread_readbacks();
    let r = ev
        .evaluate(
            &g,
            &[Target::Port("scatter".into(), "visibility".into())],
            &EvalOptions {
                size: (96, 54),
                ..Default::default()
            },
        )
        .expect("evaluate");
    assert_eq!(r.stats.status("scatter"), Some(tyndall::eval::Status::Ran));
    let after = gpu.thread_readbacks();
    assert_eq!(after.1 - before.1, 0, "{} read-backs", after.0 - before.0);
}
