//! NoiseVolume: GPU equal to the CPU reference (level 0 and the mip chain), values in [0, 1]
//! with the spread of noise, drift with time, the box, and the extremes.

mod common;

use std::sync::Arc;

use tyndall::eval::{EvalOptions, Evaluator, PortValue, Target};
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
    let gpu = require_gpu!();
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
    let level0 = gpu.read_volume(&v, 0).expect("read");
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
        let got = gpu.read_volume(&v, level).expect("read");
        let want = nv::reference_mip(&below, v.level_size(level - 1));
        let d = got
            .iter()
            .zip(&want)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(d <= 1e-6, "level {level}: {d}");
        below = got;
    }
    let top = gpu.read_volume(&v, 5).expect("top");
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
    let gpu = require_gpu!();
    let p = [
        ("resolution", ParamValue::Int(32)),
        ("speed", ParamValue::Float(0.25)),
    ];
    let (a, _) = noise(&gpu, &p, false, 0.0);
    let (b, _) = noise(&gpu, &p, false, 2.0);
    let (ra, rb) = (
        gpu.read_volume(&a, 0).expect("a"),
        gpu.read_volume(&b, 0).expect("b"),
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
    let gpu = require_gpu!();
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
            let r = gpu.read_volume(&v, level).expect("read");
            assert!(r.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)));
        }
    }
}
