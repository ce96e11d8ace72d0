//! `SoftVisibility` (seed 004): GPU against the CPU reference for every kernel, the hard result
//! at zero light variance, the penumbra behind a straight edge (half-shadow line of eq. 10,
//! variance growing by σ_κ² per slice so the width is exact at d1), `SingleScattering` reading
//! the volume, and the extremes.

use crate::common;
use std::sync::Arc;

use tyndall::eval::{EvalOptions, Evaluator, Matrices, PortValue, Target};
use tyndall::graph::{Graph, ParamValue};
use tyndall::io::Raster;
use tyndall::nodes::soft_visibility::{self as sv, Kernel, KernelSpec};

/// An orthographic light over a 20 m × 20 m × 20 m box (light depth 0…1 over 20 m).
fn light() -> Matrices {
    let proj = glam::camera::rh::proj::directx::orthographic(-10.0, 10.0, -10.0, 10.0, 0.0, 20.0);
    Matrices {
        view: glam::Mat4::IDENTITY.to_cols_array_2d(),
        proj: proj.to_cols_array_2d(),
        far: 20.0,
        radiance: [1.0; 3],
        local: None,
    }
}

/// Run the node on `map` with `params`: the volume (x, y, slice order).
fn run(
    gpu: &Arc<tyndall::gpu::Gpu>,
    map: &Raster,
    params: &[(&str, ParamValue)],
) -> Result<Vec<f32>, String> {
    run_with(gpu, map, params, light())
}

/// [`run`] with the map's light matrices given.
pub(super) fn run_with(
    gpu: &Arc<tyndall::gpu::Gpu>,
    map: &Raster,
    params: &[(&str, ParamValue)],
    light: Matrices,
) -> Result<Vec<f32>, String> {
    run_carried(gpu, map, params, light).map(|(v, _)| v)
}

/// [`run_with`], and the light matrices the volume carries (a lamp's `near`: where its slices
/// start).
pub(super) fn run_carried(
    gpu: &Arc<tyndall::gpu::Gpu>,
    map: &Raster,
    params: &[(&str, ParamValue)],
    light: Matrices,
) -> Result<(Vec<f32>, Matrices), String> {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let id = g.add_node(&cat, "SoftVisibility").expect("node");
    for (k, v) in params {
        g.set_param(&cat, &id, k, v.clone()).expect("param");
    }
    let mut opts = EvalOptions::default();
    let t = Arc::new(
        gpu.upload(map.width, map.height, 1, &map.data)
            .expect("map"),
    );
    opts.inject.insert(
        (id.clone(), "shadow".into()),
        (PortValue::ShadowMap(t, light), 1),
    );
    let mut ev = Evaluator::new(registry, gpu.clone());
    let r = ev
        .evaluate(&g, &[Target::Port(id.clone(), "soft".into())], &opts)
        .map_err(|e| e.to_string())?;
    match &r.outputs[&(id, "soft".to_string())] {
        PortValue::SoftShadow(v, m) => Ok((
            gpu.recorder()
                .read_volume(v, 0)
                .map_err(|e| e.to_string())?,
            *m,
        )),
        _ => Err("not a soft volume".into()),
    }
}

/// A straight edge: an occluder at light depth 0.1 over the left half of a `res`² map, nothing
/// (depth 1) over the right half.
pub(super) fn edge_map(res: u32) -> Raster {
    let mut map = Raster::new(res, res, 1, 1.0);
    for y in 0..res {
        for x in 0..res / 2 {
            map.data[(y * res + x) as usize] = 0.1;
        }
    }
    map
}

/// Across the edge of [`edge_map`], on the middle row of slice `k`: the sum of the two texels
/// beside the edge (1 when the half shadow lies on it) and the variance of the profile's
/// derivative — the blur applied to the edge — over `half` texels each side (the buffer's own
/// border, where the occluder meets the zero outside, also falls off, so stay clear of it).
fn edge_profile(volume: &[f32], res: u32, k: u32, half: u32) -> (f64, f64) {
    let row = res / 2;
    let a = |x: u32| volume[((k * res + row) * res + x) as usize] as f64;
    let (mut m0, mut m2) = (0.0, 0.0);
    for x in res / 2 - half..res / 2 + half + 1 {
        let w = a(x - 1) - a(x);
        let pos = x as f64 - res as f64 / 2.0;
        m0 += w;
        m2 += w * pos * pos;
    }
    (a(res / 2 - 1) + a(res / 2), m2 / m0)
}

pub(super) fn p_int(v: i64) -> ParamValue {
    ParamValue::Int(v)
}
pub(super) fn p_f(v: f64) -> ParamValue {
    ParamValue::Float(v)
}

pub(super) fn spec_for(kernel: Kernel, res: u32, slices: u32, radius: f64, d1: f64) -> KernelSpec {
    KernelSpec {
        kernel,
        variance: sv::variance_texels(&light(), res, slices, radius, d1, [1.0, 1.0]),
        rotation: 0.0,
        samples: 8,
        size: 5,
        seed: 1,
    }
}

#[test]
fn gpu_equals_cpu_for_every_kernel() {
    let Some(gpu) = common::gpu_for(&["SoftVisibility"]) else {
        return;
    };
    let map = common::random_raster(24, 24, 1, 0.1, 1.2, 7);
    for kernel in Kernel::NAMES {
        let k = Kernel::from_name(kernel).expect("kernel");
        let params = [
            ("kernel", ParamValue::Enum(kernel.to_string())),
            ("resolution", p_int(16)),
            ("slices", p_int(8)),
            ("sun_radius", p_f(6.0)),
            ("d1", p_f(6.0)),
        ];
        let got = run(&gpu, &map, &params).expect("run");
        let want = sv::reference(
            &map,
            16,
            8,
            &spec_for(k, 16, 8, 6.0, 6.0),
            0.002,
            None,
            None,
        );
        let d = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        // 1e-5: the same stencils summed in the same order, f32 on both sides.
        assert!(d <= 1e-5, "{kernel}: {d}");
        assert!(
            got.iter().all(|v| (0.0..=1.0).contains(v)),
            "{kernel}: outside [0, 1]"
        );
    }
}

#[test]
fn zero_light_variance_is_the_hard_test() {
    let Some(gpu) = common::gpu_for(&["SoftVisibility"]) else {
        return;
    };
    let (res, slices) = (32, 16);
    let map = common::random_raster(res, res, 1, 0.05, 1.1, 3);
    let got = run(
        &gpu,
        &map,
        &[
            ("resolution", p_int(res as i64)),
            ("slices", p_int(slices as i64)),
            ("sun_radius", p_f(0.0)),
        ],
    )
    .expect("run");
    for k in 0..slices {
        for y in 0..res {
            for x in 0..res {
                let hard = map.pixel(x, y)[0] + 0.002 < (k + 1) as f32 / slices as f32;
                let a = got[((k * res + y) * res + x) as usize];
                assert_eq!(a, hard as u32 as f32, "slice {k}, texel ({x},{y})");
            }
        }
    }
}

/// A straight edge: an occluder at light depth 0.1 over the left half. Behind it, at n slices,
/// the shadow's profile across the edge has its half value on the edge (seed 004 eq. 10 with a
/// centred light) and variance n σ_κ², so its width at d1 is the exact penumbra's, d1 σ_l.
#[test]
fn penumbra_behind_a_straight_edge() {
    let Some(gpu) = common::gpu_for(&["SoftVisibility"]) else {
        return;
    };
    let (res, slices) = (64u32, 40u32);
    let map = edge_map(res);
    let (radius, d1) = (8.0, 5.0);
    let got = run(
        &gpu,
        &map,
        &[
            ("resolution", p_int(res as i64)),
            ("slices", p_int(slices as i64)),
            ("sun_radius", p_f(radius)),
            ("d1", p_f(d1)),
            ("kernel", ParamValue::Enum("TopHat".into())),
        ],
    )
    .expect("run");
    let target = sv::variance_texels(&light(), res, slices, radius, d1, [1.0, 1.0])[0];
    let k0 = ((0.1 + 0.002) * slices as f64) as u32; // the occluder's slice
    for k in [k0 + 4, k0 + 10, k0 + 20, slices - 1] {
        let (mid, var) = edge_profile(&got, res, k, 15);
        assert!(
            (mid - 1.0).abs() < 1e-3,
            "slice {k}: half shadow on the edge ({mid})"
        );
        let want = (k - k0) as f64 * target;
        // 5 %: the derivative's texel sampling adds 1/12 texel², a few % of these variances.
        assert!(
            (var - want).abs() <= 0.05 * want + 1.0 / 12.0,
            "slice {k}: variance {var} texels² vs n σκ² = {want}"
        );
    }
    // At d1 behind the edge the standard deviation is d1 σ_l (the exact penumbra's).
    let depth_m = 20.0;
    let e = depth_m / slices as f64;
    let texel = 20.0 / res as f64;
    let n = d1 / e;
    let sigma_l = radius.to_radians().tan() / 2.0;
    let std_m = (n * target).sqrt() * texel;
    assert!(
        (std_m - d1 * sigma_l).abs() < 1e-6 * std_m,
        "{std_m} vs {}",
        d1 * sigma_l
    );
}

#[test]
fn extremes_stay_finite_and_in_range() {
    let Some(gpu) = common::gpu_for(&["SoftVisibility"]) else {
        return;
    };
    let res = 16;
    let empty = Raster::new(res, res, 1, tyndall::eval::SHADOW_CLEAR);
    let full = Raster::new(res, res, 1, 0.0);
    for (what, map) in [("empty", &empty), ("fully occluded", &full)] {
        for (slices, radius) in [(0, 0.0), (1, 10.0), (3, 10.0), (64, 0.001)] {
            // Every kernel with the seed's growth, and the linear growth.
            let cases = Kernel::NAMES
                .iter()
                .map(|k| (*k, "seed"))
                .chain([("Dirac2", "linear")]);
            for (kernel, growth) in cases {
                let got = run(
                    &gpu,
                    map,
                    &[
                        ("resolution", p_int(res as i64)),
                        ("slices", p_int(slices)),
                        ("sun_radius", p_f(radius)),
                        ("kernel", ParamValue::Enum(kernel.to_string())),
                        ("growth", ParamValue::Enum(growth.to_string())),
                    ],
                )
                .expect("run");
                assert!(got.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v)));
                if std::ptr::eq(map, &empty) {
                    assert!(
                        got.iter().all(|v| *v == 0.0),
                        "{what}, {kernel}: nothing occludes"
                    );
                } else {
                    // Every texel is occluded from slice 0 on; the borders lose a little to
                    // the zero outside the buffer, the interior stays 1.
                    let last = &got[got.len() - (res * res) as usize..];
                    let c = last[(res * res / 2 + res / 2) as usize];
                    // 1e-6: weights summing to one in f32.
                    assert!(
                        (c - 1.0).abs() <= 1e-6,
                        "{what}, {kernel}, {slices} slices, {radius}°: {c}"
                    );
                }
            }
        }
    }
}

/// `SingleScattering` with a zero-variance soft volume at the map's resolution equals its hard
/// test except for samples within one slice of an occluder: V̄ differs little.
#[test]
fn scattering_with_a_hard_soft_volume_matches_the_hard_test() {
    let Some(gpu) = common::gpu_for(&["SoftVisibility"]) else {
        return;
    };
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let text = r#"(version: 2, nodes: {
        "scene": (kind: "Scene", params: {"name": "fence"}),
        "shadow": (kind: "ShadowMap", params: {"resolution": 256}),
        "gbuffer": (kind: "GBuffer"),
        "soft": (kind: "SoftVisibility", params: {"resolution": 256, "slices": 256, "sun_radius": 0.0}),
        "hard": (kind: "SingleScattering", params: {"method": "BruteForce", "steps": 64}),
        "soft_scatter": (kind: "SingleScattering", params: {"method": "BruteForce", "steps": 64}),
    }, edges: [("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"),
        ("shadow.map", "hard.shadow"), ("gbuffer.depth", "hard.depth"),
        ("shadow.map", "soft.shadow"), ("soft.soft", "soft_scatter.soft"),
        ("shadow.map", "soft_scatter.shadow"), ("gbuffer.depth", "soft_scatter.depth")])"#;
    let g = tyndall::graph::load_str(text, std::path::Path::new("g.ron"), &cat).expect("graph");
    let port = |n: &str, p: &str| Target::Port(n.into(), p.into());
    let mut ev = Evaluator::new(registry, gpu.clone());
    let r = ev
        .evaluate(
            &g,
            &[
                port("hard", "visibility"),
                port("soft_scatter", "visibility"),
            ],
            &EvalOptions {
                size: (64, 36),
                ..Default::default()
            },
        )
        .expect("evaluate");
    let dl = |n: &str| {
        tyndall::eval::download(
            &gpu.recorder(),
            &r.outputs[&(n.to_string(), "visibility".to_string())],
        )
        .expect("download")
    };
    let (hard, soft) = (dl("hard"), dl("soft_scatter"));
    let diffs: Vec<f32> = hard
        .data
        .iter()
        .zip(&soft.data)
        .map(|(a, b)| (a - b).abs())
        .collect();
    let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let max = diffs.iter().cloned().fold(0.0f32, f32::max);
    // Samples within one slice (20 m / 256 here) in front of an occluder read it as occluding
    // partly: a few of 64 samples on a ray at most.
    assert!(mean <= 0.01 && max <= 0.1, "mean {mean}, max {max}");
    // MinMax refuses a soft volume, naming the port.
    let mut g2 = g.clone();
    g2.set_param(
        &cat,
        "soft_scatter",
        "method",
        ParamValue::Enum("MinMax".into()),
    )
    .expect("param");
    let err = ev
        .evaluate(
            &g2,
            &[port("soft_scatter", "visibility")],
            &EvalOptions::default(),
        )
        .expect_err("MinMax with soft");
    assert!(err.to_string().contains("soft"), "{err}");
}

/// `growth = linear`: GPU = CPU, and behind the straight edge the profile's variance is n² times
/// one slice's e² σ_l² — its width grows linearly with the distance, as the exact penumbra's.
#[test]
fn linear_growth_matches_the_exact_penumbra_at_every_distance() {
    let Some(gpu) = common::gpu_for(&["SoftVisibility"]) else {
        return;
    };
    let (res, slices) = (64u32, 40u32);
    let map = edge_map(res);
    let radius = 4.0;
    let params = [
        ("resolution", p_int(res as i64)),
        ("slices", p_int(slices as i64)),
        ("sun_radius", p_f(radius)),
        ("growth", ParamValue::Enum("linear".into())),
    ];
    let got = run(&gpu, &map, &params).expect("run");
    let step = sv::step_variance(&light(), res, slices, radius, [1.0, 1.0]);
    let step32 = step.map(|v| v as f32);
    let want = sv::reference(
        &map,
        res,
        slices,
        &spec_for(Kernel::Dirac2, res, slices, radius, 1.0),
        0.002,
        Some(step32),
        None,
    );
    let d = got
        .iter()
        .zip(&want)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    // 1e-4: bilinear weights and the mean-age division in f32 on both sides, in other orders.
    assert!(d <= 1e-4, "GPU vs CPU: {d}");
    let k0 = ((0.1 + 0.002) * slices as f64) as u32;
    for k in [k0 + 3, k0 + 8, k0 + 16, k0 + 30] {
        let (mid, var) = edge_profile(&got, res, k, 20);
        assert!(
            (mid - 1.0).abs() < 1e-3,
            "slice {k}: half shadow on the edge ({mid})"
        );
        let n = (k - k0) as f64;
        let want = n * n * step[0];
        // 5 % + 1/12 texel²: as for the seed kernel's edge test above.
        assert!(
            (var - want).abs() <= 0.05 * want + 1.0 / 12.0,
            "slice {k} (n = {n}): variance {var} texels² vs n² e² σ_l² = {want}"
        );
    }
}

/// Every kernel's stencil has weights summing to 1, mean 0 and the target variance (bisection
/// to 1e-6), for small and large sample counts and variances.
#[test]
fn stencils_have_zero_mean_and_the_target_variance() {
    for kernel in Kernel::NAMES {
        for (samples, size, var) in [(2, 2, 0.3), (3, 3, 2.0), (8, 5, 0.05), (64, 15, 40.0)] {
            let spec = KernelSpec {
                kernel: Kernel::from_name(kernel).expect("kernel"),
                variance: [var, var],
                rotation: 0.3,
                samples,
                size,
                seed: 5,
            };
            for k in 0..4 {
                let st = sv::stencil(&spec, k);
                let w: f64 = st.iter().map(|t| t.2).sum();
                let mx: f64 = st.iter().map(|t| t.0 as f64 * t.2).sum();
                let my: f64 = st.iter().map(|t| t.1 as f64 * t.2).sum();
                assert!((w - 1.0).abs() < 1e-9, "{kernel}: weights sum to {w}");
                assert!(
                    mx.abs() < 1e-6 && my.abs() < 1e-6,
                    "{kernel} n={samples}: mean ({mx}, {my})"
                );
                let v = sv::stencil_variance(&st);
                assert!(
                    (v - var).abs() < 1e-6 * var.max(1.0),
                    "{kernel}: variance {v} vs {var}"
                );
            }
        }
    }
}
