//! Epipolar dilation/closure against the reference definition (seed eq. 3).

use crate::common;
use std::sync::Arc;

use tyndall::eval::{Matrices, PortValue};
use tyndall::graph::ParamValue;
use tyndall::io::Raster;
use tyndall::nodes::epipolar::reference;

fn run(
    gpu: &Arc<tyndall::gpu::Gpu>,
    kind: &str,
    map: &Raster,
    l: [f64; 2],
    z_l: f64,
    length: i64,
) -> Raster {
    run_with(gpu, kind, map, l, z_l, length, "Reference")
}

fn run_with(
    gpu: &Arc<tyndall::gpu::Gpu>,
    kind: &str,
    map: &Raster,
    l: [f64; 2],
    z_l: f64,
    length: i64,
    method: &str,
) -> Raster {
    common::run_node(
        gpu,
        kind,
        &[
            ("method", ParamValue::Enum(method.into())),
            ("epipole_x", ParamValue::Float(l[0])),
            ("epipole_y", ParamValue::Float(l[1])),
            ("epipole_depth", ParamValue::Float(z_l)),
            ("length", ParamValue::Int(length)),
        ],
        vec![(
            "map",
            PortValue::ShadowMap(
                Arc::new(gpu.upload(map.width, map.height, 1, &map.data).expect("up")),
                Matrices::default(),
            ),
        )],
        &["map"],
        (1, 1),
    )
    .expect("evaluate")
    .remove("map")
    .expect("map")
}

/// Share of texels within 1e-4. GPU and CPU follow the same f32 steps, but a sample point
/// within rounding of a texel edge may land in the neighbouring texel; such flips are rare.
fn agreement(a: &Raster, b: &Raster) -> f64 {
    let close = a
        .data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| (*x - *y).abs() <= 1e-4)
        .count();
    close as f64 / a.data.len() as f64
}

#[test]
fn gpu_matches_reference_definition_in_all_epipole_cases() {
    let gpu = require_gpu!();
    let map = common::random_raster(48, 40, 1, 0.2, 0.9, 11);
    let cases: [([f64; 2], f64); 6] = [
        ([24.5, 20.5], 0.5),   // on a texel centre inside the map
        ([10.2, 33.7], 0.3),   // inside the map
        ([-300.0, 12.0], 0.4), // outside
        ([1e6, -2e6], 0.5),    // very far: nearly parallel rays
        ([60.0, -10.0], -0.5), // z_l below 0
        ([-20.0, 70.0], 1.7),  // z_l above 1
    ];
    for (l, z_l) in cases {
        for length in [1, 5, 15] {
            let lf = [l[0] as f32, l[1] as f32];
            let dil = reference(&map, lf, z_l as f32, length, false);
            let clo = reference(&dil, lf, z_l as f32, length, true);
            let g = run(&gpu, "EpipolarDilation", &map, l, z_l, length as i64);
            let gc = run(&gpu, "EpipolarClosure", &map, l, z_l, length as i64);
            assert!(
                g.data.iter().chain(&gc.data).all(|v| v.is_finite()),
                "{l:?} {z_l}: non-finite"
            );
            assert!(
                agreement(&g, &dil) >= 0.99,
                "dilation {l:?} z_l={z_l} k={length}: {}",
                agreement(&g, &dil)
            );
            assert!(
                agreement(&gc, &clo) >= 0.99,
                "closure {l:?} z_l={z_l} k={length}: {}",
                agreement(&gc, &clo)
            );
            // Dilation only lowers depths (occluders grow); closure lies between.
            assert!(g.data.iter().zip(&map.data).all(|(a, b)| *a <= *b + 1e-6));
        }
    }
}

#[test]
fn identity_and_flat_maps() {
    let gpu = require_gpu!();
    let map = common::random_raster(16, 16, 1, 0.0, 1.0, 12);
    assert_eq!(
        run(&gpu, "EpipolarClosure", &map, [3.0, 4.0], 0.5, 0),
        map,
        "length 0 is the identity"
    );
    // The texel at the epipole is unchanged.
    let g = run(&gpu, "EpipolarDilation", &map, [8.5, 8.5], 0.5, 5);
    assert_eq!(g.pixel(8, 8), map.pixel(8, 8));
    // With the epipole in front of the map (z_l < 1), an empty map stays empty; a fully
    // occluded one stays finite.
    let ones = Raster::new(16, 16, 1, 1.0);
    let d = run(&gpu, "EpipolarDilation", &ones, [-40.0, 8.0], 0.2, 8);
    assert!(d.data.iter().all(|v| (*v - 1.0).abs() <= 1e-6));
    let zeros = Raster::new(16, 16, 1, 0.0);
    let d = run(&gpu, "EpipolarClosure", &zeros, [-40.0, 8.0], 0.2, 8);
    assert!(d.data.iter().all(|v| v.is_finite()));
    assert!(
        agreement(
            &d,
            &reference(
                &reference(&zeros, [-40.0, 8.0], 0.2, 8, false),
                [-40.0, 8.0],
                0.2,
                8,
                true
            )
        ) >= 0.99
    );
}

/// The shadow map of a built-in scene (the foliage of the tree, the figure) and its epipole.
fn scene_map(gpu: &Arc<tyndall::gpu::Gpu>, scene: &str, res: i64) -> (Raster, [f64; 2], f64) {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = tyndall::graph::Graph::new();
    let s = g.add_node(&cat, "Scene").expect("scene");
    g.set_param(&cat, &s, "name", ParamValue::Enum(scene.into()))
        .expect("name");
    let m = g.add_node(&cat, "ShadowMap").expect("map");
    g.set_param(&cat, &m, "resolution", ParamValue::Int(res))
        .expect("res");
    let b = g.add_node(&cat, "GBuffer").expect("gbuffer");
    g.connect(&cat, &format!("{s}.scene"), &format!("{m}.scene"))
        .expect("edge");
    g.connect(&cat, &format!("{s}.scene"), &format!("{b}.scene"))
        .expect("edge");
    let r = tyndall::eval::Evaluator::new(registry, gpu.clone())
        .evaluate(
            &g,
            &[
                tyndall::eval::Target::Port(m.clone(), "map".into()),
                tyndall::eval::Target::Port(b.clone(), "depth".into()),
            ],
            &tyndall::eval::EvalOptions {
                size: (8, 8),
                ..Default::default()
            },
        )
        .expect("eval");
    let (PortValue::ShadowMap(_, light), PortValue::Depth(_, cam)) = (
        &r.outputs[&(m.clone(), "map".to_string())],
        &r.outputs[&(b, "depth".to_string())],
    ) else {
        panic!("types")
    };
    let (l, z_l) = tyndall::nodes::epipolar::epipole(light, cam, res as u32, res as u32);
    let map = tyndall::eval::download(gpu, &r.outputs[&(m, "map".to_string())]).expect("download");
    (map, [l[0] as f64, l[1] as f64], z_l as f64)
}

/// Texels where the fast path differs from the reference method by more than 1e-6, and the
/// largest difference. Both evaluate the same f32 expressions, but the driver compiles each
/// entry point on its own and may fuse `z_l + d_t · κ` into an FMA in one and not the other:
/// 1 ulp (≈ 6e-8 at depth 1) is seen with the epipole 1e9 texels away; 1e-6 allows that and
/// nothing else (a texel landing on a neighbouring sample differs by far more).
fn differences(a: &Raster, b: &Raster) -> (usize, f32) {
    let n = a
        .data
        .iter()
        .zip(&b.data)
        .filter(|(x, y)| (*x - *y).abs() > 1e-6)
        .count();
    let m = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    (n, m)
}

/// Compare the two methods on one map for both kinds, several epipoles and lengths.
fn assert_fast_equals_reference(
    gpu: &Arc<tyndall::gpu::Gpu>,
    what: &str,
    map: &Raster,
    epipoles: &[([f64; 2], f64)],
    lengths: &[i64],
) {
    for &(epi, zl) in epipoles {
        for kind in ["EpipolarDilation", "EpipolarClosure"] {
            for &length in lengths {
                let reference = run_with(gpu, kind, map, epi, zl, length, "Reference");
                let fast = run_with(gpu, kind, map, epi, zl, length, "Fast");
                let (n, m) = differences(&fast, &reference);
                eprintln!(
                    "{what} {kind} epipole ({:.1}, {:.1}) z_l {zl:.3} k {length}: {n} texels differ by > 1e-6, max {m}",
                    epi[0], epi[1]
                );
                assert_eq!(
                    n, 0,
                    "{what} {kind} epipole {epi:?} z_l {zl} k {length}: {n} texels differ (max {m})"
                );
            }
        }
    }
}

/// The fast path proves every texel's answer (exact end samples against a bound from the
/// rectified grid, else the exact loop), so it must equal the definition on every texel
/// (within 1e-6, see `differences`) on the built-in scenes' shadow
/// maps with the camera's epipole and with epipoles inside, outside and far from the map.
/// (The issue asks for ≥ 99 % of texels within 1e-4; this asserts 100 % within 1e-6.)
#[test]
fn fast_path_equals_the_definition_on_scene_maps() {
    let gpu = require_gpu!();
    for scene in ["tree", "figure"] {
        let (map, l, z_l) = scene_map(&gpu, scene, 256);
        let epipoles = [
            (l, z_l),
            ([128.5, 100.0], z_l),
            ([-1e5, 3e5], z_l),
            ([300.0, -40.0], -0.3),
        ];
        assert_fast_equals_reference(&gpu, scene, &map, &epipoles, &[15, 60]);
    }
}

/// The same on uniform noise, where the grid's bound rarely proves anything and most texels
/// take the exact loop, and at the edge cases: epipole on a texel centre, inside,
/// 1e6 and 1e9 texels away (where f32 angles are too coarse for the grid and the coverage
/// check sends texels to the exact loop), z_l below 0 and above 1, lengths at and around the
/// 2·ENDS cut-over.
#[test]
fn fast_path_equals_the_definition_on_noise_and_edge_cases() {
    let gpu = require_gpu!();
    let map = common::random_raster(61, 47, 1, 0.2, 0.9, 21);
    let epipoles = [
        ([30.5, 20.5], 0.5),
        ([10.2, 33.7], 0.3),
        ([-300.0, 12.0], 0.4),
        ([1e6, -2e6], 0.5),
        ([-1e9, 3e8], 0.6),
        ([80.0, -10.0], -0.5),
        ([-20.0, 70.0], 1.7),
    ];
    assert_fast_equals_reference(&gpu, "noise", &map, &epipoles, &[1, 6, 7, 9, 33]);
}
