//! Light maps: `SingleScattering` with a `LightMap`, and `LightMapSolve` recovering a known map,
//! agreeing with its CPU reference, never increasing its residual, and staying finite on
//! degenerate input.

use crate::common;
use std::sync::Arc;

use glam::Vec3;
use tyndall::eval::{Matrices, PortValue, SHADOW_CLEAR};
use tyndall::graph::ParamValue;
use tyndall::io::Raster;
use tyndall::nodes::light_map_solve::{self as lms, Sampling, Settings, ViewProblem};
use tyndall::scene::{fit_light, Camera};

/// An orthographic sun fitted to a 10 m box around the origin.
fn light() -> Matrices {
    let (view, proj) = fit_light(
        Vec3::new(0.3, 1.0, 0.2),
        (Vec3::new(-5.0, -1.0, -5.0), Vec3::new(5.0, 3.0, 5.0)),
    );
    Matrices {
        view: view.to_cols_array_2d(),
        proj: proj.to_cols_array_2d(),
        far: 1.0,
        radiance: [1.0; 3],
        local: None,
    }
}

fn camera(position: Vec3, w: u32, h: u32) -> Matrices {
    let c = Camera {
        position,
        target: Vec3::new(0.0, 0.5, 0.0),
        fov_y: 50.0,
        near: 0.1,
        far: 40.0,
    };
    Matrices::of_camera(&c, w, h)
}

/// A shadow map with one occluder block (so some rays are partly shadowed).
fn shadow() -> Raster {
    let mut r = Raster::new(16, 16, 1, SHADOW_CLEAR);
    for y in 6..9 {
        for x in 5..8 {
            r.data[y * 16 + x] = 0.2;
        }
    }
    r
}

const VIEWS: [[f32; 3]; 3] = [[0.0, 1.5, 9.0], [8.0, 2.5, 4.0], [-7.0, 1.0, -5.0]];
const SAMPLING: Sampling = Sampling {
    sigma_t: 0.08,
    steps: 48,
    bias: 0.002,
    g: 0.5, // SingleScattering's default, which renders the targets
};

/// A spot 6 m above the origin shining down (cone 50°, map depth 0.5–12 m along its axis).
fn spot() -> Matrices {
    use tyndall::scene::{local_proj, spot_view, LocalLight};
    let (pos, dir) = (Vec3::new(0.0, 6.0, 0.0), Vec3::NEG_Y);
    let half = 50f32.to_radians();
    Matrices {
        view: spot_view(pos, dir).to_cols_array_2d(),
        proj: local_proj(half, 0.5, 12.0).to_cols_array_2d(),
        far: 12.0,
        radiance: [1.0; 3],
        local: Some(LocalLight {
            point: false,
            position: pos.to_array(),
            direction: dir.to_array(),
            cos_inner: 45f32.to_radians().cos(),
            cos_outer: half.cos(),
            range: 0.0,
            near: 0.5,
            far: 12.0,
        }),
    }
}

/// The known light map: smooth, different per channel, within [0.2, 1.6].
fn known_map(n: u32) -> Raster {
    let mut r = Raster::new(n, n, 4, 1.0);
    for y in 0..n {
        for x in 0..n {
            let (u, v) = (x as f32 / n as f32, y as f32 / n as f32);
            let k = ((y * n + x) * 4) as usize;
            r.data[k] = 0.9 + 0.7 * (u * 5.0).sin() * (v * 3.0).cos();
            r.data[k + 1] = 0.6 + 0.4 * v;
            r.data[k + 2] = 1.0 - 0.5 * u;
        }
    }
    r
}

/// Render each view with `SingleScattering` (BruteForce, no jitter) with the known map and with
/// a white one; the desired colour of every pixel is their ratio (so b = T x*).
fn views_from_render(
    gpu: &Arc<tyndall::gpu::Gpu>,
    map: &Raster,
    light: Matrices,
) -> Vec<ViewProblem> {
    let (w, h) = (40, 30);
    let sh = Arc::new(gpu.upload(16, 16, 1, &shadow().data).expect("upload"));
    let map_tex = Arc::new(
        gpu.upload(map.width, map.height, 4, &map.data)
            .expect("map"),
    );
    let white = Arc::new(gpu.upload(1, 1, 4, &[1.0; 4]).expect("white"));
    VIEWS
        .iter()
        .map(|p| {
            let cam = camera(Vec3::from(*p), w, h);
            let depth = Raster::new(w, h, 1, 14.0);
            let d = Arc::new(gpu.upload(w, h, 1, &depth.data).expect("depth"));
            let render = |lm: &Arc<tyndall::gpu::GpuTexture>| {
                common::run_node(
                    gpu,
                    "SingleScattering",
                    &[
                        ("steps", ParamValue::Int(SAMPLING.steps as i64)),
                        ("sigma_t", ParamValue::Float(SAMPLING.sigma_t as f64)),
                    ],
                    vec![
                        ("shadow", PortValue::ShadowMap(sh.clone(), light)),
                        ("depth", PortValue::Depth(d.clone(), cam)),
                        ("light_map", PortValue::LightMap(lm.clone(), light)),
                    ],
                    &["inscatter"],
                    (8, 8),
                )
                .expect("render")
                .remove("inscatter")
                .expect("inscatter")
            };
            let (with, base) = (render(&map_tex), render(&white));
            let mut targets = Raster::new(w, h, 4, 0.0);
            for k in 0..(w * h) as usize {
                for c in 0..3 {
                    let b = base.data[k * 4 + c];
                    targets.data[k * 4 + c] = if b > 0.0 {
                        with.data[k * 4 + c] / b
                    } else {
                        1.0
                    };
                }
                targets.data[k * 4 + 3] = 1.0;
            }
            ViewProblem {
                camera: cam,
                depth,
                targets,
            }
        })
        .collect()
}

/// Texels whose total constraint weight (column sum of T) is at least `frac` of the largest.
fn covered(views: &[ViewProblem], n: u32, frac: f32, light: &Matrices) -> Vec<bool> {
    let mut op = lms::CpuOperator::new(views, &shadow(), light, n, SAMPLING);
    use lms::Operator;
    let rows = op.rows();
    let col = op.adjoint(&vec![[1.0; 3]; rows]).expect("adjoint");
    let top = col.iter().map(|c| c[0]).fold(0.0, f32::max);
    col.iter()
        .map(|c| c[0] > 0.0 && c[0] >= frac * top)
        .collect()
}

/// The GPU solve at [`SAMPLING`], recorded and submitted on its own.
fn solve_gpu(
    gpu: &tyndall::gpu::Gpu,
    views: Vec<ViewProblem>,
    shadow: &tyndall::gpu::GpuTexture,
    light: Matrices,
    n: u32,
    set: Settings,
) -> Result<lms::Solution, tyndall::eval::NodeError> {
    lms::solve_gpu(&gpu.recorder(), views, shadow, light, n, SAMPLING, set)
}

fn settings(iterations: u32) -> Settings {
    Settings {
        iterations,
        tolerance: 1e-9,
        non_negative: true,
        start: 1.0,
    }
}

#[test]
fn light_map_scales_inscatter_per_channel_and_minmax_is_refused() {
    let gpu = require_gpu!();
    let (w, h) = (12, 8);
    let sh = Arc::new(gpu.upload(16, 16, 1, &shadow().data).expect("upload"));
    let d = Arc::new(
        gpu.upload(w, h, 1, &vec![14.0; (w * h) as usize])
            .expect("d"),
    );
    let cam = camera(Vec3::new(0.0, 1.5, 9.0), w, h);
    let run = |c: [f32; 4], method: &str| {
        let lm = Arc::new(gpu.upload(1, 1, 4, &c).expect("lm"));
        common::run_node(
            &gpu,
            "SingleScattering",
            &[("method", ParamValue::Enum(method.into()))],
            vec![
                ("shadow", PortValue::ShadowMap(sh.clone(), light())),
                ("depth", PortValue::Depth(d.clone(), cam)),
                ("light_map", PortValue::LightMap(lm, light())),
            ],
            &["inscatter"],
            (8, 8),
        )
    };
    let white = run([1.0; 4], "BruteForce").expect("white")["inscatter"].clone();
    let tinted = run([0.5, 0.25, 2.0, 1.0], "BruteForce").expect("tinted")["inscatter"].clone();
    assert!(white.data.iter().any(|v| *v > 0.0));
    for k in 0..(w * h) as usize {
        for (c, f) in [0.5f32, 0.25, 2.0].iter().enumerate() {
            let (a, b) = (tinted.data[k * 4 + c], white.data[k * 4 + c] * f);
            assert!((a - b).abs() <= 1e-6 * b.abs().max(1e-3), "{a} vs {b}");
        }
    }
    let e = run([1.0; 4], "MinMax").expect_err("refused").to_string();
    assert!(e.contains("light_map") && e.contains("BruteForce"), "{e}");
}

/// A target rendered by SingleScattering with a known 8×8 map: the GPU solve recovers the map
/// on the texels the constraint rays cover, and never increases its residual.
#[test]
fn solve_recovers_a_known_light_map() {
    let gpu = require_gpu!();
    recover_known_map(&gpu, light(), "sun");
}

/// The same through a spot (issue #44): its light map is a gobo over the cone, and each sample
/// of a constraint ray weighs the spot's falloff and phase (they change along the ray); the
/// CPU operator agrees with the GPU's rows.
#[test]
fn solve_recovers_a_known_light_map_through_a_spot() {
    let gpu = require_gpu!();
    recover_known_map(&gpu, spot(), "spot");
    let views = views_from_render(&gpu, &known_map(8), spot());
    let sh = gpu.upload(16, 16, 1, &shadow().data).expect("upload");
    let g = solve_gpu(&gpu, views.clone(), &sh, spot(), 8, settings(20)).expect("gpu");
    let c =
        lms::solve_reference(&views, &shadow(), &spot(), 8, SAMPLING, settings(20)).expect("cpu");
    let last = |r: &[f64]| *r.last().expect("residual");
    let (rg, rc) = (last(&g.residuals), last(&c.residuals));
    // The same operator on both sides (f32 on the GPU, fixed-point adjoint): residuals within
    // 1 % of the start after 20 iterations.
    assert!(
        (rg - rc).abs() <= 0.01 * c.residuals[0],
        "GPU residual {rg} vs CPU {rc} (start {})",
        c.residuals[0]
    );
}

/// Render three views with the known map through `light`, solve, and hold the covered texels
/// to 1 % (the issue's bound) with a residual that never rises.
fn recover_known_map(gpu: &Arc<tyndall::gpu::Gpu>, light: Matrices, what: &str) {
    let n = 8;
    let truth = known_map(n);
    let views = views_from_render(gpu, &truth, light);
    let sh = gpu.upload(16, 16, 1, &shadow().data).expect("upload");
    let sol = solve_gpu(gpu, views.clone(), &sh, light, n, settings(300)).expect("solve");
    for w in sol.residuals.windows(2) {
        // Rounding only: the fixed-point adjoint and f32 sums (relative 1e-6 of the start).
        assert!(
            w[1] <= w[0] + 1e-6 * sol.residuals[0],
            "{what}: residual rose: {:?}",
            w
        );
    }
    let cov = covered(&views, n, 0.2, &light);
    let mut worst = 0.0f32;
    for (i, c) in cov.iter().enumerate() {
        if *c {
            for ch in 0..3 {
                let t = truth.data[i * 4 + ch];
                worst = worst.max((sol.x[i][ch] - t).abs() / t);
            }
        }
    }
    let count = cov.iter().filter(|c| **c).count();
    eprintln!("{what}: {count} covered texels, worst relative error {worst:.2e}");
    assert!(count >= 16, "{what}: only {count} covered texels");
    // The issue's bound: 1 % relative error on the covered texels.
    assert!(
        worst <= 0.01,
        "{what}: worst relative error {worst} over {count} texels"
    );
}

/// GPU and CPU solves agree on a small problem.
#[test]
fn gpu_and_cpu_solves_agree() {
    let gpu = require_gpu!();
    let n = 8;
    let views = views_from_render(&gpu, &known_map(n), light());
    let sh = gpu.upload(16, 16, 1, &shadow().data).expect("upload");
    // Five iterations: the iterates are well defined there. This problem (an 8² map seen by
    // three 40×30 views) is solved to f32 precision by then, and further CG steps move in
    // directions the data do not fix, in an order-dependent way: measured, GPU and CPU differ
    // by 6e-7 of the largest value after 5 iterations, 1e-4 after 8, 1.4e-2 after 10 (with or
    // without non-negativity), since #60 made the fixture's clear texels clear.
    let set = settings(5);
    let cpu = lms::solve_reference(&views, &shadow(), &light(), n, SAMPLING, set).expect("cpu");
    let g = solve_gpu(&gpu, views.clone(), &sh, light(), n, set).expect("gpu");
    let top = cpu.x.iter().flatten().fold(0.0f32, |m, v| m.max(v.abs()));
    let d = cpu
        .x
        .iter()
        .flatten()
        .zip(g.x.iter().flatten())
        .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
    // 1e-3 relative: the issue's bound (the passes march in f32 in another order). On larger, underdetermined maps the iterates are sensitive to such differences
    // (24²: 3e-4 without non-negativity after 20 iterations, and the active set of the
    // non-negativity can differ), so the comparison is made where the problem is well posed.
    assert!(
        d <= 1e-3 * top,
        "GPU vs CPU solve: {d} (largest value {top})"
    );
}

/// Texels no constraint ray reaches keep the start value.
#[test]
fn unreached_texels_keep_the_start_value() {
    let gpu = require_gpu!();
    let n = 24;
    // One view, a 4×4-pixel stroke: its rays cross a narrow band of the map.
    let mut views = views_from_render(&gpu, &known_map(n), light());
    views.truncate(1);
    let w = views[0].targets.width as usize;
    for (k, px) in views[0].targets.data.chunks_mut(4).enumerate() {
        let (x, y) = (k % w, k / w);
        px[3] = if (18..22).contains(&x) && (13..17).contains(&y) {
            1.0
        } else {
            0.0
        };
    }
    let sh = gpu.upload(16, 16, 1, &shadow().data).expect("upload");
    let mut set = settings(20);
    set.start = 0.7;
    let g = solve_gpu(&gpu, views.clone(), &sh, light(), n, set).expect("gpu");
    let reached = covered(&views, n, 0.0, &light());
    assert!(
        reached.iter().any(|c| !c),
        "every texel is reached: the check is empty"
    );
    for (i, c) in reached.iter().enumerate() {
        if !c {
            assert_eq!(g.x[i], [0.7; 3], "texel {i} has no ray but moved");
        }
    }
    assert!(g.x.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
}

/// Zero strokes, a single pixel, contradictory strokes and an all-shadowed problem end finite
/// (and non-negative), the residual never rising.
#[test]
fn degenerate_problems_end_finite() {
    let gpu = require_gpu!();
    let n = 8;
    let sh = gpu.upload(16, 16, 1, &shadow().data).expect("upload");
    let none = solve_gpu(&gpu, vec![], &sh, light(), n, settings(10)).expect("none");
    assert!(none.x.iter().all(|v| *v == [1.0; 3]));
    let mut one = views_from_render(&gpu, &known_map(n), light());
    one.truncate(1);
    for (k, px) in one[0].targets.data.chunks_mut(4).enumerate() {
        px[3] = if k == 615 { 1.0 } else { 0.0 };
    }
    let s1 = solve_gpu(&gpu, one.clone(), &sh, light(), n, settings(10)).expect("one");
    assert!(s1.x.iter().flatten().all(|v| v.is_finite()));
    // Contradictory: the second and third views want the opposite red of the first.
    let mut contra = views_from_render(&gpu, &known_map(n), light());
    for v in contra.iter_mut().skip(1) {
        for px in v.targets.data.chunks_mut(4) {
            px[0] = 2.0 - px[0];
        }
    }
    let s3 = solve_gpu(&gpu, contra, &sh, light(), n, settings(40)).expect("contra");
    assert!(s3.x.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    for w in s3.residuals.windows(2) {
        assert!(
            w[1] <= w[0] + 1e-6 * s3.residuals[0],
            "residual rose: {:?}",
            w
        );
    }
    let dark = gpu.upload(16, 16, 1, &[0.0; 256]).expect("dark");
    let s2 = solve_gpu(&gpu, one, &dark, light(), n, settings(10)).expect("dark");
    assert!(s2.x.iter().flatten().all(|v| v.is_finite()));
    assert!(s2.residuals.iter().all(|r| r.is_finite()));
}

/// The node in a graph: a built-in scene, its shadow map, one painted view; the light map feeds
/// SingleScattering.
#[test]
fn node_solves_strokes_in_a_graph() {
    let gpu = require_gpu!();
    let registry = Arc::new(tyndall::nodes::registry());
    let text = r#"(
    version: 2,
    nodes: {
        "scene": (kind: "Scene", params: {"name": "window"}),
        "shadow": (kind: "ShadowMap", params: {"resolution": 256}),
        "gbuffer": (kind: "GBuffer"),
        "solve": (kind: "LightMapSolve", params: {"resolution": 32, "iterations": 8, "steps": 32},
                  data: (views: [(camera: Scene, width: 96, height: 54, strokes: [
                      (colour: (1.0, 0.3, 0.0), width: 10.0, points: [(10.0, 40.0), (40.0, 30.0)]),
                      (colour: (0.0, 0.4, 1.0), width: 6.0, points: [(60.0, 35.0)]),
                  ])])),
        "scatter": (kind: "SingleScattering", params: {"steps": 32}),
    },
    edges: [
        ("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"),
        ("scene.scene", "solve.scene"), ("shadow.map", "solve.shadow"),
        ("shadow.map", "scatter.shadow"), ("gbuffer.depth", "scatter.depth"),
        ("solve.light_map", "scatter.light_map"),
    ],
)"#;
    let g = tyndall::graph::load_str(text, std::path::Path::new("t.ron"), registry.catalog())
        .expect("graph");
    let mut ev = tyndall::eval::Evaluator::new(registry, gpu.clone());
    let targets = [
        tyndall::eval::Target::Port("solve".into(), "residual".into()),
        tyndall::eval::Target::Port("scatter".into(), "inscatter".into()),
    ];
    let opts = tyndall::eval::EvalOptions {
        size: (96, 54),
        ..Default::default()
    };
    let r = ev.evaluate(&g, &targets, &opts).expect("evaluates");
    let res = tyndall::eval::download(
        &gpu.recorder(),
        &r.outputs[&("solve".into(), "residual".into())],
    )
    .expect("residual");
    assert!(res.data.len() >= 2 && res.data.iter().all(|v| v.is_finite()));
    assert!(res.data.last() < res.data.first(), "{:?}", res.data);
    let ins = tyndall::eval::download(
        &gpu.recorder(),
        &r.outputs[&("scatter".into(), "inscatter".into())],
    )
    .expect("inscatter");
    assert!(ins.data.iter().all(|v| v.is_finite()));
}

/// The resident solve (vectors on the GPU) reaches the CPU solve's residual on the same problem,
/// and matches the operator path: the same GPU passes for T and Tᵀ (`GpuOperator`) driven by
/// the CPU-side CG (`cgls::solve`), which reads the views and the sums back every pass.
#[test]
fn resident_solve_reaches_the_cpu_residual() {
    let gpu = require_gpu!();
    let n = 24;
    let views = views_from_render(&gpu, &known_map(n), light());
    let sh = gpu.upload(16, 16, 1, &shadow().data).expect("upload");
    let set = settings(40);
    let cpu = lms::solve_reference(&views, &shadow(), &light(), n, SAMPLING, set).expect("cpu");
    let res = solve_gpu(&gpu, views.clone(), &sh, light(), n, set).expect("gpu");
    let want = lms::desired(&views);
    let rec = gpu.recorder();
    let mut operator =
        lms::GpuOperator::new(&rec, views, &sh, light(), n, SAMPLING).expect("operator");
    let op = lms::solve(&mut operator, &want, set, &mut |_, _| {}).expect("op");
    let last = |s: &lms::Solution| s.residuals[s.residuals.len() - 1];
    let (c, r, o) = (last(&cpu), last(&res), last(&op));
    assert!(
        c < 0.5 * cpu.residuals[0],
        "the CPU solve did not converge: {c}"
    );
    // 1 %: the passes sum in f32 in another order than the CPU's f64, and 40 iterations on an
    // underdetermined 24² map amplify that (see gpu_and_cpu_solves_agree); the goal is the
    // residual reached, not the same iterates.
    assert!(r <= 1.01 * c, "resident residual {r} vs CPU {c}");
    assert!(o <= 1.01 * c, "operator-path residual {o} vs CPU {c}");
    // The same passes: the two GPU drivers' residuals agree step by step (measured within 4e-7
    // relative) until the non-negativity's active sets first differ, which on this fixture
    // happens after iteration 23 (from there the ends differ by a few %, both below the CPU's).
    for (i, (a, b)) in res.residuals.iter().zip(&op.residuals).take(20).enumerate() {
        assert!(
            (a - b).abs() <= 1e-4 * b,
            "iteration {i}: resident residual {a} vs operator path {b}"
        );
    }
}
