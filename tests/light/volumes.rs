//! NoiseVolume: GPU equal to the CPU reference (level 0 and the mip chain), values in [0, 1]
//! with the spread of noise, drift with time, the box, and the extremes.

use crate::common;
use std::sync::Arc;

use tyndall::eval::{EvalOptions, Evaluator, PortValue, Status, Target};
use tyndall::graph::{Graph, ParamValue};
use tyndall::nodes::noise_volume as nv;

/// Evaluate a NoiseVolume with these parameters (and a `window` scene on `scene` when asked);
/// returns the volume and its box.
fn noise(
    gpu: &Arc<tyndall::gpu::Gpu>,
    params: &[(&str, ParamValue)],
    with_scene: bool,
    time: f64,
) -> (Arc<tyndall::gpu::GpuVolume>, [[f32; 3]; 2]) {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let id = g.add_node(&cat, "NoiseVolume").expect("node");
    for (k, v) in params {
        g.set_param(&cat, &id, k, v.clone()).expect("param");
    }
    if with_scene {
        let s = g.add_node(&cat, "Scene").expect("scene");
        g.set_param(&cat, &s, "name", ParamValue::Enum("window".into()))
            .expect("name");
        g.connect(&cat, &format!("{s}.scene"), &format!("{id}.scene"))
            .expect("edge");
    }
    let mut ev = Evaluator::new(registry, gpu.clone());
    let opts = EvalOptions {
        time,
        ..Default::default()
    };
    let r = ev
        .evaluate(&g, &[Target::Port(id.clone(), "volume".into())], &opts)
        .expect("evaluate");
    match &r.outputs[&(id, "volume".to_string())] {
        PortValue::Volume(v, b) => (v.clone(), *b),
        other => panic!("not a volume: {other:?}"),
    }
}

fn params(n: u32, freq: f32, octaves: u32, persistence: f32, seed: u32) -> nv::NoiseParams {
    nv::NoiseParams {
        size: [n; 3],
        octaves,
        offset: [0.0; 3],
        frequency: freq,
        persistence,
        seed,
        _pad0: 0,
        _pad1: 0,
    }
}

#[test]
fn gpu_equals_cpu_with_its_mip_chain() {
    let gpu = require_gpu_for!("NoiseVolume");
    let (v, _) = noise(
        &gpu,
        &[
            ("resolution", ParamValue::Int(32)),
            ("frequency", ParamValue::Float(3.5)),
            ("octaves", ParamValue::Int(4)),
            ("persistence", ParamValue::Float(0.6)),
            ("seed", ParamValue::Int(7)),
        ],
        false,
        0.0,
    );
    assert_eq!(v.mips(), 6, "32 → 16 → 8 → 4 → 2 → 1");
    let level0 = gpu.recorder().read_volume(&v, 0).expect("read");
    let want = nv::reference(&params(32, 3.5, 4, 0.6, 7));
    let d = level0
        .iter()
        .zip(&want)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    // 1e-5: the same f32 operations; the GPU may fuse multiply-adds.
    assert!(d <= 1e-5, "level 0: {d}");
    let mut below = level0;
    for level in 1..v.mips() {
        let got = gpu.recorder().read_volume(&v, level).expect("read");
        let want = nv::reference_mip(&below, v.level_size(level - 1));
        let d = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(d <= 1e-6, "level {level}: {d}");
        below = got;
    }
    let top = gpu.recorder().read_volume(&v, 5).expect("top");
    assert_eq!(top.len(), 1);
}

#[test]
fn values_spread_over_zero_to_one() {
    let v = nv::reference(&params(32, 4.0, 3, 0.5, 1));
    assert!(v.iter().all(|x| (0.0..=1.0).contains(x)));
    let mean = v.iter().sum::<f32>() / v.len() as f32;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f32>() / v.len() as f32).sqrt();
    assert!((mean - 0.5).abs() < 0.05, "mean {mean}");
    assert!(sd > 0.05, "spread {sd}: noise, not a constant");
    // Another seed is another volume.
    let w = nv::reference(&params(32, 4.0, 3, 0.5, 2));
    assert!(v.iter().zip(&w).any(|(a, b)| (a - b).abs() > 0.1));
    // Frequency 0 samples one lattice point: a constant volume.
    let c = nv::reference(&params(32, 0.0, 8, 1.0, 1));
    assert!(c.iter().all(|x| *x == c[0]));
}

#[test]
fn drift_follows_time_and_box_follows_the_scene() {
    let gpu = require_gpu_for!("NoiseVolume");
    let p = [
        ("resolution", ParamValue::Int(32)),
        ("speed", ParamValue::Float(0.25)),
    ];
    let (a, _) = noise(&gpu, &p, false, 0.0);
    let (b, _) = noise(&gpu, &p, false, 2.0);
    let (ra, rb) = (
        gpu.recorder().read_volume(&a, 0).expect("a"),
        gpu.recorder().read_volume(&b, 0).expect("b"),
    );
    assert!(ra.iter().zip(&rb).any(|(x, y)| (x - y).abs() > 0.05));
    // Drift is a shift along z: frame 2 at speed 0.25 with frequency 4 over 32 texels moves the
    // noise by 0.5 cells = 4 texels.
    let n = 32usize;
    let at = |v: &[f32], x: usize, y: usize, z: usize| v[(z * n + y) * n + x];
    for (x, y, z) in [(3, 5, 0), (10, 20, 7), (31, 0, 27)] {
        assert!((at(&rb, x, y, z) - at(&ra, x, y, z + 4)).abs() < 1e-4);
    }
    let (_, bounds) = noise(&gpu, &[("resolution", ParamValue::Int(32))], true, 0.0);
    let scene = tyndall::scene::builtin("window", 1).expect("scene");
    let (lo, hi) = scene.bounds();
    assert_eq!(bounds, [lo.to_array(), hi.to_array()]);
}

#[test]
fn extremes_stay_finite() {
    let gpu = require_gpu_for!("NoiseVolume");
    for (freq, oct, pers) in [(0.0, 1, 0.0), (256.0, 8, 1.0), (1e-3, 8, 0.0)] {
        let (v, _) = noise(
            &gpu,
            &[
                ("resolution", ParamValue::Int(32)),
                ("frequency", ParamValue::Float(freq)),
                ("octaves", ParamValue::Int(oct)),
                ("persistence", ParamValue::Float(pers)),
                ("seed", ParamValue::Int(2147483647)),
            ],
            false,
            1e6,
        );
        for level in 0..v.mips() {
            let r = gpu.recorder().read_volume(&v, level).expect("read");
            assert!(r.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)));
        }
    }
}

use tyndall::eval::Matrices;
use tyndall::io::Raster;
use tyndall::nodes::heterogeneity as het;

fn camera(w: u32, h: u32) -> Matrices {
    let c = tyndall::scene::Camera {
        position: glam::Vec3::new(7.0, 2.0, 8.0),
        target: glam::Vec3::new(0.0, 1.5, 0.0),
        fov_y: 50.0,
        near: 0.1,
        far: 40.0,
    };
    Matrices::of_camera(&c, w, h)
}

/// A graph: noise (and optionally α and I volumes, other noises) → Heterogeneity, with the
/// in-scatter and depth injected; returns h, the image, and the noise / α / I volumes read back.
#[allow(clippy::type_complexity)]
fn heterogeneity(
    gpu: &Arc<tyndall::gpu::Gpu>,
    params: &[(&str, ParamValue)],
    volumes: bool,
    depth: &Raster,
    ins: &Raster,
) -> (Raster, Raster, Vec<het::CpuVolume>, Status) {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let het_id = g.add_node(&cat, "Heterogeneity").expect("node");
    for (k, v) in params {
        g.set_param(&cat, &het_id, k, v.clone()).expect("param");
    }
    let mut vols = vec![];
    let ports: &[&str] = if volumes {
        &["noise", "alpha", "intensity"]
    } else {
        &["noise"]
    };
    for (i, port) in ports.iter().enumerate() {
        let n = g.add_node(&cat, "NoiseVolume").expect("noise");
        g.set_param(&cat, &n, "resolution", ParamValue::Int(32))
            .expect("res");
        g.set_param(&cat, &n, "seed", ParamValue::Int(i as i64 + 3))
            .expect("seed");
        g.set_param(
            &cat,
            &n,
            "box_min",
            ParamValue::Vec3([-4.0 - i as f64, 0.0, -4.0]),
        )
        .expect("box");
        g.connect(&cat, &format!("{n}.volume"), &format!("{het_id}.{port}"))
            .expect("edge");
        vols.push(n);
    }
    let mut ev = Evaluator::new(registry, gpu.clone());
    let mut opts = EvalOptions::default();
    let m = camera(depth.width, depth.height);
    let d = Arc::new(
        gpu.upload(depth.width, depth.height, 1, &depth.data)
            .expect("d"),
    );
    opts.inject.insert(
        (het_id.clone(), "depth".into()),
        (PortValue::Depth(d, m), 1),
    );
    opts.inject.insert(
        (het_id.clone(), "inscatter".into()),
        (common::upload(gpu, ins, tyndall::graph::PortType::Image), 2),
    );
    let mut targets = vec![
        Target::Port(het_id.clone(), "h".into()),
        Target::Port(het_id.clone(), "image".into()),
    ];
    targets.extend(
        vols.iter()
            .map(|n| Target::Port(n.clone(), "volume".into())),
    );
    let r = ev.evaluate(&g, &targets, &opts).expect("evaluate");
    let get = |p: &str| {
        tyndall::eval::download(
            &gpu.recorder(),
            &r.outputs[&(het_id.clone(), p.to_string())],
        )
        .expect("read")
    };
    let cpu = vols
        .iter()
        .map(|n| match &r.outputs[&(n.clone(), "volume".to_string())] {
            PortValue::Volume(v, b) => {
                het::CpuVolume::read(&gpu.recorder(), v, *b).expect("read volume")
            }
            _ => panic!("volume"),
        })
        .collect();
    let status = r.stats.status(&het_id).expect("het has a status");
    (get("h"), get("image"), cpu, status)
}

fn scene_depth(w: u32, h: u32) -> Raster {
    let mut d = Raster::new(w, h, 1, 0.0);
    for (k, v) in d.data.iter_mut().enumerate() {
        *v = 6.0 + (k % 7) as f32 * 1.5;
    }
    d
}

#[test]
fn heterogeneity_gpu_equals_cpu() {
    let gpu = require_gpu_for!("NoiseVolume");
    let (w, h) = (24, 14);
    let depth = scene_depth(w, h);
    let ins = common::random_raster(w, h, 4, 0.0, 2.0, 9);
    for volumes in [false, true] {
        let p = [
            ("alpha", ParamValue::Float(0.8)),
            ("frequency", ParamValue::Float(1.3)),
            ("intensity", ParamValue::Float(1.5)),
            ("steps", ParamValue::Int(24)),
        ];
        let (got_h, got_img, vols, status) = heterogeneity(&gpu, &p, volumes, &depth, &ins);
        let fields = het::Fields {
            alpha: if volumes { Ok(&vols[1]) } else { Err(0.8) },
            frequency: Err(1.3),
            intensity: if volumes { Ok(&vols[2]) } else { Err(1.5) },
        };
        assert_eq!(status, Status::Ran, "volumes {volumes}: it marched");
        let want = het::reference_h(&depth, &camera(w, h), &vols[0], &fields, 24);
        let d = got_h
            .data
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        // 1e-4: 24 samples of trilinear lookups summed in f32 in another order.
        assert!(d <= 1e-4, "volumes {volumes}: {d}");
        for k in 0..(w * h) as usize {
            for c in 0..3 {
                let e = ins.data[k * 4 + c] * got_h.data[k];
                assert!((got_img.data[k * 4 + c] - e).abs() <= 1e-5 * e.abs().max(1.0));
            }
        }
        assert!(want.iter().any(|v| (v - want[0]).abs() > 1e-3), "h varies");
    }
}

#[test]
fn homogeneous_settings_pass_through_and_constant_noise_gives_its_value() {
    let gpu = require_gpu_for!("NoiseVolume");
    let (w, h) = (10, 6);
    let depth = scene_depth(w, h);
    let ins = common::random_raster(w, h, 4, 0.0, 2.0, 4);
    let (hh, img, _, status) = heterogeneity(
        &gpu,
        &[
            ("alpha", ParamValue::Float(0.0)),
            ("intensity", ParamValue::Float(1.0)),
        ],
        false,
        &depth,
        &ins,
    );
    assert_eq!(img.data, ins.data, "α = 0, I = 1: the input, unchanged");
    assert_eq!(
        status,
        Status::PassedThrough,
        "the statistics show that nothing was marched"
    );
    assert!(hh.data.iter().all(|v| *v == 1.0));
    // α = 1 at the coarsest level (one texel: the volume's mean) gives that value everywhere.
    let (hh, _, vols, _) = heterogeneity(
        &gpu,
        &[
            ("alpha", ParamValue::Float(1.0)),
            ("frequency", ParamValue::Float(16.0)),
        ],
        false,
        &depth,
        &ins,
    );
    let top = vols[0].levels.last().expect("top").1[0];
    assert!(hh.data.iter().all(|v| (v - top).abs() < 1e-5), "{top}");
}

#[test]
fn heterogeneity_extremes_stay_finite() {
    let gpu = require_gpu_for!("NoiseVolume");
    let (w, h) = (8, 5);
    let mut depth = scene_depth(w, h);
    depth.data[0] = 1e30;
    depth.data[1] = 0.0;
    depth.data[2] = 40.0;
    let ins = common::random_raster(w, h, 4, 0.0, 1.0, 5);
    for (steps, f) in [(1, 0.0), (4096, 16.0), (7, 5.5)] {
        let (hh, img, _, _) = heterogeneity(
            &gpu,
            &[
                ("steps", ParamValue::Int(steps)),
                ("frequency", ParamValue::Float(f)),
                ("alpha", ParamValue::Float(1.0)),
                ("intensity", ParamValue::Float(1e3)),
            ],
            true,
            &depth,
            &ins,
        );
        assert!(
            hh.data.iter().chain(&img.data).all(|v| v.is_finite()),
            "{steps} {f}"
        );
    }
}

use tyndall::nodes::blend_volume as bv;

/// Evaluate a BlendVolume with this data block and parameters; returns level 0 read back.
fn blend(
    gpu: &Arc<tyndall::gpu::Gpu>,
    data: &str,
    params: &[(&str, ParamValue)],
) -> Result<Vec<f32>, String> {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let id = g.add_node(&cat, "BlendVolume").expect("node");
    for (k, v) in params {
        g.set_param(&cat, &id, k, v.clone()).expect("param");
    }
    g.set_data(
        &id,
        Some(tyndall::graph::NodeData::from_text(data).expect("ron")),
    )
    .expect("data");
    let mut ev = Evaluator::new(registry, gpu.clone());
    let r = ev
        .evaluate(
            &g,
            &[Target::Port(id.clone(), "volume".into())],
            &EvalOptions::default(),
        )
        .map_err(|e| e.to_string())?;
    match &r.outputs[&(id, "volume".to_string())] {
        PortValue::Volume(v, _) => Ok(gpu.recorder().read_volume(v, 0).expect("read")),
        _ => Err("not a volume".into()),
    }
}

const SPLATS: &str = "(splats: [
    (centre: (0.0, 1.0, 0.0), radii: (3.0, 1.5, 2.0), value: 0.9, opacity: 1.0, hardness: 0.4,
     rotation: (0.0, 0.3826834, 0.0, 0.9238795)),
    (centre: (2.0, 2.0, 1.0), radii: (1.5, 1.5, 1.5), opacity: 0.7, hardness: 0.0, erase: true),
    (centre: (-3.0, 4.0, 2.0), radii: (0.0, 1.0, 1.0)),
])";

#[test]
fn blend_volume_gpu_equals_cpu_and_follows_its_splats() {
    let gpu = require_gpu_for!("BlendVolume");
    let got = blend(
        &gpu,
        SPLATS,
        &[
            ("resolution", ParamValue::Int(24)),
            ("base", ParamValue::Float(0.2)),
        ],
    )
    .expect("bake");
    let data: bv::BlendData = tyndall::graph::NodeData::from_text(SPLATS)
        .expect("ron")
        .parse()
        .expect("BlendData");
    let bounds = [[-5.0, 0.0, -5.0], [5.0, 5.0, 5.0]];
    let want = bv::reference(&data.splats, 0.2, bv::Role::Alpha, 24, bounds);
    let d = got
        .iter()
        .zip(&want)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    // 1e-5: the same f32 maths; the GPU rotates by the quaternion with its own operation order.
    assert!(d <= 1e-5, "{d}");
    // The first splat's centre holds its value; far away the base; the radius-0 splat is inert.
    let s = &data.splats;
    assert!((bv::weight(&s[0], s[0].centre) - 1.0).abs() < 1e-6);
    assert_eq!(bv::weight(&s[2], s[2].centre), 0.0);
    assert!(want.iter().all(|v| (0.2..=0.9).contains(v)));
    assert!(want.iter().any(|v| *v > 0.85) && want.contains(&0.2));
}

#[test]
fn blend_volume_extremes_and_roles() {
    let gpu = require_gpu_for!("BlendVolume");
    // A splat larger than the volume covers it all; values beyond the role's range are clamped.
    let huge =
        "(splats: [(centre: (0.0, 2.0, 0.0), radii: (1e6, 1e6, 1e6), value: 50.0, hardness: 1.0)])";
    let v = blend(&gpu, huge, &[("resolution", ParamValue::Int(16))]).expect("huge");
    assert!(v.iter().all(|x| *x == 1.0), "α clamps to 1");
    let v = blend(
        &gpu,
        huge,
        &[
            ("resolution", ParamValue::Int(16)),
            ("role", ParamValue::Enum("frequency".into())),
        ],
    )
    .expect("frequency");
    assert!(
        v.iter().all(|x| *x == 16.0),
        "frequency clamps to 16 levels"
    );
    // No splats: the base; a tiny splat between texel centres: finite.
    let v = blend(&gpu, "(splats: [])", &[("base", ParamValue::Float(0.4))]).expect("empty");
    assert!(v.iter().all(|x| *x == 0.4));
    let tiny = "(splats: [(centre: (0.01, 1.0, 0.01), radii: (1e-6, 1e-6, 1e-6))])";
    let v = blend(&gpu, tiny, &[]).expect("tiny");
    assert!(v.iter().all(|x| x.is_finite()));
    // A non-finite number is refused by name.
    let e = blend(
        &gpu,
        "(splats: [(centre: (0.0, 1.0, inf), radii: (1.0, 1.0, 1.0))])",
        &[],
    )
    .expect_err("refused");
    assert!(e.contains("BlendVolume") && e.contains("splat 0"), "{e}");
}
