//! Hole creation: Perlin noise, hole maps (calibrated fractions), hole compositing.

use crate::common;
use std::sync::Arc;

use tyndall::eval::{Matrices, PortValue};
use tyndall::graph::{ParamValue, PortType};
use tyndall::io::Raster;
use tyndall::nodes::algorithms::quantile;
use tyndall::nodes::{hole_composite, hole_map, perlin_noise2d};

fn noise(gpu: &Arc<tyndall::gpu::Gpu>, params: &[(&str, ParamValue)], size: (u32, u32)) -> Raster {
    common::run_node(gpu, "PerlinNoise2D", params, vec![], &["noise"], size)
        .expect("noise")
        .remove("noise")
        .expect("noise")
}

fn params(freq: f64, octaves: u32, mode: &str) -> perlin_noise2d::NoiseParams {
    perlin_noise2d::NoiseParams {
        scale: (16.0 * freq) as f32,
        persistence: 0.5,
        octaves,
        mode: if mode == "seed" { 0 } else { 1 },
        seed: 3,
        angle: 0.0,
        _pad0: 0,
        _pad1: 0,
    }
}

/// The shader and the CPU reference evaluate the same f32 formulas; the GPU may fuse
/// multiply-adds in the fade and interpolation steps, so values agree within a few ULP of 1.
#[test]
fn perlin_matches_reference_for_both_modes_and_octave_extremes() {
    let gpu = require_gpu!();
    for mode in ["seed", "fbm"] {
        for octaves in [1u32, 8] {
            let got = noise(
                &gpu,
                &[
                    ("mode", ParamValue::Enum(mode.into())),
                    ("octaves", ParamValue::Int(octaves as i64)),
                    ("seed", ParamValue::Int(3)),
                ],
                (47, 33),
            );
            let want = perlin_noise2d::reference(&params(1.0, octaves, mode), 47, 33);
            let d = common::max_abs_diff(&got, &want);
            assert!(d <= 1e-5, "{mode} o={octaves}: {d}");
            assert!(got.data.iter().all(|v| (0.0..=1.0).contains(v)));
            let spread = got.data.iter().cloned().fold(0.0f32, f32::max)
                - got.data.iter().cloned().fold(1.0f32, f32::min);
            assert!(
                spread > 0.2,
                "{mode} o={octaves}: noise too flat ({spread})"
            );
        }
    }
    // Frequency 0: every texel looks the noise up at the origin, a constant map.
    let flat = noise(&gpu, &[("frequency", ParamValue::Float(0.0))], (9, 9));
    assert!(flat.data.iter().all(|v| *v == flat.data[0]));
}

#[test]
fn animation_moves_the_noise_and_time_zero_is_static() {
    let gpu = require_gpu!();
    let base = noise(&gpu, &[], (32, 32));
    let t0 = noise(
        &gpu,
        &[
            ("speed", ParamValue::Float(1.0)),
            ("time", ParamValue::Float(0.0)),
        ],
        (32, 32),
    );
    let t1 = noise(
        &gpu,
        &[
            ("speed", ParamValue::Float(1.0)),
            ("time", ParamValue::Float(0.5)),
        ],
        (32, 32),
    );
    assert_eq!(base, t0);
    assert!(common::max_abs_diff(&base, &t1) > 0.05);
}

fn holes(gpu: &Arc<tyndall::gpu::Gpu>, n: &Raster, h: f64, calibrated: bool) -> Raster {
    common::run_node(
        gpu,
        "HoleMap",
        &[
            ("probability", ParamValue::Float(h)),
            ("calibrated", ParamValue::Bool(calibrated)),
        ],
        vec![("noise", common::upload(gpu, n, PortType::Scalar))],
        &["holes"],
        (1, 1),
    )
    .expect("holes")
    .remove("holes")
    .expect("holes")
}

#[test]
fn calibrated_hole_fraction_is_h() {
    let gpu = require_gpu!();
    let n = noise(&gpu, &[("octaves", ParamValue::Int(4))], (128, 128));
    for k in 1..=9 {
        let h = k as f64 / 10.0;
        let map = holes(&gpu, &n, h, true);
        let fraction =
            map.data.iter().filter(|v| **v == 1.0).count() as f64 / map.data.len() as f64;
        assert!(
            (fraction - h).abs() <= 0.02,
            "h = {h}: hole fraction {fraction}"
        );
        assert_eq!(
            map,
            hole_map::reference(&n, hole_map::calibrated_threshold(&n.data, h))
        );
    }
    // Uncalibrated, h is a plain threshold: Perlin noise clusters around 0.5.
    let raw = holes(&gpu, &n, 0.3, false);
    let fraction = raw.data.iter().filter(|v| **v == 1.0).count() as f64 / raw.data.len() as f64;
    assert!(fraction < 0.25, "uncalibrated fraction {fraction}");
    for calibrated in [true, false] {
        assert!(
            holes(&gpu, &n, 0.0, calibrated)
                .data
                .iter()
                .all(|v| *v == 0.0),
            "h = 0: no holes"
        );
        assert!(
            holes(&gpu, &n, 1.0, calibrated)
                .data
                .iter()
                .all(|v| *v == 1.0),
            "h = 1: all holes"
        );
    }
}

/// The calibrated threshold is selected on the GPU (radix select): on values with negatives,
/// ties, ±0, NaN and ±∞, at odd sizes and every kind of h, the map equals the CPU reference's
/// (sort, k-th finite value) exactly, and evaluating the node reads nothing back.
#[test]
fn calibrated_threshold_is_selected_on_the_gpu_bit_for_bit_without_readback() {
    let gpu = require_gpu!();
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    for (w, h, seed) in [(1, 1, 1), (37, 5, 2), (64, 61, 3), (255, 3, 4)] {
        let mut n = common::random_raster(w, h, 1, -3.0, 3.0, seed);
        for (i, v) in n.data.iter_mut().enumerate() {
            match i % 23 {
                3 => *v = f32::NAN,
                5 => *v = f32::INFINITY,
                7 => *v = f32::NEG_INFINITY,
                11 => *v = 0.0,
                13 => *v = -0.0,
                17 => *v = 1.5, // ties
                _ => {}
            }
        }
        for prob in [1e-9, 0.01, 0.3, 0.5, 0.77, 0.999_999] {
            let mut g = tyndall::graph::Graph::new();
            let id = g.add_node(&cat, "HoleMap").expect("add");
            g.set_param(&cat, &id, "probability", ParamValue::Float(prob))
                .expect("probability");
            let mut opts = tyndall::eval::EvalOptions::default();
            opts.inject.insert(
                (id.clone(), "noise".into()),
                (common::upload(&gpu, &n, PortType::Scalar), 1),
            );
            let target = tyndall::eval::Target::Port(id.clone(), "holes".into());
            let before = gpu.thread_readbacks();
            let r = tyndall::eval::Evaluator::new(registry.clone(), gpu.clone())
                .evaluate(&g, &[target], &opts)
                .expect("evaluate");
            assert_eq!(
                gpu.thread_readbacks(),
                before,
                "{w}x{h} h={prob}: a read-back"
            );
            let out = tyndall::eval::download(&gpu.recorder(), &r.outputs[&(id, "holes".into())])
                .expect("download");
            let want = hole_map::reference(&n, hole_map::calibrated_threshold(&n.data, prob));
            assert_eq!(out, want, "{w}x{h} h={prob}");
            // Both forms of the histograms (the node takes the one for its adapter).
            let p = hole_map::Params::with_overrides(&[("probability", ParamValue::Float(prob))])
                .expect("params");
            let noise = common::upload(&gpu, &n, PortType::Scalar);
            let tex = noise.texture().expect("texture").clone();
            for form in [quantile::Histogram::Shared, quantile::Histogram::Workgroup] {
                let t = hole_map::holes(&gpu.recorder(), &tex, &p, form).expect("holes");
                let got = tyndall::eval::download(&gpu.recorder(), &PortValue::Scalar(Arc::new(t)))
                    .expect("download");
                assert_eq!(got, want, "{w}x{h} h={prob} {form:?}");
            }
        }
    }
}

#[test]
fn hole_composite_matches_reference() {
    let gpu = require_gpu!();
    let object = common::random_raster(19, 11, 1, 0.1, 0.4, 5);
    let rest = common::random_raster(19, 11, 1, 0.2, 1.0, 6);
    let mut h = Raster::new(19, 11, 1, 0.0);
    for (i, v) in h.data.iter_mut().enumerate() {
        *v = (i % 3 == 0) as u8 as f32;
    }
    let m = Matrices::default();
    let out = common::run_node(
        &gpu,
        "HoleComposite",
        &[],
        vec![
            (
                "object",
                PortValue::ShadowMap(Arc::new(gpu.upload(19, 11, 1, &object.data).expect("o")), m),
            ),
            ("holes", common::upload(&gpu, &h, PortType::Scalar)),
            (
                "rest",
                PortValue::ShadowMap(Arc::new(gpu.upload(19, 11, 1, &rest.data).expect("r")), m),
            ),
        ],
        &["map"],
        (1, 1),
    )
    .expect("composite");
    assert_eq!(out["map"], hole_composite::reference(&object, &h, &rest));
}

/// Holes per light (issue #44, item 4): the tree's foliage (tag `foliage`) and the rest drawn
/// into a spot's map each, Perlin holes punched in the foliage's: the composite is the spot's
/// map (it carries the lamp), equal to its CPU reference, with light through the holes — the
/// first occluder lies deeper (the trunk or the ground behind the leaves) where a hole is
/// punched, and nowhere nearer than in the full map; maps of two different lights are refused.
#[test]
fn hole_composite_works_in_a_spots_map_and_refuses_two_lights() {
    let gpu = require_gpu!();
    let spot = r#""name": "tree", "light": "custom", "light_type": "spot", "light_x": 2.0,
        "light_y": 6.5, "light_z": 1.5, "light_target_x": 0.0, "light_target_y": 1.0,
        "light_target_z": 0.0, "cone_inner": 18.0, "cone_outer": 30.0"#;
    let graph = |rest_light: &str| {
        format!(
            r#"(version: 3, nodes: {{
            "scene": (kind: "Scene", params: {{{spot}}}),
            "sun_scene": (kind: "Scene", params: {{"name": "tree"}}),
            "all": (kind: "ShadowMap", params: {{"resolution": 256}}),
            "object": (kind: "ShadowMap", params: {{"resolution": 256, "include": "foliage"}}),
            "rest": (kind: "ShadowMap", params: {{"resolution": 256, "exclude": "foliage"}}),
            "noise": (kind: "PerlinNoise2D", params: {{"width": 256, "height": 256, "frequency": 24.0}}),
            "holes": (kind: "HoleMap", params: {{"probability": 0.4}}),
            "comp": (kind: "HoleComposite"),
        }}, edges: [
            ("scene.scene", "all.scene"), ("scene.scene", "object.scene"),
            ("{rest_light}.scene", "rest.scene"),
            ("noise.noise", "holes.noise"), ("object.map", "comp.object"),
            ("holes.holes", "comp.holes"), ("rest.map", "comp.rest"),
        ])"#
        )
    };
    let ports = [
        ("all", "map"),
        ("object", "map"),
        ("rest", "map"),
        ("holes", "holes"),
        ("comp", "map"),
    ];
    let out = common::eval_ron(&gpu, &graph("scene"), &ports, (32, 18));
    match out.get("comp", "map") {
        PortValue::ShadowMap(_, m) => assert!(
            m.local.is_some_and(|l| !l.point),
            "the composite carries the spot"
        ),
        other => panic!("comp.map: {other:?}"),
    }
    let (object, holes, rest, all) = (
        out.read("object", "map"),
        out.read("holes", "holes"),
        out.read("rest", "map"),
        out.read("all", "map"),
    );
    let comp = out.read("comp", "map");
    assert_eq!(comp, hole_composite::reference(&object, &holes, &rest));
    // The full map is the minimum of the two parts (drawn the same way), so exactly.
    let deeper = comp
        .data
        .iter()
        .zip(&all.data)
        .inspect(|(c, a)| assert!(**c >= **a, "a hole made an occluder nearer: {c} < {a}"))
        .filter(|(c, a)| **c > **a)
        .count();
    assert!(
        deeper > 100,
        "holes should let light through the foliage: only {deeper} texels deeper"
    );
    // The rest drawn for the sun instead: refused, naming the port.
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let g = tyndall::graph::load_str(
        &graph("sun_scene"),
        std::path::Path::new("g.ron"),
        registry.catalog(),
    )
    .expect("graph");
    let e = tyndall::eval::Evaluator::new(registry, gpu.clone())
        .evaluate(
            &g,
            &[tyndall::eval::Target::Port("comp".into(), "map".into())],
            &tyndall::eval::EvalOptions {
                size: (32, 18),
                ..Default::default()
            },
        )
        .expect_err("two lights' maps")
        .to_string();
    assert!(e.contains("object") && e.contains("another light"), "{e}");
}
