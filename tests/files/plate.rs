//! Plate mode on the committed Cycles render `graphs/plate/plate.exr` (made by
//! `scripts/make_plate.py` from the same Blender scene as `graphs/plate/colonnade.glb`, with a
//! crate the glTF lacks): Cycles' planar Z, converted to ray distance, agrees with Tyndall's own
//! G-buffer where both see the same geometry; where the medium is absent the output is the
//! plate exactly; and in-scatter stops at the crate only the plate has.

use crate::common;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use tyndall::eval::{EvalOptions, Evaluator, PathPolicy, Target};
use tyndall::graph::{Graph, ParamValue};
use tyndall::io::Raster;

fn preset() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/plate/colonnade.ron")
}

fn load(registry: &tyndall::eval::Registry) -> Graph {
    let g = tyndall::graph::load_file(&preset(), registry.catalog()).expect("preset");
    let policy = PathPolicy {
        graph_dir: preset().parent().unwrap().to_path_buf(),
        output_dir: std::env::temp_dir(),
        allow_any: true,
    };
    tyndall::eval::resolve_files(registry, &g, &policy).expect("paths")
}

fn eval(gpu: &Arc<tyndall::gpu::Gpu>, g: &Graph, ports: &[(&str, &str)]) -> Vec<Raster> {
    let registry = Arc::new(tyndall::nodes::registry());
    let targets: Vec<Target> = ports
        .iter()
        .map(|(n, p)| Target::Port(n.to_string(), p.to_string()))
        .collect();
    let r = Evaluator::new(registry, gpu.clone())
        .evaluate(g, &targets, &EvalOptions::default())
        .expect("evaluate");
    ports
        .iter()
        .map(|(n, p)| {
            tyndall::eval::download(&gpu.recorder(), &r.outputs[&(n.to_string(), p.to_string())])
                .expect("download")
        })
        .collect()
}

/// The camera the G-buffer's depth carries (the glTF's, as Blender exported it).
fn camera_of(gpu: &Arc<tyndall::gpu::Gpu>, g: &Graph) -> tyndall::eval::Matrices {
    let registry = Arc::new(tyndall::nodes::registry());
    let r = Evaluator::new(registry, gpu.clone())
        .evaluate(
            g,
            &[Target::Port("gbuffer".into(), "depth".into())],
            &EvalOptions::default(),
        )
        .expect("evaluate");
    match &r.outputs[&("gbuffer".to_string(), "depth".to_string())] {
        tyndall::eval::PortValue::Depth(_, m) => *m,
        v => panic!("{v:?}"),
    }
}

#[test]
fn cycles_depth_matches_the_gltf_and_bounds_the_shafts() {
    let Some(gpu) = common::gpu() else { return };
    let registry = tyndall::nodes::registry();
    let mut g = load(&registry);
    let cat = registry.catalog();
    // A box of medium around the colonnade only: rays that miss it see no medium.
    g.set_param(
        cat,
        "scatter",
        "box_min",
        ParamValue::Vec3([-4.0, 0.0, -3.0]),
    )
    .unwrap();
    g.set_param(cat, "scatter", "box_max", ParamValue::Vec3([4.0, 5.0, 1.0]))
        .unwrap();
    let out = eval(
        &gpu,
        &g,
        &[
            ("gbuffer", "depth"),
            ("plate_depth", "scalar"),
            ("bound", "depth"),
            ("bound", "mask"),
            ("plate", "image"),
            ("scatter", "inscatter"),
            ("scatter", "transmittance"),
            ("over", "image"),
        ],
    );
    let [scene_d, plate_z, bound_d, mask, plate, inscatter, transmittance, over] =
        out.try_into().unwrap();
    let n = (plate.width * plate.height) as usize;
    let cam = camera_of(&gpu, &g);

    // 1. Where both see the same geometry they agree: Cycles' planar Z → ray distance equals
    //    the G-buffer's distance to 1 % at the median (silhouettes differ by a pixel's
    //    coverage, and the crate is only in the plate).
    let (w, h) = (plate.width, plate.height);
    let mut rel = Vec::new();
    let mut nearer = 0;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let z = plate_z.data[i];
            let Some(d) = tyndall::nodes::plate::plate_distance(
                z,
                &cam,
                (x, y, w, h),
                tyndall::nodes::plate::Convention::Planar,
                1.0,
            ) else {
                continue;
            };
            if scene_d.data[i] < 50.0 {
                rel.push((d - scene_d.data[i]).abs() / scene_d.data[i]);
                nearer += (d < 0.9 * scene_d.data[i]) as usize;
            }
        }
    }
    rel.sort_by(f32::total_cmp);
    assert!(rel.len() > n / 3, "{} pixels see geometry", rel.len());
    let median = rel[rel.len() / 2];
    let p90 = rel[rel.len() * 9 / 10];
    eprintln!(
        "Cycles Z as distance vs G-buffer: median relative difference {median:.2e}, 90th percentile {p90:.2e}, over {} px; {nearer} px > 10 % nearer (the crate)",
        rel.len()
    );
    assert!(median < 0.01, "median {median}");
    // The crate covers ~1900 of the 320 × 180 pixels.
    assert!(nearer > 400 && nearer < 3000, "{nearer} px of crate");
    // The mask is the crate: every pixel > 10 % nearer, and few more (its silhouette, where
    // the plate and scene differ by 1–10 %).
    let masked = (0..n).filter(|i| mask.data[*i] == 1.0).count();
    eprintln!("mask: {masked} px");
    assert!(
        masked >= nearer && masked < nearer + nearer / 4,
        "{masked} masked, {nearer} nearer"
    );

    // 2. Where the medium is absent (T = 1, no in-scatter) the output is the plate exactly.
    let (mut absent, mut worst) = (0, 0.0f32);
    for i in 0..n {
        let l = &inscatter.data[i * 4..i * 4 + 3];
        if transmittance.data[i] == 1.0 && l.iter().all(|v| *v == 0.0) {
            absent += 1;
            for c in 0..4 {
                worst = worst.max((over.data[i * 4 + c] - plate.data[i * 4 + c]).abs());
            }
        }
    }
    eprintln!("medium absent on {absent} px: max |out − plate| = {worst}");
    assert!(absent > n / 10 && absent < n - n / 10, "{absent} of {n}");
    assert_eq!(worst, 0.0);

    // 3. In-scatter stops at the crate: with the plate's depth the crate's pixels get less
    //    in-scatter than the same rays run through to the glTF's geometry behind it.
    g.disconnect("scatter", "depth");
    g.connect(cat, "gbuffer.depth", "scatter.depth").unwrap();
    let unbounded = eval(&gpu, &g, &[("scatter", "inscatter")]).remove(0);
    let (mut less, mut crate_lit) = (0, 0);
    for i in (0..n).filter(|i| bound_d.data[*i] < 0.9 * scene_d.data[*i]) {
        let (a, b) = (inscatter.data[i * 4], unbounded.data[i * 4]);
        assert!(
            a <= b * (1.0 + 1e-5) + 1e-7,
            "pixel {i}: bounded {a} > unbounded {b}"
        );
        less += (a < 0.9 * b) as usize;
        crate_lit += (b > 0.0) as usize;
    }
    eprintln!("crate pixels: {less} of {crate_lit} with in-scatter get < 90 % of it");
    assert!(
        crate_lit > 100 && less * 2 > crate_lit,
        "{less} of {crate_lit}"
    );
    // Elsewhere the plate's depth changes nothing.
    let same = (0..n)
        .filter(|i| mask.data[*i] == 0.0)
        .all(|i| inscatter.data[i * 4] == unbounded.data[i * 4]);
    assert!(same, "pixels without plate-only geometry changed");
}

#[test]
fn plate_nodes_match_their_cpu_references() {
    let Some(gpu) = common::gpu() else { return };
    let (w, h) = (37, 23);
    let mut plate_z = common::random_raster(19, 11, 1, 0.5, 30.0, 1);
    plate_z.data[3] = 1e10; // background
    plate_z.data[5] = f32::INFINITY;
    let scene_z = common::random_raster(w, h, 1, 1.0, 25.0, 2);
    let cam = tyndall::eval::Matrices::of_camera(
        &tyndall::scene::Camera {
            position: glam::Vec3::new(1.0, 2.0, 6.0),
            target: glam::Vec3::new(0.0, 1.0, 0.0),
            fov_y: 55.0,
            near: 0.1,
            far: 100.0,
        },
        w,
        h,
    );
    for convention in ["planar", "distance"] {
        let depth = tyndall::eval::PortValue::Depth(
            Arc::new(gpu.upload(w, h, 1, &scene_z.data).unwrap()),
            cam,
        );
        let pz = common::upload(&gpu, &plate_z, tyndall::graph::PortType::Scalar);
        let out = common::run_node(
            &gpu,
            "PlateDepth",
            &[("convention", ParamValue::Enum(convention.into()))],
            vec![("depth", depth), ("plate_depth", pz)],
            &["depth", "mask"],
            (w, h),
        )
        .unwrap();
        let out = [out["depth"].clone(), out["mask"].clone()];
        let conv = if convention == "planar" {
            tyndall::nodes::plate::Convention::Planar
        } else {
            tyndall::nodes::plate::Convention::Distance
        };
        let (d, m) =
            tyndall::nodes::plate::depth_reference(&scene_z, &cam, &plate_z, conv, 1.0, 0.01);
        // f32 ray directions: the GPU's normalize and matrix products differ from glam's by
        // a few ULP, ~1e-6 relative on distances of ~30 m.
        let err = common::max_abs_diff(&out[0], &d);
        assert!(err < 1e-4, "{convention}: depth {err}");
        assert_eq!(out[1].data, m.data, "{convention}: mask");
        assert!(m.data.contains(&1.0) && m.data.contains(&0.0));
    }
    let plate = common::random_raster(w, h, 4, 0.0, 2.0, 3);
    let ins = common::random_raster(13, 9, 4, 0.0, 0.5, 4);
    let tr = common::random_raster(13, 9, 1, 0.0, 1.0, 5);
    let out = common::run_node(
        &gpu,
        "PlateOver",
        &[],
        vec![
            (
                "plate",
                common::upload(&gpu, &plate, tyndall::graph::PortType::Image),
            ),
            (
                "inscatter",
                common::upload(&gpu, &ins, tyndall::graph::PortType::Image),
            ),
            (
                "transmittance",
                common::upload(&gpu, &tr, tyndall::graph::PortType::Scalar),
            ),
        ],
        &["image"],
        (w, h),
    )
    .unwrap()
    .remove("image")
    .unwrap();
    let want = tyndall::nodes::plate::over_reference(&plate, Some(&ins), Some(&tr));
    // Bilinear weights in f32 on both sides, same formula: a few ULP of values ≤ 2.5.
    let err = common::max_abs_diff(&out, &want);
    assert!(err < 1e-5, "over {err}");
}

#[test]
fn a_missing_layer_names_the_layers_there_are() {
    let Some(gpu) = common::gpu() else { return };
    let registry = tyndall::nodes::registry();
    let mut g = load(&registry);
    g.set_param(
        registry.catalog(),
        "plate",
        "layer",
        ParamValue::Text("ViewLayer.Shafts".into()),
    )
    .unwrap();
    let r = Evaluator::new(Arc::new(tyndall::nodes::registry()), gpu.clone()).evaluate(
        &g,
        &[Target::Port("plate".into(), "image".into())],
        &EvalOptions::default(),
    );
    let e = r.expect_err("a missing layer").to_string();
    assert!(
        e.contains("plate")
            && e.contains("no layer or channel 'ViewLayer.Shafts'")
            && e.contains("ViewLayer.Combined, ViewLayer.Depth"),
        "{e}"
    );
}

#[test]
fn image_input_depth_carries_the_exr_headers_camera() {
    let Some(gpu) = common::gpu() else { return };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plate.exr");
    let (w, h) = (8u32, 6u32);
    let cam = tyndall::eval::Matrices::of_camera(
        &tyndall::scene::Camera {
            position: glam::Vec3::new(2.0, 1.5, 7.0),
            target: glam::Vec3::new(0.0, 1.0, 0.0),
            fov_y: 40.0,
            near: 0.1,
            far: 200.0,
        },
        w,
        h,
    );
    let z: Vec<f32> = (0..w * h).map(|i| 3.0 + i as f32 * 0.1).collect();
    tyndall::io::write_exr_layers(
        &path,
        (w, h),
        &[tyndall::io::ExrLayer {
            name: "ViewLayer.Depth".into(),
            channels: vec![("Z".into(), z.clone())],
            half: false,
        }],
        &tyndall::io::ExrHeader {
            world_to_camera: Some(glam::Mat4::from_cols_array_2d(&cam.view).to_cols_array()),
            world_to_ndc: Some(cam.view_proj().to_cols_array()),
            ..Default::default()
        },
    )
    .unwrap();
    let out = common::run_node(
        &gpu,
        "ImageInput",
        &[
            ("path", ParamValue::Text(path.display().to_string())),
            ("layer", ParamValue::Text("ViewLayer.Depth".into())),
        ],
        vec![],
        &["depth"],
        (w, h),
    )
    .unwrap();
    assert_eq!(out["depth"].data, z);
    let registry = Arc::new(tyndall::nodes::registry());
    let mut g = Graph::new();
    let id = g.add_node(registry.catalog(), "ImageInput").unwrap();
    g.set_param(
        registry.catalog(),
        &id,
        "path",
        ParamValue::Text(path.display().to_string()),
    )
    .unwrap();
    g.set_param(
        registry.catalog(),
        &id,
        "layer",
        ParamValue::Text("ViewLayer.Depth.Z".into()),
    )
    .unwrap();
    let r = Evaluator::new(registry, gpu.clone())
        .evaluate(
            &g,
            &[Target::Port(id.clone(), "depth".into())],
            &EvalOptions::default(),
        )
        .unwrap();
    let tyndall::eval::PortValue::Depth(_, m) = &r.outputs[&(id.clone(), "depth".to_string())]
    else {
        panic!("not a depth")
    };
    // The header's view and projection come back (f32 inverse: ~1e-6 relative).
    let (a, b) = (m.view_proj(), cam.view_proj());
    let err = (a - b)
        .to_cols_array()
        .iter()
        .fold(0.0f32, |e, v| e.max(v.abs()));
    assert!(err < 1e-4, "view-projection differs by {err}");
    assert!((m.eye() - glam::Vec3::new(2.0, 1.5, 7.0)).length() < 1e-4);
    assert_eq!(m.far, *z.last().unwrap(), "far = the largest depth");
}
