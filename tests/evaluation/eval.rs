//! The evaluator: only what outputs need runs, only what changed re-runs, the cache is bounded.

use crate::common;
use std::sync::Arc;

use tyndall::eval::{EvalOptions, Evaluator, Status, Target};
use tyndall::graph::{load_str, Graph, Interp, Key, ParamValue};

/// Two independent branches (see `common::two_branches_ron`).
fn two_branches(dir: &std::path::Path) -> Graph {
    load_str(
        &common::two_branches_ron(dir),
        std::path::Path::new("two.ron"),
        tyndall::nodes::registry().catalog(),
    )
    .expect("graph")
}

fn evaluator(gpu: Arc<tyndall::gpu::Gpu>) -> Evaluator {
    Evaluator::new(Arc::new(tyndall::nodes::registry()), gpu)
}

#[test]
fn only_changed_node_and_downstream_rerun() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let mut g = two_branches(dir.path());
    let mut ev = evaluator(gpu);
    let cat = ev.registry().catalog().clone();
    let sinks = ev.sinks(&g);
    assert_eq!(sinks.len(), 2);
    let opts = EvalOptions::default();
    let first = ev.evaluate(&g, &sinks, &opts).expect("first");
    assert_eq!(
        first.stats.with_status(Status::Ran).len(),
        6,
        "{}",
        first.stats
    );
    assert!(dir.path().join("one.exr").exists() && dir.path().join("two.exr").exists());

    let again = ev.evaluate(&g, &sinks, &opts).expect("again");
    assert_eq!(
        again.stats.with_status(Status::Reused).len(),
        6,
        "{}",
        again.stats
    );

    g.set_param(&cat, "m1", "b", ParamValue::Float(4.0))
        .expect("set");
    let third = ev.evaluate(&g, &sinks, &opts).expect("third");
    let mut ran = third.stats.with_status(Status::Ran);
    ran.sort();
    assert_eq!(ran, vec!["m1", "out1"], "{}", third.stats);
    let mut reused = third.stats.with_status(Status::Reused);
    reused.sort();
    assert_eq!(reused, vec!["c1", "c2", "out2", "r2"], "{}", third.stats);
    let one = tyndall::io::read_image(&dir.path().join("one.exr"), false).expect("read");
    assert!(one.data.iter().all(|v| *v == 8.0), "m1 = 2 · 4");
}

/// A node keyed on the parts of the scene it reads: a sun change re-runs the shadow map, not the
/// G-buffer (camera and geometry); a camera change the reverse; other geometry (another built-in
/// scene) both. The scene node re-runs each time, and uploads its meshes again only for other
/// geometry.
#[test]
fn a_sun_change_leaves_the_g_buffer_reused() {
    let gpu = require_gpu!();
    let cat = tyndall::nodes::registry().catalog().clone();
    let mut g = load_str(
        r#"(version: 3, nodes: {
            "scene": (kind: "Scene", params: {"light": "custom", "camera": "custom"}),
            "gb": (kind: "GBuffer"),
            "sm": (kind: "ShadowMap"),
        }, edges: [("scene.scene", "gb.scene"), ("scene.scene", "sm.scene")])"#,
        std::path::Path::new("g.ron"),
        &cat,
    )
    .expect("graph");
    let mut ev = evaluator(gpu);
    let targets = [
        Target::Port("gb".into(), "depth".into()),
        Target::Port("sm".into(), "map".into()),
        Target::Port("scene".into(), "scene".into()),
    ];
    let opts = EvalOptions {
        size: (64, 36),
        ..Default::default()
    };
    let mut step = |g: &Graph, ran: &[&str], reused: &[&str], meshes_reused: bool| {
        let r = ev.evaluate(g, &targets, &opts).expect("evaluate");
        let scene = r.outputs[&("scene".to_string(), "scene".to_string())]
            .payload::<tyndall::scene::GpuScene>()
            .expect("scene");
        assert_eq!(scene.geometry_reused, meshes_reused, "{}", r.stats);
        for id in ran {
            assert_eq!(r.stats.status(id), Some(Status::Ran), "{id}: {}", r.stats);
        }
        for id in reused {
            assert_eq!(
                r.stats.status(id),
                Some(Status::Reused),
                "{id}: {}",
                r.stats
            );
        }
    };
    step(&g, &["scene", "gb", "sm"], &[], false);
    g.set_param(&cat, "scene", "sun_elevation", ParamValue::Float(20.0))
        .expect("sun");
    step(&g, &["scene", "sm"], &["gb"], true);
    g.set_param(&cat, "scene", "cam_x", ParamValue::Float(5.0))
        .expect("camera");
    step(&g, &["scene", "gb"], &["sm"], true);
    g.set_param(&cat, "scene", "name", ParamValue::Enum("tree".into()))
        .expect("geometry");
    step(&g, &["scene", "gb", "sm"], &[], false);
}

#[test]
fn output_paths_do_not_invalidate_but_are_still_written() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let g = two_branches(dir.path());
    let mut ev = evaluator(gpu);
    let sinks = ev.sinks(&g);
    ev.evaluate(&g, &sinks, &EvalOptions::default())
        .expect("first");
    let opts = EvalOptions {
        output_suffix: "_w2".into(),
        ..Default::default()
    };
    let second = ev.evaluate(&g, &sinks, &opts).expect("suffixed");
    assert_eq!(
        second.stats.with_status(Status::Ran).len(),
        0,
        "{}",
        second.stats
    );
    assert!(dir.path().join("one_w2.exr").exists() && dir.path().join("two_w2.exr").exists());
}

#[test]
fn nodes_no_output_needs_never_run() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let g = two_branches(dir.path());
    let mut ev = evaluator(gpu);
    let r = ev
        .evaluate(
            &g,
            &[Target::Port("m1".into(), "out".into())],
            &EvalOptions::default(),
        )
        .expect("eval");
    let mut not_needed = r.stats.with_status(Status::NotNeeded);
    not_needed.sort();
    assert_eq!(not_needed, vec!["c2", "out1", "out2", "r2"], "{}", r.stats);
    assert!(
        !dir.path().join("one.exr").exists(),
        "a sink ran without being requested"
    );
    assert!(r
        .outputs
        .contains_key(&("m1".to_string(), "out".to_string())));
}

#[test]
fn a_node_computes_only_wanted_outputs() {
    let gpu = require_gpu!();
    let cat = tyndall::nodes::registry().catalog().clone();
    let mut g = Graph::new();
    let c = g.add_node(&cat, "Constant").expect("add");
    let mut ev = evaluator(gpu);
    let opts = EvalOptions {
        size: (4, 4),
        ..Default::default()
    };
    let r = ev
        .evaluate(&g, &[Target::Port(c.clone(), "value".into())], &opts)
        .expect("value");
    assert_eq!(r.stats.status(&c), Some(Status::Ran));
    assert_eq!(
        ev.cached_bytes(),
        4 * 4 * 4,
        "only the Scalar output was computed"
    );
    let r = ev
        .evaluate(&g, &[Target::Port(c.clone(), "value".into())], &opts)
        .expect("value");
    assert_eq!(r.stats.status(&c), Some(Status::Reused));
    let r = ev
        .evaluate(&g, &[Target::Port(c.clone(), "colour".into())], &opts)
        .expect("colour");
    assert_eq!(
        r.stats.status(&c),
        Some(Status::Ran),
        "colour was not computed before"
    );
}

#[test]
fn key_frames_drive_reevaluation_by_time() {
    let gpu = require_gpu!();
    let cat = tyndall::nodes::registry().catalog().clone();
    let mut g = Graph::new();
    let c = g.add_node(&cat, "Constant").expect("add");
    let m = g.add_node(&cat, "Math").expect("add");
    g.connect(&cat, &format!("{c}.value"), &format!("{m}.a"))
        .expect("edge");
    g.set_keys(
        &cat,
        &m,
        "b",
        vec![
            Key {
                t: 0.0,
                v: 1.0,
                interp: Interp::Hold,
            },
            Key {
                t: 10.0,
                v: 5.0,
                interp: Interp::Linear,
            },
        ],
    )
    .expect("keys");
    g.set_param(&cat, &c, "value", ParamValue::Float(2.0))
        .expect("set");
    let mut ev = evaluator(gpu.clone());
    let target = [Target::Port(m.clone(), "out".into())];
    let at = |t: f64| EvalOptions {
        time: t,
        size: (2, 2),
        ..Default::default()
    };
    let r0 = ev.evaluate(&g, &target, &at(0.0)).expect("t0");
    let v0 = tyndall::eval::download(&gpu.recorder(), &r0.outputs[&(m.clone(), "out".into())])
        .expect("dl");
    assert_eq!(v0.data[0], 3.0);
    let r1 = ev.evaluate(&g, &target, &at(5.0)).expect("t5");
    assert_eq!(
        r1.stats.status(&m),
        Some(Status::Reused),
        "Hold keeps b = 1 until t = 10"
    );
    assert_eq!(r1.stats.status(&c), Some(Status::Reused));
    let r2 = ev.evaluate(&g, &target, &at(12.0)).expect("t12");
    assert_eq!(r2.stats.status(&m), Some(Status::Ran));
    let v2 = tyndall::eval::download(&gpu.recorder(), &r2.outputs[&(m.clone(), "out".into())])
        .expect("dl");
    assert_eq!(v2.data[0], 7.0);
}

#[test]
fn cache_respects_its_memory_budget() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let g = two_branches(dir.path());
    let mut ev = evaluator(gpu);
    ev.evaluate(
        &g,
        &[Target::Port("m1".into(), "out".into())],
        &EvalOptions::default(),
    )
    .expect("a");
    assert_eq!(ev.cached_nodes(), 2);
    ev.set_budget(0);
    // The latest evaluation's results are kept; older ones are evicted past the budget.
    let r = ev
        .evaluate(
            &g,
            &[Target::Port("r2".into(), "out".into())],
            &EvalOptions::default(),
        )
        .expect("b");
    assert_eq!(ev.cached_nodes(), 2, "c2 and r2 only");
    let r2 = ev
        .evaluate(
            &g,
            &[Target::Port("m1".into(), "out".into())],
            &EvalOptions::default(),
        )
        .expect("c");
    assert_eq!(
        r2.stats.status("m1"),
        Some(Status::Ran),
        "m1 was evicted, so it runs again"
    );
    drop(r);
    ev.set_budget(usize::MAX);
    ev.evaluate(&g, &ev.sinks(&g), &EvalOptions::default())
        .expect("d");
    assert_eq!(ev.cached_nodes(), 6);
    assert!(ev.cached_bytes() > 0);
}

#[test]
fn input_file_changes_rerun_image_input() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("in.exr");
    tyndall::io::write_image(
        &path,
        &tyndall::io::Raster::new(3, 2, 1, 1.0),
        tyndall::io::Precision::F32,
        false,
    )
    .expect("w");
    let cat = tyndall::nodes::registry().catalog().clone();
    let mut g = Graph::new();
    let i = g.add_node(&cat, "ImageInput").expect("add");
    g.set_param(
        &cat,
        &i,
        "path",
        ParamValue::Text(path.display().to_string()),
    )
    .expect("p");
    let mut ev = evaluator(gpu);
    let t = [Target::Port(i.clone(), "scalar".into())];
    ev.evaluate(&g, &t, &EvalOptions::default()).expect("1");
    assert_eq!(
        ev.evaluate(&g, &t, &EvalOptions::default())
            .expect("2")
            .stats
            .status(&i),
        Some(Status::Reused)
    );
    tyndall::io::write_image(
        &path,
        &tyndall::io::Raster::new(4, 2, 1, 2.0),
        tyndall::io::Precision::F32,
        false,
    )
    .expect("w");
    assert_eq!(
        ev.evaluate(&g, &t, &EvalOptions::default())
            .expect("3")
            .stats
            .status(&i),
        Some(Status::Ran)
    );
}

#[test]
fn evaluation_errors_name_node_and_parameter() {
    let gpu = require_gpu!();
    let cat = tyndall::nodes::registry().catalog().clone();
    let mut g = Graph::new();
    let c = g.add_node(&cat, "Constant").expect("add");
    let o = g.add_node(&cat, "ImageOutput").expect("add");
    g.connect(&cat, &format!("{c}.colour"), &format!("{o}.image"))
        .expect("edge");
    g.set_param(&cat, &o, "path", ParamValue::Text("".into()))
        .expect("p");
    let mut ev = evaluator(gpu);
    let err = ev
        .evaluate(
            &g,
            &ev.sinks(&g),
            &EvalOptions {
                size: (2, 2),
                ..Default::default()
            },
        )
        .expect_err("empty path");
    assert!(
        err.to_string()
            .contains("node 'imageoutput1' (ImageOutput): parameter 'path'"),
        "{err}"
    );
    let err = ev
        .evaluate(
            &g,
            &[Target::Port(c.clone(), "nope".into())],
            &EvalOptions::default(),
        )
        .expect_err("port");
    assert!(err.to_string().contains("no output port 'nope'"), "{err}");
}

#[test]
fn gpu_timings_come_from_timestamp_queries_when_asked() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let g = two_branches(dir.path());
    let mut ev = evaluator(gpu.clone());
    let target = [Target::Port("m1".into(), "out".into())];
    let plain = ev
        .evaluate(&g, &target, &EvalOptions::default())
        .expect("plain");
    assert!(
        plain.stats.nodes.iter().all(|n| n.gpu_time.is_none()),
        "timings are off by default"
    );
    ev.clear();
    let timed = ev
        .evaluate(
            &g,
            &target,
            &EvalOptions {
                gpu_timings: true,
                ..Default::default()
            },
        )
        .expect("timed");
    let m1 = timed.stats.nodes.iter().find(|n| n.id == "m1").expect("m1");
    if gpu
        .device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY)
    {
        let t = m1.gpu_time.expect("gpu time");
        assert!(
            t <= m1.time,
            "GPU time {t:?} exceeds the wall time {:?}",
            m1.time
        );
    } else {
        assert!(m1.gpu_time.is_none());
    }
}

/// With `gpu_timings` and `pipelined` (`tyndall eval --stats`), nothing waits between nodes: the
/// passes are submitted in chunks, not per node, and every node that ran still gets its GPU
/// time — its passes' timestamps, read once at the end (the scattering's is not zero).
#[test]
fn pipelined_gpu_timings_are_read_once_per_evaluation() {
    let gpu = require_gpu!();
    if !gpu
        .device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY)
    {
        return;
    }
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let g = tyndall::graph::load_file(&path, registry.catalog()).expect("graph");
    let mut ev = tyndall::eval::Evaluator::new(registry, gpu.clone());
    let r = ev
        .evaluate(
            &g,
            &[Target::Port("tonemap".into(), "out".into())],
            &EvalOptions {
                size: (64, 36),
                gpu_timings: true,
                pipelined: true,
                ..Default::default()
            },
        )
        .expect("evaluate");
    let submits = r.stats.submits;
    let ran: Vec<_> = r.stats.nodes.iter().filter(|n| n.status.ran()).collect();
    assert!(ran.len() >= 5, "{}", r.stats);
    assert!(
        ran.iter().all(|n| n.gpu_time.is_some()),
        "every node that ran has a GPU time: {}",
        r.stats
    );
    let scatter = ran.iter().find(|n| n.id == "scatter").expect("scatter");
    assert!(scatter
        .gpu_time
        .is_some_and(|t| t > std::time::Duration::ZERO));
    if gpu.info.backend != wgpu::Backend::Gl {
        assert!(
            (submits as usize) < ran.len(),
            "{submits} submissions for {} nodes: one per node or more",
            ran.len()
        );
    }
}

/// A document checked against another catalog (a newer Tyndall's, a hand-built one) can carry an
/// enum value this registry does not know. The loader refuses such files, but nothing stops a
/// `Graph` built in code: the node must then fail with an error naming the node and the
/// parameter — never fall back silently to the first option.
#[test]
fn unknown_choice_is_an_error_naming_node_and_parameter() {
    use tyndall::graph::{Catalog, NodeSchema, ParamSpec, PortSpec, PortType};
    let gpu = require_gpu!();
    let registry = tyndall::nodes::registry();
    let real = registry.catalog().get("Tonemap").expect("Tonemap");
    static OPS: &[&str] = &["filmic", "reinhard", "linear", "agx"];
    static IMG: &[PortType] = &[PortType::Image];
    static INPUTS: &[PortSpec] = &[PortSpec::required("image", IMG, "")];
    static OUTPUTS: &[PortSpec] = &[PortSpec::output("out", IMG, "")];
    static PARAMS: &[ParamSpec] = &[
        ParamSpec::float("exposure", 0.0, -20.0, 20.0, "stops", ""),
        ParamSpec::choice("operator", OPS, "agx", ""),
    ];
    static NEWER: NodeSchema = NodeSchema {
        kind: "Tonemap",
        category: "Image",
        doc: "",
        inputs: INPUTS,
        outputs: OUTPUTS,
        params: PARAMS,
    };
    assert_eq!(real.params.len(), NEWER.params.len());
    let mut newer = Catalog::new();
    newer.add(&NEWER);
    let mut g = Graph::new();
    let id = g.add_node(&newer, "Tonemap").expect("add");
    g.set_param(&newer, &id, "operator", ParamValue::Enum("agx".into()))
        .expect("valid in the newer catalog");
    let mut opts = EvalOptions {
        size: (4, 4),
        ..Default::default()
    };
    let image = common::upload(
        &gpu,
        &tyndall::io::Raster::new(4, 4, 4, 0.5),
        tyndall::graph::PortType::Image,
    );
    opts.inject.insert((id.clone(), "image".into()), (image, 1));
    let mut ev = Evaluator::new(Arc::new(registry), gpu);
    let err = ev
        .evaluate(&g, &[Target::Port(id.clone(), "out".into())], &opts)
        .expect_err("an unknown operator must not evaluate");
    let msg = err.to_string();
    for part in [
        id.as_str(),
        "Tonemap",
        "operator",
        "agx",
        "filmic, reinhard, linear",
    ] {
        assert!(msg.contains(part), "'{part}' missing from: {msg}");
    }
}

/// A texture side beyond the adapter's limit fails naming the parameter and the limit (every
/// node with a resolution parameter reads it through `RunCtx::side`); lavapipe's limits
/// are above every parameter's range, so the check itself is tested here.
#[test]
fn texture_sides_beyond_the_limit_name_the_parameter_and_the_limit() {
    use tyndall::eval::{check_side, NodeError};
    assert_eq!(check_side("resolution", 2048, 8192, 2).expect("fits"), 2048);
    for bad in [8193, 0, -1, i64::MAX] {
        match check_side("resolution", bad, 8192, 2) {
            Err(NodeError::Param { param, message }) => {
                assert_eq!(param, "resolution");
                assert!(
                    message.contains("8192") && message.contains("2D"),
                    "{message}"
                );
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
    let e = check_side("slices", 4096, 2048, 3).expect_err("3D");
    assert!(e.to_string().contains("max_texture_dimension_3d"), "{e}");
}

/// Files named inside a data block (a transfer function's image layers, in the stack and in its
/// key-frames) resolve against the graph's folder like file parameters; absolute paths and
/// the other layers are left as they are.
#[test]
fn image_layers_in_a_data_block_resolve_against_the_graph_folder() {
    let registry = tyndall::nodes::registry();
    let text = r#"(
    version: 2,
    nodes: {
        "tf": (kind: "TransferFunction", data: (
            layers: [
                (layer: Image(path: "looks/tf.png")),
                (layer: Image(path: "/abs/tf.png")),
                (layer: Solid(colour: (1.0, 0.0, 0.0, 1.0))),
            ],
            keys: [(t: 0.0, layers: [(layer: Image(path: "k.png"))])],
        )),
    },
    edges: [],
)"#;
    let g = load_str(text, std::path::Path::new("g.ron"), registry.catalog()).expect("graph");
    let policy = tyndall::eval::PathPolicy {
        graph_dir: std::path::PathBuf::from("/shots/s1"),
        output_dir: std::path::PathBuf::from("."),
        allow_any: false,
    };
    let resolved = tyndall::eval::resolve_files(&registry, &g, &policy).expect("resolved");
    let data = resolved
        .node("tf")
        .and_then(|n| n.data.as_ref())
        .expect("data");
    let tf: tyndall::nodes::transfer_function::TfData = data.parse().expect("parse");
    let paths: Vec<String> = tf
        .layers
        .iter()
        .chain(tf.keys.iter().flat_map(|k| &k.layers))
        .filter_map(|e| match &e.layer {
            tyndall::nodes::transfer_function::Layer::Image { path } => Some(path.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(
        paths,
        ["/shots/s1/looks/tf.png", "/abs/tf.png", "/shots/s1/k.png"]
    );
    assert_eq!(tf.layers.len(), 3, "the solid layer is kept");
}

/// A chain of `n` Math nodes after a Constant (as `scripts/make_chain.py` writes).
fn chain(n: usize) -> Graph {
    let mut text =
        String::from("(version: 3, nodes: {\"c\": (kind: \"Constant\", params: {\"value\": 0.5}),");
    for i in 0..n {
        text += &format!("\"m{i}\": (kind: \"Math\", params: {{\"op\": \"add\", \"b\": 0.25}}),");
    }
    text += "}, edges: [";
    let mut prev = "c.value".to_string();
    for i in 0..n {
        text += &format!("(\"{prev}\", \"m{i}.a\"),");
        prev = format!("m{i}.out");
    }
    text += "])";
    load_str(
        &text,
        std::path::Path::new("chain.ron"),
        tyndall::nodes::registry().catalog(),
    )
    .expect("chain")
}

#[test]
fn pipelined_evaluation_gives_the_same_values() {
    let gpu = require_gpu!();
    let g = chain(40);
    let target = [Target::Port("m39".into(), "out".into())];
    let mut values = Vec::new();
    for pipelined in [false, true] {
        let opts = EvalOptions {
            size: (8, 4),
            pipelined,
            ..Default::default()
        };
        let r = evaluator(gpu.clone())
            .evaluate(&g, &target, &opts)
            .expect("eval");
        let v = tyndall::eval::download(&gpu.recorder(), &r.outputs[&("m39".into(), "out".into())])
            .expect("download");
        values.push(v.data);
    }
    // 0.5 + 40 × 0.25, exactly representable: both ways.
    assert!(
        values[0].iter().all(|v| *v == 10.5),
        "{:?}",
        &values[0][..4]
    );
    assert_eq!(values[0], values[1]);
}

#[test]
fn a_cancelled_evaluation_stops_between_nodes_and_keeps_what_ran() {
    let gpu = require_gpu!();
    let g = chain(10);
    let target = [Target::Port("m9".into(), "out".into())];
    let mut ev = evaluator(gpu);
    // Stop before the sixth node: c, m0…m3 ran.
    let asked = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let count = asked.clone();
    let opts = EvalOptions {
        size: (4, 4),
        cancel: Some(tyndall::eval::CancelCheck(Arc::new(move || {
            count.fetch_add(1, std::sync::atomic::Ordering::SeqCst) >= 5
        }))),
        ..Default::default()
    };
    match ev.evaluate(&g, &target, &opts) {
        Err(tyndall::eval::EvalError::Cancelled { before }) => assert_eq!(before, "m4"),
        other => panic!("expected a cancellation, got {other:?}"),
    }
    // The nodes that ran are reused by the next (uncancelled) evaluation.
    let opts = EvalOptions {
        size: (4, 4),
        ..Default::default()
    };
    let r = ev.evaluate(&g, &target, &opts).expect("eval");
    assert_eq!(r.stats.with_status(Status::Reused).len(), 5, "{}", r.stats);
    assert_eq!(r.stats.with_status(Status::Ran).len(), 6, "{}", r.stats);
}

#[test]
fn proxy_copies_divide_screen_pixel_knobs_and_nothing_else() {
    use tyndall::eval::proxy::{proxy_graph, proxy_size};
    let reg = tyndall::nodes::registry();
    let cat = reg.catalog();
    let mut g = Graph::new();
    let bf = g.add_node(cat, "BilateralFilter").expect("node");
    let gb = g.add_node(cat, "GBuffer").expect("node");
    let rb = g.add_node(cat, "RadialBlur").expect("node");
    g.set_param(cat, &gb, "width", ParamValue::Int(3))
        .expect("w");
    let keys = vec![
        Key {
            t: 0.0,
            v: 8.0,
            interp: Interp::Linear,
        },
        Key {
            t: 10.0,
            v: 16.0,
            interp: Interp::Linear,
        },
    ];
    g.set_keys(cat, &bf, "sigma_spatial", keys).expect("keys");
    let p = proxy_graph(&g, cat, 4);
    let at = |g: &Graph, id: &str, name: &str, t: f64| g.param_at(cat, id, name, t).expect(name);
    // Key-frames scale with the value: 8 → 2 at t 0, 12 → 3 at t 5.
    assert_eq!(at(&p, &bf, "sigma_spatial", 0.0), ParamValue::Float(2.0));
    assert_eq!(at(&p, &bf, "sigma_spatial", 5.0), ParamValue::Float(3.0));
    // An integer size stays at least 1; 0 ("the evaluation size") stays 0.
    assert_eq!(at(&p, &gb, "width", 0.0), ParamValue::Int(1));
    assert_eq!(at(&p, &gb, "height", 0.0), ParamValue::Int(0));
    // A default in pixels is divided too (the light position 480, 100 → 120, 25).
    assert_eq!(at(&p, &rb, "light_x", 0.0), ParamValue::Float(120.0));
    assert_eq!(at(&p, &rb, "light_y", 0.0), ParamValue::Float(25.0));
    // Other units are left alone (the filter's range σ and taps, the blur's sample count).
    for (id, name) in [(&bf, "sigma_range"), (&bf, "radius"), (&rb, "samples")] {
        assert_eq!(at(&p, id, name, 0.0), at(&g, id, name, 0.0), "{name}");
    }
    // Factor 1 is the document itself; sizes never reach 0.
    assert_eq!(save_string_of(&proxy_graph(&g, cat, 1)), save_string_of(&g));
    assert_eq!(proxy_size((960, 540), 4), (240, 135));
    assert_eq!(proxy_size((3, 2), 8), (1, 1));
}

#[test]
fn proxy_copies_divide_light_space_sizes_and_reduce_input_files() {
    use tyndall::eval::proxy::proxy_graph;
    let reg = tyndall::nodes::registry();
    let cat = reg.catalog();
    let mut g = Graph::new();
    let sm = g.add_node(cat, "ShadowMap").expect("node");
    let close = g.add_node(cat, "Closure2D").expect("node");
    let metres = g.add_node(cat, "Closure2D").expect("node");
    let tf = g.add_node(cat, "TransferFunction").expect("node");
    let solve = g.add_node(cat, "LightMapSolve").expect("node");
    let plate = g.add_node(cat, "ImageInput").expect("node");
    let blur = g.add_node(cat, "Blur").expect("node");
    g.set_param(cat, &blur, "sigma", ParamValue::Float(16.0))
        .expect("sigma");
    g.set_param(cat, &close, "radius", ParamValue::Float(12.0))
        .expect("r");
    g.set_param(cat, &metres, "radius", ParamValue::Float(12.0))
        .expect("r");
    g.set_param(cat, &metres, "unit", ParamValue::Enum("metres".into()))
        .expect("unit");
    let p = proxy_graph(&g, cat, 4);
    let at = |g: &Graph, id: &str, name: &str| g.param_at(cat, id, name, 0.0).expect(name);
    // The map (default 2048) and a radius in its texels follow the factor.
    assert_eq!(at(&p, &sm, "resolution"), ParamValue::Int(512));
    assert_eq!(at(&p, &close, "radius"), ParamValue::Float(3.0));
    // A blur's σ is in texels of its input, which shrinks with the proxy (picture or map).
    assert_eq!(at(&p, &blur, "sigma"), ParamValue::Float(4.0));
    // A file is read at ¼ (so a plate stays the size of the proxied pictures).
    assert_eq!(at(&p, &plate, "reduce"), ParamValue::Int(4));
    // A radius in metres, a table's size and a light map's (the solve's unknowns) do not.
    assert_eq!(at(&p, &metres, "radius"), ParamValue::Float(12.0));
    for (id, name) in [(&tf, "resolution"), (&solve, "resolution")] {
        assert_eq!(at(&p, id, name), at(&g, id, name), "{name}");
    }
}

fn save_string_of(g: &Graph) -> String {
    tyndall::graph::save_string(g)
}

/// Composite's `light_map` multiplies the sun on surfaces: with the ambient term off, the
/// picture through a constant coloured light map is the picture without it times the colour,
/// channel by channel, on every pixel (the sky colour set to black, as the sun does not light it).
#[test]
fn composite_light_map_colours_the_sunlit_surfaces() {
    let Some(gpu) = common::gpu() else { return };
    let reg = tyndall::nodes::registry();
    let text = r#"(version: 3, nodes: {
        "scene": (kind: "Scene", params: {"name": "window"}),
        "shadow": (kind: "ShadowMap", params: {"resolution": 512}),
        "gbuffer": (kind: "GBuffer"),
        "glass": (kind: "LightMap", params: {"colour": (1.0, 0.25, 0.5, 1.0)}),
        "plain": (kind: "Composite", params: {"ambient": (0.0, 0.0, 0.0, 1.0), "sky": (0.0, 0.0, 0.0, 1.0)}),
        "tinted": (kind: "Composite", params: {"ambient": (0.0, 0.0, 0.0, 1.0), "sky": (0.0, 0.0, 0.0, 1.0)}),
    }, edges: [
        ("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"),
        ("shadow.map", "glass.shadow"),
        ("gbuffer.albedo", "plain.albedo"), ("gbuffer.normal", "plain.normal"),
        ("gbuffer.depth", "plain.depth"), ("shadow.map", "plain.shadow"),
        ("gbuffer.albedo", "tinted.albedo"), ("gbuffer.normal", "tinted.normal"),
        ("gbuffer.depth", "tinted.depth"), ("shadow.map", "tinted.shadow"),
        ("glass.light_map", "tinted.light_map"),
    ])"#;
    let g = load_str(text, std::path::Path::new("g.ron"), reg.catalog()).expect("graph");
    let targets = [
        Target::Port("plain".into(), "image".into()),
        Target::Port("tinted".into(), "image".into()),
    ];
    let opts = EvalOptions {
        size: (64, 36),
        ..Default::default()
    };
    let r = evaluator(gpu.clone())
        .evaluate(&g, &targets, &opts)
        .expect("evaluate");
    let get = |n: &str| {
        tyndall::eval::download(
            &gpu.recorder(),
            &r.outputs[&(n.to_string(), "image".to_string())],
        )
        .expect("download")
    };
    let (plain, tinted) = (get("plain"), get("tinted"));
    let colour = [1.0f32, 0.25, 0.5];
    let mut lit = 0;
    for (p, t) in plain.data.chunks(4).zip(tinted.data.chunks(4)) {
        for c in 0..3 {
            // One multiplication more on the tinted side: within a few ULP.
            let want = p[c] * colour[c];
            assert!(
                (t[c] - want).abs() <= 4.0 * f32::EPSILON * want.abs() + 1e-7,
                "channel {c}: {} vs {want}",
                t[c]
            );
        }
        lit += (p[0] > 0.01) as usize;
    }
    assert!(lit > 0, "the sun lights some surfaces");
}

#[test]
fn a_knob_set_back_to_an_earlier_value_is_found_in_the_cache() {
    let gpu = require_gpu!();
    let dir = tempfile::tempdir().expect("tempdir");
    let mut g = two_branches(dir.path());
    let mut ev = evaluator(gpu);
    let cat = ev.registry().catalog().clone();
    let target = [Target::Port("m1".into(), "out".into())];
    let opts = EvalOptions::default();
    let status_at = |g: &mut Graph, ev: &mut Evaluator, b: f64| {
        g.set_param(&cat, "m1", "b", ParamValue::Float(b))
            .expect("set");
        let r = ev.evaluate(g, &target, &opts).expect("evaluate");
        r.stats.status("m1")
    };
    assert_eq!(status_at(&mut g, &mut ev, 2.0), Some(Status::Ran));
    assert_eq!(status_at(&mut g, &mut ev, 4.0), Some(Status::Ran));
    // Several keys per node: the first value's result is still there.
    assert_eq!(status_at(&mut g, &mut ev, 2.0), Some(Status::Reused));
    assert_eq!(ev.cached_nodes(), 2, "m1 and its source c1");
    // `keep_latest` keeps only what the latest evaluation used (b = 2).
    ev.keep_latest();
    assert_eq!(status_at(&mut g, &mut ev, 4.0), Some(Status::Ran));
    assert_eq!(status_at(&mut g, &mut ev, 2.0), Some(Status::Reused));
}
