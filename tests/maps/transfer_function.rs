//! TransferFunction: the lookup against the layer formulas (on EXR inputs written by OpenEXR),
//! blend modes, diffusion layers (uniform, monotone, GPU = CPU, converged to the exact harmonic
//! solution), key-frames, the `lut` port, depth ranges and stability at the extremes.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::Command;

use tyndall::eval::{Matrices, PortValue};
use tyndall::graph::{ParamValue, PortType};
use tyndall::io::{read_image, Raster};
use tyndall::nodes::transfer_function::{
    self as tf, blend, Blend, Constraint, Layer, LayerEntry, TfData,
};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/tf")
        .join(name)
}

fn scalar(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> Raster {
    let mut r = Raster::new(w, h, 1, 0.0);
    for y in 0..h {
        for x in 0..w {
            r.data[(y * w + x) as usize] = f(x, y);
        }
    }
    r
}

fn c(at: [f32; 2], colour: [f32; 4]) -> Constraint {
    Constraint {
        at,
        colour,
        anchor: None,
    }
}

/// The CLI on the OpenEXR-written fixtures equals the float64 layer formulas.
#[test]
fn lookup_on_exr_inputs_equals_the_layer_formulas() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("O.exr");
    let status = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(["node", "TransferFunction", "--data"])
        .arg(fixture("linear.ron"))
        .args(["--param", "depth_min=2", "--param", "depth_max=50"])
        .args(["--param", "intensity=2"])
        .arg(format!("--input=visibility={}", fixture("V.exr").display()))
        .arg(format!("--input=depth={}", fixture("D.exr").display()))
        .arg(format!("--output=image={}", out.display()))
        .output()
        .expect("run tyndall");
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let got = read_image(&out, false).expect("output");
    let want = read_image(&fixture("expected.exr"), false).expect("expected");
    // 1e-4: the issue's bound where the formulas are linear in (u, v); the stack's last layer
    // is quadratic (alpha varies along its gradient), whose bilinear lookup errs by ~h²/8 ≈ 2e-6
    // at N = 256, and f32 rounding adds ~1e-6.
    let d = common::max_abs_diff(&got, &want);
    assert!(d <= 1e-4, "max |got − formula| = {d}");
}

#[test]
fn blend_modes_follow_their_formulas() {
    let dst = [0.2, 0.4, 0.6, 0.5];
    let src = [0.5, 0.25, 1.0, 0.5];
    let a = 0.8 * 0.5;
    let alpha = blend(dst, src, Blend::Alpha, 0.8);
    let mul = blend(dst, src, Blend::Multiply, 0.8);
    let add = blend(dst, src, Blend::Add, 0.8);
    for ch in 0..3 {
        assert!((alpha[ch] - (dst[ch] * (1.0 - a) + src[ch] * a)).abs() < 1e-7);
        assert!((mul[ch] - (dst[ch] * (1.0 - a) + dst[ch] * src[ch] * a)).abs() < 1e-7);
        assert!((add[ch] - (dst[ch] + src[ch] * a)).abs() < 1e-7);
    }
    for out in [alpha, mul, add] {
        assert!(
            (out[3] - (0.5 * (1.0 - a) + a)).abs() < 1e-7,
            "alpha composites as Alpha"
        );
    }
}

/// The GPU bake equals the CPU reference for every layer kind and blend mode.
#[test]
fn gpu_bake_matches_the_reference() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("tf.png");
    let mut img = Raster::new(5, 3, 4, 1.0);
    for (i, v) in img.data.iter_mut().enumerate() {
        if i % 4 != 3 {
            *v = (i % 7) as f32 / 6.0;
        }
    }
    tyndall::io::write_image(&png, &img, tyndall::io::Precision::U8, true).expect("png");
    let data = format!(
        "(layers: [
            (layer: Solid(colour: (0.1, 0.2, 0.3, 1.0))),
            (layer: Gradient(from: (0.2, 0.1), to: (0.7, 0.9), from_colour: (1.0, 0.0, 0.5, 0.5),
                             to_colour: (0.0, 1.0, 0.5, 1.0)), blend: Multiply, opacity: 0.7),
            (layer: Diffusion(constraints: [(at: (0.1, 0.1), colour: (1.0, 0.0, 0.0, 1.0)),
                                            (at: (0.9, 0.3), colour: (0.0, 0.0, 1.0, 0.5)),
                                            (at: (0.4, 0.8), colour: (0.0, 1.0, 0.0, 0.8))]),
             blend: Alpha, opacity: 0.9),
            (layer: Image(path: {:?}), blend: Add, opacity: 0.5),
        ])",
        png.display().to_string()
    );
    let n = 37; // odd: the multigrid's rounding-up coarsening is exercised
    let out = common::run_node_with(
        &gpu,
        "TransferFunction",
        &[("resolution", ParamValue::Int(n as i64))],
        Some(&data),
        0.0,
        vec![],
        &["lut"],
        (8, 8),
    )
    .expect("bake");
    let parsed: TfData = tyndall::graph::NodeData::from_text(&data)
        .expect("ron")
        .parse()
        .expect("TfData");
    let image = tyndall::io::read_image(&png, true)
        .expect("image")
        .into_rgba();
    let images = vec![None, None, None, Some(image)];
    let want = tf::bake_reference(&parsed.layers, n, 8, &images);
    // 1e-4: the GPU and the CPU run the same V-cycles in f32 with sums in a different order.
    let d = common::max_abs_diff(&out["lut"], &want);
    assert!(d <= 1e-4, "GPU bake vs CPU reference: {d}");
}

#[test]
fn one_diffusion_constraint_gives_a_uniform_layer() {
    let gpu = require_gpu!();
    let col = [0.8, 0.3, 0.1, 1.0];
    let lut = tf::diffuse_gpu(&gpu.recorder(), &[c([0.3, 0.7], col)], 64, 6).expect("solve");
    let r = tyndall::eval::download(&gpu.recorder(), &PortValue::Lut2D(std::sync::Arc::new(lut)))
        .expect("download");
    for px in r.data.chunks(4) {
        for ch in 0..4 {
            assert!((px[ch] - col[ch]).abs() <= 1e-4, "{px:?}");
        }
    }
}

/// Exact solution of the discrete problem by conjugate gradients (f64, to 1e-12).
fn harmonic_exact(cs: &[Constraint], n: u32, ch: usize) -> Vec<f64> {
    let (mask, values, _) = tf::rasterise_constraints(cs, n);
    let n = n as usize;
    let free = |k: usize| mask[k] < 0.5;
    let apply = |u: &[f64]| -> Vec<f64> {
        // A u on free texels (graph Laplacian), identity elsewhere.
        let mut out = vec![0.0; n * n];
        for y in 0..n {
            for x in 0..n {
                let k = y * n + x;
                if !free(k) {
                    out[k] = u[k];
                    continue;
                }
                let mut s = 0.0;
                let mut c = 0.0;
                for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                    let (qx, qy) = (x as i64 + dx, y as i64 + dy);
                    if qx >= 0 && qy >= 0 && (qx as usize) < n && (qy as usize) < n {
                        let q = qy as usize * n + qx as usize;
                        c += 1.0;
                        if free(q) {
                            s += u[q];
                        }
                    }
                }
                out[k] = c * u[k] - s;
            }
        }
        out
    };
    // b: fixed values moved to the right-hand side.
    let mut b = vec![0.0; n * n];
    for y in 0..n {
        for x in 0..n {
            let k = y * n + x;
            if !free(k) {
                b[k] = values[k][ch] as f64;
                continue;
            }
            for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                let (qx, qy) = (x as i64 + dx, y as i64 + dy);
                if qx >= 0 && qy >= 0 && (qx as usize) < n && (qy as usize) < n {
                    let q = qy as usize * n + qx as usize;
                    if !free(q) {
                        b[k] += values[q][ch] as f64;
                    }
                }
            }
        }
    }
    let mut x = vec![0.0; n * n];
    let mut r = b.clone();
    let mut p = r.clone();
    let mut rr: f64 = r.iter().map(|v| v * v).sum();
    for _ in 0..20 * n * n {
        if rr.sqrt() < 1e-12 {
            break;
        }
        let ap = apply(&p);
        let alpha = rr / p.iter().zip(&ap).map(|(a, b)| a * b).sum::<f64>();
        for i in 0..n * n {
            x[i] += alpha * p[i];
            r[i] -= alpha * ap[i];
        }
        let new: f64 = r.iter().map(|v| v * v).sum();
        for i in 0..n * n {
            p[i] = r[i] + new / rr * p[i];
        }
        rr = new;
    }
    x
}

/// The default eight V-cycles are within 2e-4 of the exact discrete harmonic solution, and the
/// GPU solve equals the CPU one.
#[test]
fn diffusion_converges_and_gpu_equals_cpu() {
    let gpu = require_gpu!();
    let cs = [
        c([0.1, 0.15], [1.0, 0.0, 0.2, 1.0]),
        c([0.85, 0.3], [0.0, 0.5, 1.0, 1.0]),
        c([0.45, 0.9], [0.3, 1.0, 0.0, 0.6]),
    ];
    let n = 64;
    let cpu = tf::diffuse_reference(&cs, n, 8);
    for ch in 0..4 {
        let exact = harmonic_exact(&cs, n, ch);
        let err = exact
            .iter()
            .enumerate()
            .map(|(k, e)| (cpu.data[k * 4 + ch] as f64 - e).abs())
            .fold(0.0, f64::max);
        // The stated tolerance of the solver (docs of nodes/transfer_function.rs).
        assert!(
            err <= 2e-4,
            "channel {ch}: max error {err} against the exact solution"
        );
    }
    let g = tf::diffuse_gpu(&gpu.recorder(), &cs, n, 8).expect("solve");
    let g = tyndall::eval::download(&gpu.recorder(), &PortValue::Lut2D(std::sync::Arc::new(g)))
        .expect("download");
    // 1e-4: same V-cycles, f32, sums in a different order.
    let d = common::max_abs_diff(&g, &cpu);
    assert!(d <= 1e-4, "GPU vs CPU diffusion: {d}");
}

/// Two constraints: the layer is a gradient, monotone along their segment, with their colours
/// at their texels.
#[test]
fn two_diffusion_constraints_give_a_monotone_gradient() {
    let (a, b) = ([0.2, 0.3], [0.8, 0.6]);
    let n = 128;
    let r = tf::diffuse_reference(&[c(a, [0.0; 4]), c(b, [1.0, 0.5, 0.25, 1.0])], n, 8);
    let mut last = -1.0f32;
    for s in 0..=200 {
        let t = s as f32 / 200.0;
        let p = [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t];
        let v = tf::bilinear(&r, p[0], p[1])[0];
        assert!(
            v >= last - 1e-5,
            "not monotone at t = {t}: {v} after {last}"
        );
        last = v;
    }
    // At the constrained texels' centres the layer takes the constraints' colours.
    let centre = |p: [f32; 2]| p.map(|x| ((x * n as f32).floor() + 0.5) / n as f32);
    let at = |p: [f32; 2]| tf::bilinear(&r, centre(p)[0], centre(p)[1]);
    assert_eq!(at(a), [0.0; 4]);
    assert_eq!(at(b), [1.0, 0.5, 0.25, 1.0]);
}

/// Key-frames interpolate every number linearly; mismatched stacks are refused by name.
#[test]
fn keyframes_interpolate_and_mismatches_are_refused() {
    let data = TfData {
        layers: vec![],
        keys: vec![
            tf::TfKey {
                t: 10.0,
                layers: vec![LayerEntry {
                    layer: Layer::Solid {
                        colour: [0.0, 0.0, 1.0, 1.0],
                    },
                    blend: Blend::Alpha,
                    opacity: 0.0,
                }],
            },
            tf::TfKey {
                t: 0.0,
                layers: vec![LayerEntry {
                    layer: Layer::Solid {
                        colour: [1.0, 0.0, 0.0, 1.0],
                    },
                    blend: Blend::Alpha,
                    opacity: 1.0,
                }],
            },
        ],
    };
    let mid = data.stack_at(2.5).expect("interpolates");
    assert_eq!(
        mid[0].layer,
        Layer::Solid {
            colour: [0.75, 0.0, 0.25, 1.0]
        }
    );
    assert!((mid[0].opacity - 0.75).abs() < 1e-6);
    assert_eq!(data.stack_at(-5.0).expect("before")[0].opacity, 1.0);
    assert_eq!(data.stack_at(50.0).expect("after")[0].opacity, 0.0);
    let mut bad = data.clone();
    bad.keys[0].layers[0].layer = Layer::Image {
        path: "x.png".into(),
    };
    let e = bad.stack_at(5.0).expect_err("kinds differ");
    assert!(e.contains("layer 0") && e.contains("Image"), "{e}");
}

/// On the GPU, the time picks the interpolated stack (and is part of the cache key).
#[test]
fn keyed_tf_follows_the_time() {
    let gpu = require_gpu!();
    let data = "(keys: [(t: 0.0, layers: [(layer: Solid(colour: (1.0, 0.0, 0.0, 1.0)))]),
                        (t: 4.0, layers: [(layer: Solid(colour: (0.0, 0.0, 1.0, 1.0)))])])";
    for (t, want) in [
        (0.0, [1.0, 0.0, 0.0]),
        (1.0, [0.75, 0.0, 0.25]),
        (9.0, [0.0, 0.0, 1.0]),
    ] {
        let out = common::run_node_with(
            &gpu,
            "TransferFunction",
            &[("resolution", ParamValue::Int(4))],
            Some(data),
            t,
            vec![],
            &["lut"],
            (8, 8),
        )
        .expect("bake");
        for px in out["lut"].data.chunks(4) {
            for ch in 0..3 {
                assert!((px[ch] - want[ch]).abs() < 1e-6, "t = {t}: {px:?}");
            }
        }
    }
}

/// Modulate with a grey TF scales the in-scatter; a baked `lut` fed to a second node gives the
/// same image as the node that baked it.
#[test]
fn modulate_scales_inscatter_and_lut_port_reuses_the_table() {
    let gpu = require_gpu!();
    let (w, h) = (9, 7);
    let vis = common::random_raster(w, h, 1, 0.0, 1.0, 3);
    let depth = common::random_raster(w, h, 1, 0.0, 30.0, 4);
    let ins = common::random_raster(w, h, 4, 0.0, 5.0, 5);
    let grey = "(layers: [(layer: Solid(colour: (0.5, 0.5, 0.5, 1.0)))])";
    let inputs = || {
        vec![
            ("visibility", common::upload(&gpu, &vis, PortType::Scalar)),
            ("depth", common::upload(&gpu, &depth, PortType::Depth)),
            ("inscatter", common::upload(&gpu, &ins, PortType::Image)),
        ]
    };
    let out = common::run_node_with(
        &gpu,
        "TransferFunction",
        &[("mode", ParamValue::Enum("Modulate".into()))],
        Some(grey),
        0.0,
        inputs(),
        &["image", "lut"],
        (8, 8),
    )
    .expect("modulate");
    for k in 0..(w * h) as usize {
        for ch in 0..3 {
            let want = 0.5 * ins.data[k * 4 + ch];
            assert!((out["image"].data[k * 4 + ch] - want).abs() <= 1e-6 * want.max(1.0));
        }
    }
    let mut with_lut = inputs();
    with_lut.push(("lut", common::upload(&gpu, &out["lut"], PortType::Lut2D)));
    let again = common::run_node_with(
        &gpu,
        "TransferFunction",
        &[("mode", ParamValue::Enum("Modulate".into()))],
        None,
        0.0,
        with_lut,
        &["image"],
        (8, 8),
    )
    .expect("lut input");
    assert_eq!(again["image"].data, out["image"].data);
}

/// Auto depth range: a scene ten times larger (every depth × 10) gives the same image.
#[test]
fn auto_depth_range_transfers_between_scene_sizes() {
    let gpu = require_gpu!();
    let (w, h) = (16, 12);
    let vis = common::random_raster(w, h, 1, 0.0, 1.0, 7);
    let depth = scalar(w, h, |x, y| 1.0 + x as f32 * 0.7 + y as f32 * 0.3);
    let data = "(layers: [(layer: Gradient(from: (0.0, 0.0), to: (0.0, 1.0),
                 from_colour: (1.0, 0.2, 0.0, 1.0), to_colour: (0.0, 0.2, 1.0, 1.0)))])";
    let run = |scale: f32| {
        let mut d = depth.clone();
        d.data.iter_mut().for_each(|v| *v *= scale);
        common::run_node_with(
            &gpu,
            "TransferFunction",
            &[("depth_range", ParamValue::Enum("auto".into()))],
            Some(data),
            0.0,
            vec![
                ("visibility", common::upload(&gpu, &vis, PortType::Scalar)),
                ("depth", common::upload(&gpu, &d, PortType::Depth)),
            ],
            &["image"],
            (8, 8),
        )
        .expect("auto")
        .remove("image")
        .expect("image")
    };
    let (a, b) = (run(1.0), run(10.0));
    // 1e-5: (10d − 10p1)/(10p99 − 10p1) equals (d − p1)/(p99 − p1) up to f32 rounding.
    assert!(common::max_abs_diff(&a, &b) <= 1e-5);
    let (lo, hi) = tf::auto_range(&depth.data, &Matrices::default());
    assert!(lo > 1.0 && hi < 1.0 + 15.0 * 0.7 + 11.0 * 0.3, "{lo} {hi}");
    let mut m = Matrices::default();
    m.view[3][0] = 1.0; // a camera's matrices: values at or beyond `far` are sky
    m.far = 5.0;
    let (lo, hi) = tf::auto_range(&depth.data, &m);
    assert!(lo >= 1.0 && hi < 5.0, "{lo} {hi}");
    assert_eq!(tf::auto_range(&[f32::INFINITY], &m), (0.0, 1.0));
}

/// Finite output at the extremes: empty stack, depth_min = depth_max, V̄ exactly 0 and 1, sky
/// (infinite and huge depths), a resolution of 2, every blend at opacity 0 and 1.
#[test]
fn extremes_stay_finite() {
    let gpu = require_gpu!();
    let (w, h) = (6, 4);
    let vis = scalar(w, h, |x, _| if x % 2 == 0 { 0.0 } else { 1.0 });
    let depth = scalar(w, h, |x, y| match (x + y) % 3 {
        0 => f32::INFINITY,
        1 => 1e30,
        _ => 0.0,
    });
    let stacks = [
        "(layers: [])",
        "(layers: [(layer: Diffusion(constraints: []))])",
        "(layers: [(layer: Solid(colour: (1e6, 0.0, 1.0, 1.0)), blend: Add, opacity: 0.0),
                   (layer: Gradient(from: (0.5, 0.5), to: (0.5, 0.5), from_colour: (1.0, 1.0, 1.0, 1.0),
                                    to_colour: (0.0, 0.0, 0.0, 0.0)), blend: Multiply, opacity: 1.0),
                   (layer: Diffusion(constraints: [(at: (0.0, 0.0), colour: (1.0, 0.0, 0.0, 1.0)),
                                                   (at: (0.0, 0.0), colour: (0.0, 1.0, 0.0, 1.0)),
                                                   (at: (1.0, 1.0), colour: (0.0, 0.0, 1.0, 0.0))]))])",
    ];
    for data in stacks {
        for (res, lo, hi) in [(2, 5.0, 5.0), (256, 0.0, 1e7)] {
            let out = common::run_node_with(
                &gpu,
                "TransferFunction",
                &[
                    ("resolution", ParamValue::Int(res)),
                    ("depth_min", ParamValue::Float(lo)),
                    ("depth_max", ParamValue::Float(hi)),
                ],
                Some(data),
                0.0,
                vec![
                    ("visibility", common::upload(&gpu, &vis, PortType::Scalar)),
                    ("depth", common::upload(&gpu, &depth, PortType::Depth)),
                ],
                &["image", "lut"],
                (8, 8),
            )
            .expect("extreme");
            for (port, r) in &out {
                assert!(
                    r.data.iter().all(|v| v.is_finite()),
                    "{data} at N = {res}: non-finite {port}"
                );
            }
        }
    }
}

/// Bad data blocks and missing inputs are errors naming the node and what is wrong.
#[test]
fn errors_name_the_node_and_the_problem() {
    let gpu = require_gpu!();
    let cases = [
        ("(layers: [(layer: Sold(colour: (1.0, 0.0, 0.0, 1.0)))])", "data block"),
        ("(layers: [(layer: Solid(colour: (1.0, 0.0, 0.0, 1.0)), opacity: 2.0)])", "opacity"),
        (
            "(layers: [(layer: Diffusion(constraints: [(at: (0.5, 0.5), colour: (1.0, 1.0, 1.0, 1.0),
               anchor: Some((object: \"wall\", triangle: 3, bary: (0.2, 0.3, 0.5))))]))])",
            "anchored",
        ),
        ("(layers: [(layer: Image(path: \"/nonexistent/tf.png\"))])", "/nonexistent/tf.png"),
    ];
    for (data, needle) in cases {
        let e = common::run_node_with(
            &gpu,
            "TransferFunction",
            &[],
            Some(data),
            0.0,
            vec![],
            &["lut"],
            (8, 8),
        )
        .expect_err("refused")
        .to_string();
        assert!(e.contains("TransferFunction") && e.contains(needle), "{e}");
    }
    let e = common::run_node_with(
        &gpu,
        "TransferFunction",
        &[],
        None,
        0.0,
        vec![],
        &["image"],
        (8, 8),
    )
    .expect_err("no inputs")
    .to_string();
    assert!(e.contains("visibility"), "{e}");
}

fn tree_graph(data: &str, cam: Option<[f64; 3]>) -> String {
    let camera = match cam {
        Some([x, y, z]) => format!(
            r#", "camera": "custom", "cam_x": {x:.1}, "cam_y": {y:.1}, "cam_z": {z:.1}, "target_y": 3.5"#
        ),
        None => String::new(),
    };
    format!(
        r#"(
    version: 2,
    nodes: {{
        "scene": (kind: "Scene", params: {{"name": "tree"{camera}}}),
        "shadow": (kind: "ShadowMap", params: {{"resolution": 512}}),
        "gbuffer": (kind: "GBuffer"),
        "scatter": (kind: "SingleScattering", params: {{"steps": 32}}),
        "tf": (kind: "TransferFunction", params: {{"resolution": 64, "depth_range": "auto"}}, data: {data}),
    }},
    edges: [
        ("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"),
        ("shadow.map", "scatter.shadow"), ("gbuffer.depth", "scatter.depth"),
        ("scatter.visibility", "tf.visibility"), ("scatter.depth", "tf.depth"),
        ("scene.scene", "tf.scene"),
    ],
)"#
    )
}

fn load(text: &str) -> tyndall::graph::Graph {
    let registry = tyndall::nodes::registry();
    tyndall::graph::load_str(text, Path::new("t.ron"), registry.catalog()).expect("graph")
}

/// `pick` reads the pixel's V̄ and depth from the graph, its TF coordinates, and the surface
/// point the camera ray hits (at the pixel's depth); an anchored constraint lands where that
/// point is seen, and follows it when the camera moves.
#[test]
fn pick_and_anchored_constraints_follow_the_surface() {
    let gpu = require_gpu!();
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let mut ev = tyndall::eval::Evaluator::new(registry, gpu.clone());
    let opts = tyndall::eval::EvalOptions {
        size: (160, 90),
        ..Default::default()
    };
    let plain = load(&tree_graph("(layers: [])", None));
    let p = tyndall::eval::pick::pick(&mut ev, &plain, None, (80, 33), &opts).expect("pick");
    let s = p.surface.clone().expect("the canopy is under this pixel");
    let tfp = p.tf.clone().expect("tf coordinates");
    // The surface point lies at the pixel's depth along its ray: the G-buffer's depth is the
    // rasterised distance to the same triangle (1 % covers the pixel-centre vs fragment offset).
    let eye = glam::Vec3::new(9.0, 2.2, 9.5);
    let dist = (glam::Vec3::from(s.position) - eye).length();
    assert!(
        (dist - p.depth).abs() <= 0.01 * p.depth,
        "{dist} vs {}",
        p.depth
    );
    assert!((tfp.u - p.visibility).abs() < 1e-6);
    let (lo, hi) = (tfp.depth_min, tfp.depth_max);
    assert!((tfp.v - tf::depth_coordinate(p.depth, lo, hi)).abs() < 1e-6);

    let data = format!(
        "(layers: [(layer: Diffusion(constraints: [
            (at: (0.0, 0.0), colour: (0.0, 0.0, 1.0, 1.0)),
            (at: (0.05, 0.95), colour: (1.0, 0.0, 0.0, 1.0),
             anchor: Some((object: {:?}, triangle: {}, bary: ({}, {}, {})))),
        ]))])",
        s.object, s.triangle, s.bary[0], s.bary[1], s.bary[2]
    );
    let red_at = |lut: &Raster, at: [f32; 2]| {
        let cell = |x: f32| ((x * 64.0).floor() as usize).min(63);
        let k = (cell(at[1]) * 64 + cell(at[0])) * 4;
        lut.data[k..k + 4].to_vec()
    };
    let lut_of = |ev: &mut tyndall::eval::Evaluator, g: &tyndall::graph::Graph| {
        let r = ev
            .evaluate(
                g,
                &[tyndall::eval::Target::Port("tf".into(), "lut".into())],
                &opts,
            )
            .expect("bake");
        tyndall::eval::download(&gpu.recorder(), &r.outputs[&("tf".into(), "lut".into())])
            .expect("lut")
    };
    let lut = lut_of(&mut ev, &load(&tree_graph(&data, None)));
    assert_eq!(red_at(&lut, [tfp.u, tfp.v]), vec![1.0, 0.0, 0.0, 1.0]);
    // Another camera: the same surface point, seen elsewhere in the frame and in TF space.
    let moved = load(&tree_graph(&data, Some([6.0, 3.0, 11.0])));
    let lut2 = lut_of(&mut ev, &moved);
    let r = ev
        .evaluate(
            &moved,
            &[
                tyndall::eval::Target::Port("scatter".into(), "visibility".into()),
                tyndall::eval::Target::Port("scatter".into(), "depth".into()),
            ],
            &opts,
        )
        .expect("frame");
    let depth_value = &r.outputs[&("scatter".into(), "depth".into())];
    let PortValue::Depth(_, cam) = depth_value else {
        panic!("depth");
    };
    let vis = tyndall::eval::download(
        &gpu.recorder(),
        &r.outputs[&("scatter".into(), "visibility".into())],
    )
    .expect("vis");
    let depth = tyndall::eval::download(&gpu.recorder(), depth_value).expect("depth");
    let range = tf::auto_range(&depth.data, cam);
    let at = tf::anchor_tf_position(glam::Vec3::from(s.position), cam, &vis, &depth, range)
        .expect("still visible from the second camera");
    assert_eq!(red_at(&lut2, at), vec![1.0, 0.0, 0.0, 1.0]);
    assert_ne!(
        red_at(&lut2, [tfp.u, tfp.v]),
        vec![1.0, 0.0, 0.0, 1.0],
        "the constraint did not move with the camera (choose another pixel or camera)"
    );
}

/// `depth_range = auto` on the GPU (the percentiles selected there, only the selections read
/// back) equals the CPU reference bit for bit: a camera's depth (sky at the far distance, NaN
/// and ∞ texels left out), a file's depth (every finite value counts), and a map where nothing
/// qualifies (the default range).
#[test]
fn auto_depth_range_is_selected_on_the_gpu_as_the_reference() {
    let gpu = require_gpu!();
    use tyndall::nodes::transfer_function::{auto_range, auto_range_gpu};
    let camera = tyndall::scene::Camera {
        position: glam::Vec3::new(0.0, 1.0, 5.0),
        target: glam::Vec3::ZERO,
        fov_y: 45.0,
        near: 0.1,
        far: 40.0,
    };
    let cam = Matrices::of_camera(&camera, 53, 31);
    let mut depth = common::random_raster(53, 31, 1, 0.5, 60.0, 11);
    for (i, d) in depth.data.iter_mut().enumerate() {
        match i % 17 {
            3 => *d = 40.0, // sky: the far distance
            5 => *d = f32::NAN,
            7 => *d = f32::INFINITY,
            11 => *d = 7.25, // ties
            _ => {}
        }
    }
    let tex = common::upload(&gpu, &depth, PortType::Scalar);
    let tex = tex.texture().expect("texture");
    for m in [cam, Matrices::default()] {
        let want = auto_range(&depth.data, &m);
        let got = auto_range_gpu(&gpu.recorder(), tex, &m).expect("auto range");
        assert_eq!(
            (got.0.to_bits(), got.1.to_bits()),
            (want.0.to_bits(), want.1.to_bits()),
            "{got:?} vs {want:?}"
        );
        assert!(want.0 < want.1);
    }
    // Nearest rank of the percentile: 60 depths 1…60 m give ranks round(0.01·59) = 1 and
    // round(0.99·59) = 58, i.e. 2 m and 59 m (a floor of q·n would give 1 m).
    let ramp = Raster {
        width: 12,
        height: 5,
        channels: 1,
        data: (1..=60).rev().map(|i| i as f32).collect(),
    };
    assert_eq!(auto_range(&ramp.data, &Matrices::default()), (2.0, 59.0));
    let ramp_tex = common::upload(&gpu, &ramp, PortType::Scalar);
    let got = auto_range_gpu(
        &gpu.recorder(),
        ramp_tex.texture().expect("texture"),
        &Matrices::default(),
    )
    .expect("ramp");
    assert_eq!(got, (2.0, 59.0));
    let sky = Raster::new(9, 4, 1, 40.0);
    let sky_tex = common::upload(&gpu, &sky, PortType::Scalar);
    let got =
        auto_range_gpu(&gpu.recorder(), sky_tex.texture().expect("texture"), &cam).expect("sky");
    assert_eq!(got, (0.0, 1.0), "no surface: the default range");
}

/// `depth_range = auto` in the node reads nothing back: the lookup reads the percentiles the
/// quantile passes selected on the GPU, and its picture equals the same node with the range
/// set by hand to the CPU reference's percentiles of that frame's depth, bit for bit
/// (`graphs/color/sunrise.ron`, whose TF is automatic).
#[test]
fn the_automatic_depth_range_is_read_by_the_lookup_not_by_the_cpu() {
    let gpu = require_gpu!();
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/color/sunrise.ron");
    let mut g = tyndall::graph::load_file(&path, &cat).expect("graph");
    let mut ev = tyndall::eval::Evaluator::new(registry, gpu.clone());
    let opts = tyndall::eval::EvalOptions {
        size: (64, 36),
        ..Default::default()
    };
    let image = tyndall::eval::Target::Port("sunrise".into(), "image".into());
    let depth = tyndall::eval::Target::Port("scatter".into(), "depth".into());
    // The upstream nodes first: what the TF's own run reads back is what is counted.
    let r = ev
        .evaluate(&g, std::slice::from_ref(&depth), &opts)
        .expect("upstream");
    let PortValue::Depth(_, cam) = &r.outputs[&("scatter".into(), "depth".into())] else {
        panic!("depth");
    };
    let cam = *cam;
    let depth_map = tyndall::eval::download(
        &gpu.recorder(),
        &r.outputs[&("scatter".into(), "depth".into())],
    )
    .expect("depth");
    let before = gpu.thread_readbacks().1;
    let r = ev
        .evaluate(&g, std::slice::from_ref(&image), &opts)
        .expect("auto");
    assert_eq!(
        r.stats.status("sunrise"),
        Some(tyndall::eval::Status::Ran),
        "{}",
        r.stats
    );
    assert_eq!(gpu.thread_readbacks().1 - before, 0, "the TF read back");
    let auto = tyndall::eval::download(
        &gpu.recorder(),
        &r.outputs[&("sunrise".into(), "image".into())],
    )
    .expect("image");
    let (lo, hi) = tyndall::nodes::transfer_function::auto_range(&depth_map.data, &cam);
    assert!(lo < hi, "{lo} … {hi}: a frame with surfaces");
    for (name, v) in [
        ("depth_range", ParamValue::Enum("manual".into())),
        ("depth_min", ParamValue::Float(lo as f64)),
        ("depth_max", ParamValue::Float(hi as f64)),
    ] {
        g.set_param(&cat, "sunrise", name, v).expect(name);
    }
    let r = ev.evaluate(&g, &[image], &opts).expect("manual");
    let manual = tyndall::eval::download(
        &gpu.recorder(),
        &r.outputs[&("sunrise".into(), "image".into())],
    )
    .expect("image");
    assert_eq!(auto.data, manual.data);
}

/// A transfer function on a lamp's shafts (issue #44, item 4): the tree lit by a custom spot
/// (MinMax, its exact V̄) and a point light, recoloured by a gradient along V̄ (black at 0,
/// white at 1, Replace): every pixel's output is its own V̄ — bilinear between the 256 table
/// texels reproduces a linear ramp exactly except within half a texel of the ends (clamped:
/// 1/512) — so the table is indexed by the lamp's V̄ as by the sun's.
#[test]
fn a_transfer_function_reads_a_lamps_visibility() {
    let gpu = require_gpu!();
    for kind in ["spot", "point"] {
        let text = format!(
            r#"(version: 3, nodes: {{
            "scene": (kind: "Scene", params: {{"name": "tree", "light": "custom",
                "light_type": "{kind}", "light_x": 2.0, "light_y": 6.5, "light_z": 1.5,
                "light_target_x": 0.0, "light_target_y": 1.0, "light_target_z": 0.0,
                "cone_inner": 18.0, "cone_outer": 30.0, "light_intensity": 400.0}}),
            "shadow": (kind: "ShadowMap", params: {{"resolution": 256}}),
            "gbuffer": (kind: "GBuffer"),
            "scatter": (kind: "SingleScattering", params: {{"method": "MinMax", "steps": 32}}),
            "tf": (kind: "TransferFunction", params: {{"mode": "Replace"}}, data: (layers: [
                (layer: Gradient(from: (0.0, 0.0), to: (1.0, 0.0),
                                 from_colour: (0.0, 0.0, 0.0, 1.0), to_colour: (1.0, 1.0, 1.0, 1.0))),
            ])),
        }}, edges: [
            ("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"),
            ("shadow.map", "scatter.shadow"), ("gbuffer.depth", "scatter.depth"),
            ("scatter.visibility", "tf.visibility"), ("gbuffer.depth", "tf.depth"),
        ])"#
        );
        let out = common::eval_ron(
            &gpu,
            &text,
            &[("scatter", "visibility"), ("tf", "image")],
            (48, 27),
        );
        let (v, img) = (out.read("scatter", "visibility"), out.read("tf", "image"));
        let lo = v.data.iter().cloned().fold(1.0f32, f32::min);
        let hi = v.data.iter().cloned().fold(0.0f32, f32::max);
        assert!(
            hi - lo > 0.2,
            "{kind}: V̄ should vary over the picture ({lo}…{hi})"
        );
        let worst = v
            .data
            .iter()
            .enumerate()
            .map(|(i, x)| (img.data[i * 4] - x).abs())
            .fold(0.0f32, f32::max);
        assert!(
            worst <= 1.0 / 512.0 + 1e-5,
            "{kind}: TF(V̄) differs from V̄ by {worst}"
        );
    }
}
