//! Epipolar dilation/closure against the reference definition (seed eq. 3).

mod common;

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
    common::run_node(
        gpu,
        kind,
        &[
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
