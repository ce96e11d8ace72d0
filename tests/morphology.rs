//! 2D morphology: GPU equals the CPU reference exactly (min/max involve no rounding).

mod common;

use std::sync::Arc;

use tyndall::eval::{Matrices, PortValue};
use tyndall::graph::{ParamValue, PortType};
use tyndall::io::Raster;
use tyndall::nodes::morphology2d::{chord, radius_texels, reference, reference_closure, Unit};

/// Exact equality, reporting the first differing texel (whole rasters are too long to print).
fn same(a: &Raster, b: &Raster, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}: size");
    if let Some(i) = a.data.iter().zip(&b.data).position(|(x, y)| x != y) {
        panic!(
            "{what}: texel ({}, {}) is {} on the GPU, {} on the CPU",
            i as u32 % a.width,
            i as u32 / a.width,
            a.data[i],
            b.data[i]
        );
    }
}

fn run(
    gpu: &Arc<tyndall::gpu::Gpu>,
    kind: &str,
    map: &Raster,
    shape: &str,
    r: f64,
    method: &str,
) -> Raster {
    common::run_node(
        gpu,
        kind,
        &[
            ("shape", ParamValue::Enum(shape.into())),
            ("radius", ParamValue::Float(r)),
            ("method", ParamValue::Enum(method.into())),
        ],
        vec![("map", common::upload(gpu, map, PortType::ShadowMap))],
        &["map"],
        (1, 1),
    )
    .unwrap_or_else(|e| panic!("{kind} {shape} r={r} {method}: {e}"))
    .remove("map")
    .expect("map")
}

/// Random maps with holes: mostly occluder depths in [0.2, 0.6], some texels at 1 (no occluder).
fn holey(w: u32, h: u32, seed: u64) -> Raster {
    let mut r = common::random_raster(w, h, 1, 0.2, 0.6, seed);
    let mut rng = common::Rng(seed * 7 + 3);
    for v in &mut r.data {
        if rng.next_f32() < 0.3 {
            *v = 1.0;
        }
    }
    r
}

#[test]
fn gpu_equals_cpu_reference_exactly_for_all_shapes_and_radii() {
    let gpu = require_gpu!();
    let map = holey(37, 23, 1);
    for shape in ["Circle", "Square"] {
        let circle = shape == "Circle";
        for r in [0, 1, 2, 3, 4, 5, 7, 10, 22, 40, 100] {
            let dil = reference(&map, r, circle, false);
            let ero = reference(&map, r, circle, true);
            let clo = reference_closure(&map, r, circle);
            for method in ["Fast", "BruteForce"] {
                same(
                    &run(&gpu, "Dilate2D", &map, shape, r as f64, method),
                    &dil,
                    &format!("Dilate2D {shape} r={r} {method}"),
                );
                same(
                    &run(&gpu, "Erode2D", &map, shape, r as f64, method),
                    &ero,
                    &format!("Erode2D {shape} r={r} {method}"),
                );
                same(
                    &run(&gpu, "Closure2D", &map, shape, r as f64, method),
                    &clo,
                    &format!("Closure2D {shape} r={r} {method}"),
                );
            }
        }
    }
}

#[test]
fn edge_cases() {
    let gpu = require_gpu!();
    let map = holey(16, 9, 2);
    // r = 0 is the identity.
    same(
        &run(&gpu, "Closure2D", &map, "Circle", 0.0, "Fast"),
        &map,
        "r = 0",
    );
    // r larger than the map: every texel sees the whole map (square) and min/max are global.
    let min = map.data.iter().cloned().fold(f32::MAX, f32::min);
    let d = run(&gpu, "Dilate2D", &map, "Square", 1000.0, "Fast");
    assert!(d.data.iter().all(|v| *v == min));
    // All-1 (empty) and all-0 (fully occluded) maps are fixed points.
    for fill in [0.0, 1.0] {
        let flat = Raster::new(13, 7, 1, fill);
        for kind in ["Dilate2D", "Erode2D", "Closure2D"] {
            same(
                &run(&gpu, kind, &flat, "Circle", 3.0, "Fast"),
                &flat,
                &format!("{kind} on {fill}"),
            );
        }
    }
    // Closure fills holes smaller than the kernel: a single-texel hole disappears at r = 1.
    let mut one_hole = Raster::new(9, 9, 1, 0.3);
    one_hole.data[4 * 9 + 4] = 1.0;
    assert!(run(&gpu, "Closure2D", &one_hole, "Square", 1.0, "Fast")
        .data
        .iter()
        .all(|v| *v == 0.3));
}

#[test]
fn output_keeps_the_shadow_map_matrices_and_scalar_type() {
    let gpu = require_gpu!();
    let map = holey(8, 8, 3);
    let m = Matrices {
        far: 3.0,
        ..Matrices::default()
    };
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = tyndall::graph::Graph::new();
    let id = g.add_node(&cat, "Closure2D").expect("node");
    let mut opts = tyndall::eval::EvalOptions::default();
    opts.inject.insert(
        (id.clone(), "map".into()),
        (
            PortValue::ShadowMap(Arc::new(gpu.upload(8, 8, 1, &map.data).expect("up")), m),
            1,
        ),
    );
    let r = tyndall::eval::Evaluator::new(registry, gpu.clone())
        .evaluate(
            &g,
            &[tyndall::eval::Target::Port(id.clone(), "map".into())],
            &opts,
        )
        .expect("eval");
    match &r.outputs[&(id, "map".to_string())] {
        PortValue::ShadowMap(_, got) => assert_eq!(*got, m),
        other => panic!("{other:?}"),
    }
    let scalar = common::run_node(
        &gpu,
        "Erode2D",
        &[],
        vec![("map", common::upload(&gpu, &map, PortType::Scalar))],
        &["map"],
        (1, 1),
    )
    .expect("scalar");
    same(
        &scalar["map"],
        &reference(&map, 4, true, true),
        "Erode2D on a Scalar",
    );
}

#[test]
fn chords_and_units() {
    for r in 0..60 {
        for dy in 0..=r {
            let w = chord(r, dy);
            assert!(
                w * w + dy * dy <= r * r && (w + 1) * (w + 1) + dy * dy > r * r,
                "r={r} dy={dy} w={w}"
            );
        }
    }
    // A 2048-texel map spanning 20 m: 1 m = 102.4 texels.
    let m = Matrices {
        proj: glam::camera::rh::proj::directx::orthographic(-10.0, 10.0, -10.0, 10.0, 0.0, 1.0)
            .to_cols_array_2d(),
        ..Matrices::default()
    };
    assert_eq!(
        radius_texels(0.5, Unit::Metres, Some(&m), 2048).expect("m"),
        51
    );
    assert_eq!(
        radius_texels(0.5, Unit::Metres, Some(&m), 1024).expect("m"),
        26
    );
    assert_eq!(radius_texels(6.4, Unit::Texels, None, 1024).expect("t"), 6);
    assert!(radius_texels(1.0, Unit::Metres, None, 1024).is_err());
}

#[test]
fn hole_components_are_counted_four_connected() {
    let mut r = Raster::new(5, 4, 1, 0.0);
    // Two separate holes and one diagonal pair (two components under 4-connectivity).
    for (x, y) in [(0, 0), (1, 0), (3, 1), (3, 2), (0, 3), (1, 2)] {
        r.data[y * 5 + x] = 1.0;
    }
    assert_eq!(tyndall::bench::count_components(&r, 1.0), 4);
    assert_eq!(
        tyndall::bench::count_components(&Raster::new(3, 3, 1, 0.5), 1.0),
        0
    );
    assert_eq!(
        tyndall::bench::count_components(&Raster::new(3, 3, 1, 1.0), 1.0),
        1
    );
}
