//! Node groups: format v3 (v2 presets load unchanged and save stably), library groups (found
//! beside the graph, edited files followed at the next load), embedded copies, errors (a group
//! containing itself, a missing library group, a port-type mismatch across a group boundary),
//! and evaluation: a grouped preset renders bit-identically to its flat original and to its own
//! flattened graph, and a knob re-runs only the inner nodes it reaches and what is below.

use crate::common;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use tyndall::eval::{EvalOptions, Evaluator, Status, Target};
use tyndall::graph::{load_file, load_str, save_string, Graph, GraphError, ParamValue};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn registry() -> Arc<tyndall::eval::Registry> {
    Arc::new(tyndall::nodes::registry())
}

#[test]
fn every_preset_loads_into_v3_and_saves_stably() {
    let reg = registry();
    for f in common::presets() {
        let g = load_file(&f, reg.catalog()).unwrap_or_else(|e| panic!("{e}"));
        let once = save_string(&g);
        assert!(once.starts_with("(\n    version: 3,"), "{}", f.display());
        let back = load_str(&once, &f, reg.catalog()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back, g, "{}", f.display());
        assert_eq!(
            save_string(&back),
            once,
            "{}: save → load → save",
            f.display()
        );
    }
    // The flat v2 original loads too.
    let flat = root().join("tests/fixtures/flat/tree_hole_filling.ron");
    assert!(std::fs::read_to_string(&flat)
        .unwrap()
        .contains("version: 2"));
    load_file(&flat, reg.catalog()).expect("v2 loads");
}

/// A graph file loaded with its relative input paths (a glTF scene, a light map) resolved
/// against its own folder, as `tyndall render` resolves them.
fn load_resolved(path: &Path, reg: &tyndall::eval::Registry) -> Result<Graph, String> {
    let g = load_file(path, reg.catalog()).map_err(|e| e.to_string())?;
    let policy = tyndall::eval::PathPolicy {
        graph_dir: path.parent().expect("a file in a folder").to_path_buf(),
        output_dir: std::env::temp_dir(),
        allow_any: true,
    };
    tyndall::eval::resolve_files(reg, &g, &policy).map_err(|e| e.to_string())
}

/// The values on `ports` of `g` at a small size.
fn eval(g: &Graph, ports: &[(&str, &str)]) -> Vec<tyndall::io::Raster> {
    let gpu = common::gpu().expect("adapter");
    let targets: Vec<Target> = ports
        .iter()
        .map(|(n, p)| Target::Port(n.to_string(), p.to_string()))
        .collect();
    let opts = EvalOptions {
        size: (96, 54),
        ..Default::default()
    };
    let r = Evaluator::new(registry(), gpu.clone())
        .evaluate(g, &targets, &opts)
        .unwrap_or_else(|e| panic!("{e}"));
    ports
        .iter()
        .map(|(n, p)| {
            tyndall::eval::download(&gpu.recorder(), &r.outputs[&(n.to_string(), p.to_string())])
                .unwrap()
        })
        .collect()
}

#[test]
fn grouped_preset_renders_like_its_flat_original_and_its_flattened_graph() {
    if common::gpu().is_none() {
        return;
    }
    let reg = registry();
    let grouped =
        load_resolved(&root().join("graphs/stylize/tree_hole_filling.ron"), &reg).expect("grouped");
    assert!(grouped.has_group_nodes());
    let flat = load_resolved(
        &root().join("tests/fixtures/flat/tree_hole_filling.ron"),
        &reg,
    )
    .expect("flat");
    let a = eval(&grouped, &[("side", "image"), ("holes", "map")]);
    let b = eval(&flat, &[("side", "image"), ("close", "map")]);
    assert_eq!(a[0].data, b[0].data, "grouped vs hand-wired chain");
    assert_eq!(
        a[1].data, b[1].data,
        "a group's output port is its inner port"
    );
    assert!(a[0].data.iter().any(|v| *v > 0.0));
    // Its own flattened graph, saved and reloaded (what evaluation sees), gives the same bits.
    let flattened = grouped.flatten(reg.catalog()).unwrap();
    assert!(flattened.node("holes/shafts/scatter").is_some());
    let text = save_string(&flattened);
    let again = load_str(&text, Path::new("flat.ron"), reg.catalog()).unwrap();
    assert_eq!(eval(&again, &[("side", "image")])[0].data, a[0].data);
}

/// The port feeding sink `out`'s `image` in `g`.
fn out_source(g: &Graph) -> (String, String) {
    let e = g
        .edges()
        .into_iter()
        .find(|e| e.to_node == "out" && e.to_port == "image")
        .expect("an out.image edge");
    (e.from_node, e.from_port)
}

/// Every top-level `ShadowMap` of `g` at 256².
fn small_shadow_maps(g: &mut Graph) {
    let reg = registry();
    let ids: Vec<String> = g
        .nodes()
        .filter(|n| n.kind == "ShadowMap")
        .map(|n| n.id.clone())
        .collect();
    for id in ids {
        g.set_param(reg.catalog(), &id, "resolution", ParamValue::Int(256))
            .unwrap();
    }
}

/// Every preset rebuilt on library groups renders bit-identically to its flat original
/// (`tests/fixtures/flat/NAME.ron`, the preset before it used groups), and together they use
/// every library group of `graphs/lib`, so each library group is checked against its
/// hand-wired nodes.
#[test]
fn every_preset_rebuilt_on_groups_renders_like_its_flat_original() {
    if common::gpu().is_none() {
        return;
    }
    let reg = registry();
    let mut compared = 0;
    let mut used = std::collections::BTreeSet::new();
    for e in std::fs::read_dir(root().join("tests/fixtures/flat")).unwrap() {
        let flat_path = e.unwrap().path();
        let name = flat_path.file_name().unwrap().to_owned();
        let preset = common::presets()
            .into_iter()
            .find(|p| p.file_name() == Some(&name))
            .expect("the preset of a flat original");
        let mut grouped = load_resolved(&preset, &reg).unwrap();
        assert!(grouped.has_group_nodes(), "{}", preset.display());
        let mut defs: Vec<_> = grouped.groups().values().cloned().collect();
        while let Some(d) = defs.pop() {
            if let Some(l) = &d.library {
                used.insert(l.name.clone());
            }
            defs.extend(d.graph.groups().values().cloned());
        }
        let mut flat = load_resolved(&flat_path, &reg).unwrap();
        // The same smaller shadow maps on both sides (a 2048² closure takes seconds in a debug
        // build); the comparison is of the same graph either way.
        small_shadow_maps(&mut grouped);
        small_shadow_maps(&mut flat);
        let (gn, gp) = out_source(&grouped);
        let (fnode, fport) = out_source(&flat);
        let a = eval(&grouped, &[(&gn, &gp)]);
        let b = eval(&flat, &[(&fnode, &fport)]);
        assert_eq!(a[0].data, b[0].data, "{}", preset.display());
        assert!(
            a[0].data.iter().any(|v| *v > 0.0),
            "{}: a black picture compares equal to anything black",
            preset.display()
        );
        compared += 1;
    }
    assert!(compared >= 3, "{compared} presets compared");
    for (_, reference) in tyndall::graph::list_library(&[root().join("graphs/lib")]) {
        assert!(
            used.contains(&reference),
            "library group {reference} is used by no preset with a flat original"
        );
    }
}

#[test]
fn a_knob_reruns_only_what_it_reaches() {
    let Some(gpu) = common::gpu() else { return };
    let reg = registry();
    let mut g =
        load_resolved(&root().join("graphs/stylize/tree_hole_filling.ron"), &reg).expect("preset");
    let mut ev = Evaluator::new(reg.clone(), gpu);
    let opts = EvalOptions {
        size: (64, 36),
        ..Default::default()
    };
    let target = [Target::Port("side".into(), "image".into())];
    ev.evaluate(&g, &target, &opts).unwrap();
    g.set_param(reg.catalog(), "holes", "radius", ParamValue::Float(9.0))
        .unwrap();
    let r = ev.evaluate(&g, &target, &opts).unwrap();
    let mut ran = r.stats.with_status(Status::Ran);
    ran.sort();
    assert_eq!(
        ran,
        vec![
            "holes/close",
            "holes/shafts/composite",
            "holes/shafts/scatter",
            "holes/shafts/tonemap",
            "side"
        ],
        "{:?}",
        r.stats
            .nodes
            .iter()
            .map(|n| (&n.id, n.status))
            .collect::<Vec<_>>()
    );
    for id in [
        "scene",
        "shadow",
        "gbuffer",
        "physical/scatter",
        "physical/tonemap",
    ] {
        assert_eq!(r.stats.status(id), Some(Status::Reused), "{id}");
    }
}

/// A scratch preset library: `dir/graphs/lib/…` and a graph `dir/graphs/look.ron` using it.
fn scratch(dir: &Path, lib: &str, graph: &str) -> PathBuf {
    std::fs::create_dir_all(dir.join("graphs/lib")).unwrap();
    std::fs::write(dir.join("graphs/lib/grade.ron"), lib).unwrap();
    let g = dir.join("graphs/look.ron");
    std::fs::write(&g, graph).unwrap();
    g
}

const GRADE: &str = r#"(version: 3, group: (name: "Grade", version: 1, doc: "A grade.",
    inputs: {"in": (to: ["m.a"])},
    outputs: {"out": (from: "m.out")},
    knobs: {"gain": (to: ["m.b"], min: 0.0, max: 10.0, doc: "Gain.")},
    nodes: {"m": (kind: "Math", params: {"op": "mul", "b": 2.0})},
))"#;

const LOOK: &str = r#"(version: 3,
    nodes: {
        "c": (kind: "Constant", params: {"value": 1.5}),
        "g": (kind: "Grade"),
    },
    edges: [("c.value", "g.in")],
    groups: {"Grade": (library: "grade", version: 1)},
)"#;

#[test]
fn editing_a_library_group_changes_the_graph_at_its_next_load() {
    if common::gpu().is_none() {
        return;
    }
    let reg = registry();
    let dir = tempfile::tempdir().unwrap();
    let path = scratch(dir.path(), GRADE, LOOK);
    let g = load_file(&path, reg.catalog()).unwrap();
    let v = eval(&g, &[("g", "out")])[0].data[0];
    assert_eq!(v, 3.0, "1.5 × the knob's default 2");
    std::fs::write(
        dir.path().join("graphs/lib/grade.ron"),
        GRADE.replace("\"b\": 2.0", "\"b\": 4.0"),
    )
    .unwrap();
    let g = load_file(&path, reg.catalog()).unwrap();
    assert_eq!(
        eval(&g, &[("g", "out")])[0].data[0],
        6.0,
        "the edited library"
    );
    // --set on a knob.
    let mut g2 = g.clone();
    g2.set_param_text(reg.catalog(), "g", "gain", "3").unwrap();
    assert_eq!(eval(&g2, &[("g", "out")])[0].data[0], 4.5);
    let e = g2
        .set_param_text(reg.catalog(), "g", "gain", "30")
        .unwrap_err();
    assert!(e.to_string().contains("gain"), "{e}");
    // An embedded copy no longer follows the library, and saves stably.
    let mut copy = g.clone();
    copy.embed_group("Grade").unwrap();
    let text = save_string(&copy);
    assert!(
        text.contains("nodes: {") && !text.contains("library:"),
        "{text}"
    );
    std::fs::remove_file(dir.path().join("graphs/lib/grade.ron")).unwrap();
    let back = load_str(&text, &path, reg.catalog()).unwrap();
    assert_eq!(save_string(&back), text);
    assert_eq!(eval(&back, &[("g", "out")])[0].data[0], 6.0);
}

fn load_err(dir: &Path, lib: &str, graph: &str) -> GraphError {
    let reg = registry();
    let path = scratch(dir, lib, graph);
    load_file(&path, reg.catalog())
        .expect_err("must not load")
        .error
}

#[test]
fn bad_groups_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    // Missing library group.
    let e = load_err(
        dir.path(),
        GRADE,
        &LOOK.replace("library: \"grade\"", "library: \"nope\""),
    );
    let text = e.to_string();
    assert!(
        text.contains("library group 'nope@1' not found: no nope.ron in the library folders"),
        "{text}"
    );
    // Another version.
    let e = load_err(
        dir.path(),
        GRADE,
        &LOOK.replace("version: 1)", "version: 2)"),
    );
    assert!(
        e.to_string()
            .contains("is version 1, the graph wants version 2"),
        "{e}"
    );
    // A group containing itself through another.
    let cyclic = r#"(version: 3, nodes: {"a": (kind: "A")}, groups: {
        "A": (version: 1, outputs: {"out": (from: "b.out")}, nodes: {"b": (kind: "B")}),
        "B": (version: 1, outputs: {"out": (from: "a.out")}, nodes: {"a": (kind: "A")}),
    })"#;
    let e = load_err(dir.path(), GRADE, cyclic);
    assert!(
        matches!(&e, GraphError::GroupCycle { chain, .. } if chain == "A → B → A"),
        "{e}"
    );
    // A port-type mismatch across the boundary: an Image into the group's Scalar/Image `in`
    // is fine, a Scene is not.
    let mismatch = LOOK
        .replace(
            r#""c": (kind: "Constant", params: {"value": 1.5}),"#,
            r#""c": (kind: "Scene"),"#,
        )
        .replace("c.value", "c.scene");
    let e = load_err(dir.path(), GRADE, &mismatch);
    assert!(
        matches!(e, GraphError::TypeMismatch { .. }) && e.to_string().contains("g.in"),
        "{e}"
    );
    // A knob wider than its target.
    let e = load_err(dir.path(), &GRADE.replace("max: 10.0", "max: 1e40"), LOOK);
    assert!(e.to_string().contains("wider than m.b"), "{e}");
}

#[test]
fn the_cli_exits_2_on_a_bad_group_and_lists_library_groups() {
    let dir = tempfile::tempdir().unwrap();
    let path = scratch(
        dir.path(),
        GRADE,
        &LOOK.replace("library: \"grade\"", "library: \"nope\""),
    );
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(["validate", &path.display().to_string()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("look.ron") && err.contains("node 'Grade'") && err.contains("nope"),
        "{err}"
    );
    // `tyndall nodes --json` lists the library groups of graphs/lib with their knobs.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(["nodes", "--json"])
        .current_dir(dir.path())
        .env("TYNDALL_PRESETS", dir.path().join("none"))
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let grade = v
        .as_array()
        .unwrap()
        .iter()
        .find(|k| k["kind"] == "Grade")
        .expect("Grade listed");
    assert_eq!(grade["library"], "library group `grade` version 1");
    assert_eq!(grade["params"][0]["name"], "gain");
    // `tyndall group` makes a library group from nodes of a graph that loads and evaluates.
    let out = dir.path().join("graphs/lib/made.ron");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args([
            "group",
            &root()
                .join("tests/fixtures/flat/tree_hole_filling.ron")
                .display()
                .to_string(),
            "--nodes",
            "close,scatter_stylized",
            "--name",
            "Made",
            "--expose",
            "close.radius",
            "-o",
            &out.display().to_string(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let def = tyndall::graph::load_library_group(
        &dir.path().join("graphs/lib"),
        "made",
        registry().catalog(),
    )
    .unwrap();
    let s = def.schema();
    let names = |ps: &[tyndall::graph::PortSpec]| ps.iter().map(|p| p.name).collect::<Vec<_>>();
    let mut inputs = names(s.inputs);
    inputs.sort();
    assert_eq!(inputs, vec!["depth", "map"]);
    assert_eq!(names(s.outputs), vec!["inscatter", "transmittance"]);
    assert_eq!(s.params[0].name, "radius");
}

/// The editor's group operations, each one undo step: Group (Ctrl+G) a selection, Expose an
/// inner parameter, change the knob, Publish to a library folder, Ungroup; undo walks back
/// through every step to the original document.
#[test]
fn editor_groups_exposes_publishes_and_ungroups_with_undo() {
    let reg = registry();
    let dir = tempfile::tempdir().unwrap();
    let flat = dir.path().join("graphs/look.ron");
    std::fs::create_dir_all(flat.parent().unwrap()).unwrap();
    std::fs::copy(
        root().join("tests/fixtures/flat/tree_hole_filling.ron"),
        &flat,
    )
    .unwrap();
    let mut s = tyndall::editor::EditorState::open(reg.catalog().clone(), &flat).unwrap();
    let original = save_string(s.graph());
    let chain: Vec<String> = [
        "close",
        "scatter_stylized",
        "composite_stylized",
        "tonemap_stylized",
    ]
    .iter()
    .map(|x| x.to_string())
    .collect();
    let group = s.group(&chain).unwrap();
    assert_eq!(group, "group1");
    let g = s.graph();
    assert_eq!(g.node("group1").unwrap().kind, "Group1");
    assert!(g.node("close").is_none());
    let after_group = save_string(g);
    s.expose("group1", "close", "radius", "radius").unwrap();
    s.set_param("group1", "radius", ParamValue::Float(9.0))
        .unwrap();
    let flat_now = s.graph().flatten(reg.catalog()).unwrap();
    assert_eq!(
        flat_now
            .param_at(reg.catalog(), "group1/close", "radius", 0.0)
            .unwrap(),
        ParamValue::Float(9.0),
        "the knob drives the inner parameter"
    );
    let lib = dir.path().join("graphs/lib");
    let file = s.publish("group1", &lib, "my/look").unwrap();
    assert!(file.is_file());
    let text = save_string(s.graph());
    assert!(
        text.contains("(library: \"my/look\", version: 1)"),
        "{text}"
    );
    // The published graph reloads from its file with the library group.
    let again = load_str(&text, &flat, reg.catalog()).unwrap();
    assert_eq!(save_string(&again), text);
    s.ungroup("group1").unwrap();
    let g = s.graph();
    assert!(g.node("group1").is_none() && g.node("close").is_some());
    assert_eq!(
        g.param_at(reg.catalog(), "close", "radius", 0.0).unwrap(),
        ParamValue::Float(9.0),
        "ungrouping keeps the knob's value"
    );
    assert!(g.groups().is_empty());
    // Undo: ungroup, publish, set, expose, group — back to the original.
    for _ in 0..4 {
        assert!(s.undo());
    }
    assert_eq!(save_string(s.graph()), after_group);
    assert!(s.undo());
    assert_eq!(save_string(s.graph()), original);
}

/// Merging a grouped preset into another document, and copy → paste of a group node, bring
/// the group definitions along.
#[test]
fn merge_and_paste_carry_the_groups() {
    let reg = registry();
    let preset = root().join("graphs/stylize/tree_hole_filling.ron");
    let clip = load_file(&preset, reg.catalog()).unwrap();
    let mut s = tyndall::editor::EditorState::new(reg.catalog().clone());
    let ids = s.paste_graph(&clip, [0.0, 0.0]).unwrap();
    assert_eq!(ids.len(), clip.len());
    assert!(s.graph().has_group_nodes());
    assert!(s.graph().flatten(reg.catalog()).is_ok());
    let hole = s
        .graph()
        .nodes()
        .find(|n| n.kind == "HoleFilling")
        .unwrap()
        .id
        .clone();
    let text = s.copy(std::slice::from_ref(&hole));
    assert!(
        text.contains("\"HoleFilling\": (library: \"stylize/hole_filling\", version: 1)"),
        "{text}"
    );
    let mut t = tyndall::editor::EditorState::open(reg.catalog().clone(), &preset).unwrap();
    let pasted = t.paste(&text, [10.0, 10.0]).unwrap();
    assert_eq!(pasted.len(), 1);
    assert_eq!(t.graph().node(&pasted[0]).unwrap().kind, "HoleFilling");
}

#[test]
fn a_node_failing_inside_a_group_names_its_path_and_its_group() {
    if common::gpu().is_none() {
        return;
    }
    // What an adapter cannot run, a missing file, any failure of an inner node: the message
    // names the node by its flattened path and the group node and group it came from.
    let lib = r#"(version: 3, group: (name: "Plate", version: 1, doc: "A plate.",
        inputs: {},
        outputs: {"out": (from: "img.image")},
        knobs: {},
        nodes: {"img": (kind: "ImageInput", params: {"path": "no_such_plate.exr"})},
    ))"#;
    let graph = r#"(version: 3,
        nodes: {"p": (kind: "Plate")},
        edges: [],
        groups: {"Plate": (library: "grade", version: 1)},
    )"#;
    let reg = registry();
    let dir = tempfile::tempdir().unwrap();
    let path = scratch(dir.path(), lib, graph);
    let g = load_file(&path, reg.catalog()).unwrap();
    let gpu = common::gpu().expect("adapter");
    let mut ev = tyndall::eval::Evaluator::new(reg.clone(), gpu);
    let e = ev
        .evaluate(
            &g,
            &[tyndall::eval::Target::Port("p".into(), "out".into())],
            &tyndall::eval::EvalOptions::default(),
        )
        .expect_err("the plate is missing");
    let text = e.to_string();
    assert!(
        text.starts_with("node 'p/img' (ImageInput): inside group node 'p' (Plate): "),
        "{text}"
    );
    assert!(text.contains("no_such_plate.exr"), "{text}");
}
