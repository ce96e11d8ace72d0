//! The editor window, headless through egui_kittest (rendered with wgpu on lavapipe).

use crate::common;
use std::path::Path;
use std::sync::Arc;

use eframe::egui;
use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use tyndall::editor::{EditorApp, EditorState};
use tyndall::graph::{save_string, ParamValue};

fn harness(graph: &str) -> Harness<'static, EditorApp> {
    common::editor::open(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join(graph),
        (1200.0, 760.0),
    )
}

use crate::common::editor::settle;

#[test]
fn canvas_shows_the_document_and_undo_button_restores_it() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    for title in [
        "scene - Scene",
        "scatter - SingleScattering",
        "composite - Composite",
    ] {
        let _ = h.get_by_label(title);
    }
    let before = save_string(h.state().state.graph());
    h.state_mut()
        .state
        .set_param("tonemap", "exposure", ParamValue::Float(1.5))
        .expect("param");
    h.run_steps(2);
    assert_ne!(save_string(h.state().state.graph()), before);
    h.get_by_label("Undo").click();
    h.run_steps(2);
    assert_eq!(
        save_string(h.state().state.graph()),
        before,
        "the Undo button restores the exact document"
    );
    h.get_by_label("Redo").click();
    h.run_steps(2);
    assert_ne!(save_string(h.state().state.graph()), before);
}

#[test]
fn selecting_a_node_shows_its_parameters_and_picture() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    h.state_mut().selected = Some("tonemap".into());
    settle(&mut h);
    // Every node with a picture output shows its thumbnail before the snapshot (they change the
    // nodes' sizes).
    for id in ["shadow", "gbuffer", "scatter", "composite", "tonemap"] {
        for _ in 0..500 {
            if h.state().has_thumbnail(id) {
                break;
            }
            h.run_steps(1);
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        assert!(h.state().has_thumbnail(id), "{id} has no thumbnail");
    }
    // The node's title on the canvas and the parameters panel's heading.
    assert_eq!(h.query_all_by_label("tonemap - Tonemap").count(), 2);
    let _ = h.get_by_label("operator");
    // The parameter and the viewer's exposure.
    assert_eq!(h.query_all_by_label("exposure").count(), 2);
    let pictures = &h
        .state()
        .pictures
        .as_ref()
        .expect("the viewer has a picture")
        .1;
    assert_eq!(pictures.len(), 1, "the tonemap's one output");
    // Every node with a picture output has a thumbnail report, none failed.
    assert!(h.state().reports.values().all(|r| r.error.is_none()));
    // Snapshot of the whole editor (1200×760 = 912 000 pixels). The status line (it counts
    // evaluated nodes and milliseconds) and the per-node timings are hidden; the wires'
    // anti-aliased edges differ from run to run in a few hundred pixels even on lavapipe
    // (measured 449–592 at threshold 0.6), so up to 1 500 pixels (0.16 %) may differ: a
    // missing panel, node, thumbnail or picture changes thousands.
    // The view is framed once the thumbnails have landed (they change the nodes' sizes, and the
    // first framing happens before, at a time that depends on the worker).
    h.state_mut().show_timings = false;
    h.state_mut().status.clear();
    h.state_mut().request_frame_all();
    h.run_steps(4);
    // One snapshot per backend: GL draws the same editor through another shader compiler and
    // rasteriser (its wires' and text's anti-aliased edges and the pictures' last bits differ:
    // 1,520 pixels against the Vulkan snapshot, measured), so each backend has its own file
    // (`editor_window.png` for Vulkan, `editor_window_gl.png`), both held to the same 1 500.
    let gpu = common::gpu().expect("adapter");
    let name = match gpu.info.backend {
        wgpu::Backend::Gl => "editor_window_gl",
        _ => "editor_window",
    };
    h.snapshot_options(
        name,
        &egui_kittest::SnapshotOptions::new().max_failed_pixels(1500),
    );
}

#[test]
fn autosave_recovery_is_offered_and_restores_the_changes() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("g.ron");
    let registry = Arc::new(tyndall::nodes::registry());
    // A session edits, autosaves, and dies without saving.
    let mut crashed = EditorState::new(registry.catalog().clone());
    crashed.add_node("Constant", [0.0, 0.0]).expect("add");
    crashed.save_as(&path).expect("save");
    crashed.add_node("Math", [100.0, 0.0]).expect("add");
    crashed.set_autosave_period(std::time::Duration::ZERO);
    assert!(crashed
        .tick_autosave(std::time::Instant::now())
        .expect("autosave"));
    let wanted = save_string(crashed.graph());
    drop(crashed);
    // The next start offers recovery.
    let state = EditorState::open(registry.catalog().clone(), &path).expect("open");
    let side = EditorState::recoverable(&path).expect("autosave found");
    let mut h = Harness::builder()
        .with_size(egui::vec2(1000.0, 700.0))
        .wgpu()
        .build_eframe(move |_cc| {
            let mut app = EditorApp::new(state, registry).with_tools(tyndall::tools::registry());
            app.recovery = Some(side);
            app
        });
    h.run_steps(3);
    assert_eq!(h.state().state.graph().len(), 1);
    h.get_by_label("Recover").click();
    h.run_steps(3);
    assert_eq!(save_string(h.state().state.graph()), wanted);
    assert!(h.state().state.is_dirty(), "recovered, not yet saved");
    assert!(h.query_by_label("Recover").is_none(), "the offer is gone");
}

#[test]
fn unsaved_changes_prompt_can_be_cancelled() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    h.state_mut()
        .state
        .set_param("tonemap", "exposure", ParamValue::Float(1.0))
        .expect("param");
    h.state_mut().confirm_quit = true;
    h.run_steps(2);
    let _ = h.get_by_label("Save and quit");
    let _ = h.get_by_label("Discard and quit");
    h.get_by_label("Cancel").click();
    h.run_steps(2);
    assert!(!h.state().confirm_quit);
    assert!(h.state().state.is_dirty(), "cancel keeps the changes");
}

#[test]
fn adding_from_the_catalog_and_connecting_changes_the_document() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    let before = h.state().state.graph().len();
    h.get_by_label("Find").click();
    h.run_steps(1);
    h.get_by_label("Find").type_text("constant");
    h.run_steps(2);
    h.get_by_label("Constant").click();
    h.run_steps(2);
    let g = h.state().state.graph();
    assert_eq!(g.len(), before + 1, "the catalog button added a node");
    let id = g
        .nodes()
        .find(|n| n.kind == "Constant")
        .map(|n| n.id.clone())
        .expect("constant");
    assert_eq!(h.state().selected.as_deref(), Some(id.as_str()));
    // Connect it where a scalar goes; the document gains the edge and the canvas redraws it.
    let math = h
        .state_mut()
        .state
        .add_node("Math", [0.0, 0.0])
        .expect("math");
    assert!(h
        .state_mut()
        .connect_ports(&format!("{id}.value"), &format!("{math}.a")));
    h.run_steps(2);
    assert_eq!(
        h.state().state.graph().source_of(&math, "a"),
        Some((id.as_str(), "value"))
    );
    // A refused connection leaves the document alone and says why on screen. (First let the
    // evaluation the new edge started finish: its summary would replace the status line.)
    settle(&mut h);
    let text = save_string(h.state().state.graph());
    assert!(!h
        .state_mut()
        .connect_ports("scatter.inscatter", "shadow.scene"));
    h.run_steps(2);
    assert_eq!(save_string(h.state().state.graph()), text);
    let status = h.state().status.clone();
    assert!(status.starts_with("refused:"), "{status}");
    let _ = h.get_by_label(&status);
    // A cycle is refused too.
    assert!(!h
        .state_mut()
        .connect_ports("tonemap.image", "composite.scattering"));
    assert!(h.state().status.starts_with("refused:"));
}

#[test]
fn a_parameter_change_reruns_only_the_nodes_below_it() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    settle(&mut h);
    let ran = |h: &Harness<'static, EditorApp>| -> Vec<String> {
        let mut v: Vec<String> = h
            .state()
            .reports
            .iter()
            .filter(|(_, r)| r.status == tyndall::eval::Status::Ran)
            .map(|(id, _)| id.clone())
            .collect();
        v.sort();
        v
    };
    assert!(
        ran(&h).contains(&"scatter".to_string()),
        "first evaluation runs the chain"
    );
    h.state_mut()
        .state
        .set_param("tonemap", "exposure", ParamValue::Float(0.7))
        .expect("param");
    settle(&mut h);
    assert_eq!(
        ran(&h),
        vec!["tonemap".to_string()],
        "only the tonemap is dirty"
    );
    for up in ["scene", "shadow", "gbuffer", "scatter", "composite"] {
        assert_eq!(
            h.state().reports[up].status,
            tyndall::eval::Status::Reused,
            "{up} is reused"
        );
    }
    // Upstream change: the scattering and everything below it run, the scene does not.
    h.state_mut()
        .state
        .set_param("scatter", "steps", ParamValue::Int(48))
        .expect("param");
    settle(&mut h);
    assert_eq!(
        ran(&h),
        vec![
            "composite".to_string(),
            "scatter".to_string(),
            "tonemap".to_string()
        ]
    );
}

#[test]
fn save_then_reopen_gives_the_same_document() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("window.ron");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron"),
        &path,
    )
    .expect("copy");
    let mut h = harness(path.to_str().expect("utf-8"));
    h.state_mut()
        .state
        .set_param("tonemap", "exposure", ParamValue::Float(2.5))
        .expect("param");
    h.run_steps(2);
    h.get_by_label("Save").click();
    h.run_steps(2);
    assert!(!h.state().state.is_dirty());
    let shown = save_string(h.state().state.graph());
    let registry = tyndall::nodes::registry();
    let reopened = EditorState::open(registry.catalog().clone(), &path).expect("reopen");
    assert_eq!(save_string(reopened.graph()), shown);
}

#[test]
fn viewer_pins_keys_and_timeline() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    // Shift+1 pins the selected scattering node; with another node selected, 1 shows the pin.
    h.state_mut().selected = Some("scatter".into());
    h.run_steps(2);
    h.key_press_modifiers(egui::Modifiers::SHIFT, egui::Key::Num1);
    h.run_steps(2);
    assert_eq!(h.state().pins[0].as_deref(), Some("scatter"));
    h.state_mut().selected = Some("tonemap".into());
    h.state_mut().active_pin = None;
    h.run_steps(1);
    h.key_press(egui::Key::Num1);
    h.run_steps(1);
    assert_eq!(h.state().viewed().as_deref(), Some("scatter"));
    settle(&mut h);
    // The probe's pictures for a scattering node: V̄ and linear depth among them.
    let ports: Vec<String> = h
        .state()
        .pictures
        .as_ref()
        .expect("pictures")
        .1
        .iter()
        .map(|(p, _)| p.clone())
        .collect();
    assert!(ports.contains(&"visibility".to_string()) && ports.contains(&"depth".to_string()));
    // The key toggle next to a numeric parameter keys it at the current frame; moving the
    // timeline and editing the value adds a second key.
    let before = h
        .state()
        .state
        .graph()
        .node("tonemap")
        .expect("n")
        .keys
        .len();
    h.get_all_by_label("○")
        .next()
        .expect("a key toggle")
        .click();
    h.run_steps(2);
    let keys = &h.state().state.graph().node("tonemap").expect("n").keys;
    assert_eq!(keys.len(), before + 1, "one parameter became animated");
    let (name, track) = keys
        .iter()
        .next()
        .map(|(k, v)| (k.clone(), v.clone()))
        .expect("k");
    assert_eq!(track.len(), 1);
    assert_eq!(track[0].t, 0.0);
    h.state_mut().time = 12.0;
    h.run_steps(2);
    h.get_by_label("◇").click();
    h.run_steps(2);
    assert_eq!(
        h.state().state.graph().node("tonemap").expect("n").keys[&name].len(),
        2
    );
    // Undo removes that key again.
    h.get_by_label("Undo").click();
    h.run_steps(2);
    assert_eq!(
        h.state().state.graph().node("tonemap").expect("n").keys[&name].len(),
        1
    );
}

#[test]
fn presets_merge_and_clipboard_paste() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    let before = h.state().state.graph().len();
    // The browser lists graphs/ with thumbnails from docs/; merging adds its nodes.
    let _ = h.get_by_label("physical/tree");
    let merge = h.get_all_by_label("Merge").next().expect("a preset");
    merge.click();
    h.run_steps(2);
    let merged = h.state().state.graph().len();
    assert!(merged > before, "merge added nodes");
    // Pasting copied text (from this or another graph) adds nodes with fresh ids.
    let ids = |h: &Harness<'static, EditorApp>| -> Vec<(String, String)> {
        let g = h.state().state.graph();
        g.nodes().map(|n| (n.id.clone(), n.kind.clone())).collect()
    };
    let before_paste = ids(&h);
    let copied = h.state().state.copy(&["tonemap".to_string()]);
    h.event(egui::Event::Paste(copied));
    h.run_steps(2);
    assert_eq!(h.state().state.graph().len(), merged + 1);
    // The pasted node is a copy under a fresh id. (Not checked through the status line: the
    // background evaluation the paste starts may finish within these frames and replace
    // "pasted 1 node(s)" with its own summary.)
    let added: Vec<_> = ids(&h)
        .into_iter()
        .filter(|n| !before_paste.contains(n))
        .collect();
    let kind = h
        .state()
        .state
        .graph()
        .node("tonemap")
        .expect("n")
        .kind
        .clone();
    assert_eq!(added.len(), 1, "{added:?}");
    assert_ne!(added[0].0, "tonemap");
    assert_eq!(added[0].1, kind);
    h.get_by_label("Undo").click();
    h.run_steps(2);
    assert_eq!(h.state().state.graph().len(), merged);
}

/// The parameters panel shows where the selected node's setting lies on its measured curve
/// (`bench/results.csv`): the matching measured setting is named with its time and error, a
/// node whose setting was not measured gets the closest one, and "Use it" applies that setting.
#[test]
fn the_selected_nodes_setting_is_shown_on_its_measured_curve() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("results.csv");
    std::fs::write(
        &csv,
        "suite,adapter,node,kind,setting,row,median_ms,min_ms,rmse,max_err\n\
         visibility/tree,test adapter,scatter,SingleScattering,method=BruteForce steps=64,setting,500,480,0.004,0.04\n\
         visibility/tree,test adapter,scatter,SingleScattering,method=MinMax min_level=0,setting,250,240,0.0001,0.001\n",
    )
    .expect("csv");
    // Tall enough for the whole parameters panel: a click lands only on a visible button.
    let mut h = common::editor::open(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron"),
        (1200.0, 1400.0),
    );
    h.state_mut().set_bench_results(&csv);
    h.state_mut().selected = Some("scatter".into());
    settle(&mut h);
    // The window preset's scatter node: MinMax at min_level 0 (the default).
    let _ = h.get_by_label("Measured speed against accuracy");
    let _ = h.get_by_label("current setting: 250.0 ms, RMSE 1.00e-4 (method=MinMax min_level=0)");
    // Another setting: no measured row matches; the closest is named.
    h.state_mut()
        .state
        .set_param("scatter", "min_level", ParamValue::Int(3))
        .expect("set");
    settle(&mut h);
    assert!(h
        .query_by_label_contains("current setting not measured; closest: method=MinMax min_level=0")
        .is_some());
    // "Use it" sets the node to the closest measured setting, as one undoable step.
    let depth = h.state().state.undo_depth();
    h.get_by_label("Use it").click();
    settle(&mut h);
    let level = |h: &egui_kittest::Harness<'static, tyndall::editor::EditorApp>| {
        h.state()
            .state
            .graph()
            .node("scatter")
            .and_then(|n| n.params.get("min_level").cloned())
    };
    assert_eq!(level(&h), Some(ParamValue::Int(0)));
    assert_eq!(h.state().state.undo_depth(), depth + 1);
    let _ = h.get_by_label("current setting: 250.0 ms, RMSE 1.00e-4 (method=MinMax min_level=0)");
}

/// The editor reads a graph's relative input paths from the graph's folder (as the CLI does),
/// not from its working directory.
#[test]
fn relative_inputs_are_read_from_the_graph_folder() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/A.exr"),
        dir.path().join("A.exr"),
    )
    .expect("copy");
    let graph = dir.path().join("g.ron");
    std::fs::write(
        &graph,
        r#"(version: 2, nodes: {"in": (kind: "ImageInput", params: {"path": "A.exr"})}, edges: [])"#,
    )
    .expect("graph");
    let mut h = common::editor::open(&graph, (900.0, 600.0));
    h.state_mut().selected = Some("in".into());
    settle(&mut h);
    assert!(
        h.state().has_thumbnail("in"),
        "A.exr next to the graph was read (the working directory, the crate root, has none)"
    );
}

/// A lost GPU device (driver reset, GPU removed) does not leave the editor without pictures:
/// the worker and its cache are dropped, evaluation restarts on a new device, and everything
/// evaluates again there. The editor runs on a private device here so that destroying it does
/// not touch the other tests' shared one.
#[test]
fn a_lost_device_restarts_evaluation_on_a_new_one() {
    if common::gpu().is_none() {
        return;
    }
    let private = Arc::new(tyndall::gpu::Gpu::new(false).expect("device"));
    let registry = Arc::new(tyndall::nodes::registry());
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let state = EditorState::open(registry.catalog().clone(), &path).expect("open");
    let gpu = private.clone();
    let mut h = Harness::builder()
        .with_size(egui::vec2(1200.0, 760.0))
        .wgpu()
        .build_eframe(move |_cc| {
            EditorApp::on_gpu(state, registry, Some(gpu)).with_tools(tyndall::tools::registry())
        });
    settle(&mut h);
    let errors = |h: &Harness<'static, EditorApp>| -> Vec<String> {
        h.state()
            .reports
            .iter()
            .filter_map(|(id, r)| r.error.as_ref().map(|e| format!("{id}: {e}")))
            .collect()
    };
    assert_eq!(errors(&h), Vec::<String>::new());
    assert_eq!(h.state().device_restarts, 0);

    private.simulate_loss();
    h.state_mut().selected = Some("tonemap".into());
    h.state_mut().pictures = None;
    h.state_mut()
        .state
        .set_param("tonemap", "exposure", ParamValue::Float(0.7))
        .expect("param");
    settle(&mut h);
    assert_eq!(h.state().device_restarts, 1, "status: {}", h.state().status);
    let status = h.state().status.clone();
    assert!(
        status.contains("GPU device lost and replaced 1×"),
        "{status}"
    );
    assert_eq!(errors(&h), Vec::<String>::new(), "the new device evaluates");
    // The new worker starts with an empty cache: the whole chain ran again, not only the
    // tonemap below the change.
    assert_eq!(
        h.state().reports["scatter"].status,
        tyndall::eval::Status::Ran
    );
    let (viewed, pictures) = h.state().pictures.clone().expect("the viewer's picture");
    assert_eq!(viewed, "tonemap");
    assert!(!pictures.is_empty());
}

/// A group node in the editor: its knobs in the parameter panel, its inside listed with Expose
/// buttons, Expose and Ungroup as buttons, Ctrl+G on a selection, and Ctrl+Z undoing each.
#[test]
fn group_nodes_show_knobs_expose_ungroup_and_undo() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/stylize/tree_hole_filling.ron");
    h.state_mut().selected = Some("holes".into());
    settle(&mut h);
    assert_eq!(h.query_all_by_label("holes - HoleFilling").count(), 2);
    let _ = h.get_by_label("radius");
    h.get_by_label("Inside HoleFilling (2 nodes)").click();
    h.run_steps(3);
    let before = save_string(h.state().state.graph());
    // Expose the closure's shape … (the first Expose button is close.method or the like: take
    // whichever, then check a knob was added).
    let knobs = |h: &egui_kittest::Harness<'static, tyndall::editor::EditorApp>| {
        h.state().state.graph().groups()["HoleFilling"].knobs.len()
    };
    let n = knobs(&h);
    h.query_all_by_label("Expose")
        .next()
        .expect("an Expose button")
        .click();
    h.run_steps(3);
    assert_eq!(knobs(&h), n + 1, "Expose added a knob");
    // … then Ungroup, and undo both.
    h.get_by_label("Ungroup").click();
    h.run_steps(3);
    assert!(h.state().state.graph().node("holes").is_none());
    assert!(h.state().state.graph().node("close").is_some());
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert_eq!(save_string(h.state().state.graph()), before);
    // Ctrl+Shift+G ungroups the selected group node too.
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::G,
    );
    h.run_steps(2);
    assert!(
        h.state().state.graph().node("shafts").is_some(),
        "HoleFilling's Shafts is now in the graph"
    );
    settle(&mut h);
    let errors: Vec<String> = h
        .state()
        .reports
        .iter()
        .filter_map(|(id, r)| r.error.as_ref().map(|e| format!("{id}: {e}")))
        .collect();
    assert!(errors.is_empty(), "{errors:?}");
}

/// The viewer's A/B wipe: W takes the node viewed now as B; viewing another node shows it (A)
/// with B over the right of the split; W again ends it.
#[test]
fn ab_wipe_compares_two_nodes_in_the_viewer() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    h.state_mut().selected = Some("scatter".into());
    settle(&mut h);
    h.key_press(egui::Key::W);
    h.run_steps(2);
    assert_eq!(h.state().wipe.as_deref(), Some("scatter"));
    h.state_mut().selected = Some("tonemap".into());
    settle(&mut h);
    let a = h.state().pictures.as_ref().map(|(n, _)| n.clone());
    let b = h
        .state()
        .compare
        .as_ref()
        .map(|(n, p)| (n.clone(), p.len()));
    assert_eq!(a.as_deref(), Some("tonemap"));
    assert!(
        matches!(&b, Some((n, k)) if n == "scatter" && *k >= 3),
        "{b:?}"
    );
    let _ = h.get_by_label("B = scatter");
    h.key_press(egui::Key::W);
    h.run_steps(2);
    assert!(h.state().wipe.is_none());
    assert!(h.query_all_by_label("B = scatter").next().is_none());
}

/// The whole group workflow through the window: Shift+click two nodes, Ctrl+G groups them, Tab
/// enters the group (the breadcrumb shows the path), Expose on an inner parameter makes it a
/// knob, Tab leaves, changing the knob re-runs only the inner nodes it reaches and what is
/// below, Publish writes the library file beside the graph; Ctrl+Z undoes each step.
#[test]
fn group_enter_expose_knob_publish_and_undo_in_the_window() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tmp");
    std::fs::create_dir(dir.path().join("lib")).expect("lib");
    let file = dir.path().join("window.ron");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron"),
        &file,
    )
    .expect("copy");
    let mut h = common::editor::open(&file, (1400.0, 800.0));
    settle(&mut h);
    let original = save_string(h.state().state.root());
    // Shift+click selects on the canvas; Ctrl+G groups the selection.
    // (Node widgets lie in the canvas's transformed layer: their rectangles are in graph space.)
    for label in ["scatter - SingleScattering", "composite - Composite"] {
        let at = h
            .state()
            .canvas_to_screen(h.get_by_label(label).rect().center());
        h.event(egui::Event::PointerMoved(at));
        h.event(egui::Event::ModifiersChanged(egui::Modifiers::SHIFT));
        h.run_steps(1);
        for pressed in [true, false] {
            h.event(egui::Event::PointerButton {
                pos: at,
                button: egui::PointerButton::Primary,
                pressed,
                modifiers: egui::Modifiers::SHIFT,
            });
            h.run_steps(1);
        }
        h.event(egui::Event::ModifiersChanged(egui::Modifiers::default()));
        h.run_steps(2);
    }
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::G);
    h.run_steps(3);
    let root = h.state().state.root().clone();
    assert_eq!(root.node("group1").map(|n| n.kind.as_str()), Some("Group1"));
    assert!(root.node("scatter").is_none() && root.node("composite").is_none());
    let grouped = save_string(&root);
    // Tab enters the selected group: the canvas shows its inside, the breadcrumb its path.
    h.state_mut().selected = Some("group1".into());
    h.run_steps(2);
    h.key_press(egui::Key::Tab);
    h.run_steps(3);
    assert_eq!(h.state().state.scope(), ["group1".to_string()]);
    let _ = h.get_by_label("Document");
    let _ = h.get_by_label("group1 (Group1)");
    assert!(h.state().state.graph().node("scatter").is_some());
    // Expose scatter.steps: the Expose button on its row of the parameter panel.
    h.state_mut().selected = Some("scatter".into());
    h.run_steps(3);
    let params: Vec<&str> = h
        .state()
        .state
        .catalog()
        .get("SingleScattering")
        .expect("kind")
        .params
        .iter()
        .map(|p| p.name)
        .collect();
    let row = params.iter().position(|p| *p == "steps").expect("steps");
    h.query_all_by_label("Expose")
        .nth(row)
        .expect("an Expose button per parameter")
        .click();
    h.run_steps(3);
    let def = h.state().state.enclosing().expect("inside a group");
    assert!(
        def.knobs
            .iter()
            .any(|k| k.name == "steps"
                && k.targets == [("scatter".to_string(), "steps".to_string())]),
        "{:?}",
        def.knobs
    );
    let _ = h.get_by_label("knob steps");
    // Tab again (the selection is not a group) leaves; the group node is selected.
    h.key_press(egui::Key::Tab);
    h.run_steps(3);
    assert!(h.state().state.scope().is_empty());
    assert_eq!(h.state().selected.as_deref(), Some("group1"));
    let _ = h.get_by_label("steps");
    settle(&mut h);
    // The knob re-runs the inner nodes it reaches and what is below: not the scene, shadow
    // map or G-buffer.
    h.state_mut()
        .state
        .set_param("group1", "steps", ParamValue::Int(48))
        .expect("knob");
    settle(&mut h);
    let mut ran: Vec<String> = h
        .state()
        .reports
        .iter()
        .filter(|(_, r)| r.status.ran())
        .map(|(id, _)| id.clone())
        .collect();
    ran.sort();
    assert_eq!(ran, ["group1/composite", "group1/scatter", "tonemap"]);
    for up in ["scene", "shadow", "gbuffer"] {
        assert_eq!(h.state().reports[up].status, tyndall::eval::Status::Reused);
    }
    // The group node shows its inner nodes' report (their thumbnail too).
    assert!(h.state().report("group1").is_some_and(|r| r.status.ran()));
    // Publish: the library file beside the graph, and the graph references it.
    h.get_by_label("Publish to library").click();
    h.run_steps(3);
    let published = dir.path().join("lib/group1.ron");
    assert!(published.is_file(), "{}", h.state().status);
    assert!(h.state().state.root().groups()["Group1"].library.is_some());
    // Undo each step: publish, the knob value, Expose, Group.
    let undo = |h: &mut Harness<'static, EditorApp>| {
        h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
        h.run_steps(2);
    };
    undo(&mut h);
    assert!(h.state().state.root().groups()["Group1"].library.is_none());
    undo(&mut h);
    assert!(h
        .state()
        .state
        .root()
        .node("group1")
        .is_some_and(|n| n.params.is_empty()));
    undo(&mut h);
    assert_eq!(save_string(h.state().state.root()), grouped);
    undo(&mut h);
    assert_eq!(save_string(h.state().state.root()), original);
}

/// The Add-node list offers the library groups: a click adds an instance that references the
/// group's file, one undo step.
#[test]
fn library_groups_are_in_the_add_node_list() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    h.get_by_label("Find").click();
    h.run_steps(1);
    h.get_by_label("Find").type_text("hole_filling");
    h.run_steps(3);
    h.get_by_label("stylize/hole_filling").click();
    h.run_steps(3);
    let g = h.state().state.root();
    let node = g
        .nodes()
        .find(|n| n.kind == "HoleFilling")
        .expect("a HoleFilling node");
    assert_eq!(h.state().selected.as_deref(), Some(node.id.as_str()));
    let lib = g.groups()["HoleFilling"]
        .library
        .as_ref()
        .expect("a reference");
    assert_eq!(lib.name, "stylize/hole_filling");
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run_steps(2);
    assert!(h
        .state()
        .state
        .root()
        .nodes()
        .all(|n| n.kind != "HoleFilling"));
}

/// The worker's outcomes until every request sent has one.
fn outcomes(w: &mut tyndall::editor::worker::Worker) -> Vec<tyndall::editor::worker::Outcome> {
    let mut all = Vec::new();
    for _ in 0..6000 {
        all.extend(w.poll());
        if w.idle() {
            return all;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    panic!("the worker did not finish");
}

/// The tonemap's picture of `g` evaluated directly at `size` (the oracle of the worker's).
fn direct(
    gpu: &Arc<tyndall::gpu::Gpu>,
    g: &tyndall::graph::Graph,
    size: (u32, u32),
) -> tyndall::io::Raster {
    let registry = Arc::new(tyndall::nodes::registry());
    let flat = g.flatten(registry.catalog()).expect("flatten");
    let target = tyndall::eval::Target::Port("tonemap".into(), "out".into());
    let opts = tyndall::eval::EvalOptions {
        size,
        ..Default::default()
    };
    let r = tyndall::eval::Evaluator::new(registry, gpu.clone())
        .evaluate(&flat, &[target], &opts)
        .expect("evaluate");
    tyndall::eval::download(
        &gpu.recorder(),
        &r.outputs[&("tonemap".into(), "out".into())],
    )
    .expect("download")
}

#[test]
fn worker_proxy_then_full_ends_on_the_full_picture_and_stale_requests_never_win() {
    let Some(gpu) = common::gpu() else {
        return;
    };
    use tyndall::editor::worker::{Request, Worker};
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let mut g = tyndall::graph::load_file(&path, &cat).expect("load");
    let mut w = Worker::start(registry.clone(), gpu.clone());
    let size = (96, 54);
    let request = |g: &tyndall::graph::Graph, proxy| Request {
        generation: 0,
        graph: g.clone(),
        time: 0.0,
        size,
        view: Some("tonemap".into()),
        compare: None,
        proxy,
        textures: false,
    };
    let picture = |o: &tyndall::editor::worker::Outcome| {
        o.view.as_ref().expect("view").1[0]
            .1
            .pixels()
            .expect("read back")
            .clone()
    };
    // A proxy: the viewer's picture only, at half the size, no thumbnails.
    w.request(request(&g, 2));
    let outs = outcomes(&mut w);
    let last = outs.last().expect("an outcome");
    assert_eq!((last.proxy, last.size), (2, (48, 27)));
    let p = picture(last);
    assert_eq!((p.width, p.height), (48, 27));
    assert!(
        last.nodes.values().all(|r| r.thumb.is_none()),
        "no thumbnails at the proxy size"
    );
    // Then the full request: exactly the picture a direct evaluation gives.
    w.request(request(&g, 1));
    let outs = outcomes(&mut w);
    let last = outs.last().expect("an outcome");
    assert_eq!((last.proxy, last.size), (1, size));
    assert_eq!(
        picture(last).data,
        direct(&gpu, &g, size).data,
        "full picture after the proxy"
    );
    // Requests sent faster than they finish: the older ones are dropped or stopped between
    // nodes; the outcomes arrive in order and the last is the newest request's.
    for e in [0.25, 0.5, 0.75, 1.0] {
        g.set_param(&cat, "tonemap", "exposure", ParamValue::Float(e))
            .expect("param");
        w.request(request(&g, 1));
    }
    let outs = outcomes(&mut w);
    let gens: Vec<u64> = outs.iter().map(|o| o.generation).collect();
    assert!(gens.windows(2).all(|p| p[0] < p[1]), "in order: {gens:?}");
    assert_eq!(
        gens.last(),
        Some(&w.sent),
        "the newest request's outcome is the last"
    );
    assert_eq!(
        picture(outs.last().expect("last")).data,
        direct(&gpu, &g, size).data
    );
}

#[test]
fn dragging_a_knob_shows_a_proxy_then_the_full_picture() {
    if common::gpu().is_none() {
        return;
    }
    let mut h = harness("graphs/physical/window.ron");
    h.state_mut().selected = Some("tonemap".into());
    settle(&mut h);
    assert_eq!(h.state().proxy.shown.0, 1, "the first picture is full size");
    // The parameters panel lies below the viewer: its `exposure` is the lower label, and its
    // field the spin button on that row.
    let label = h
        .query_all_by_label("exposure")
        .map(|n| n.rect())
        .max_by(|a, b| a.top().total_cmp(&b.top()))
        .expect("label");
    let field = h
        .get_all_by_role(egui::accesskit::Role::SpinButton)
        .map(|n| n.rect())
        .filter(|r| (r.center().y - label.center().y).abs() < label.height())
        .min_by(|a, b| {
            (a.left() - label.right())
                .abs()
                .total_cmp(&(b.left() - label.right()).abs())
        })
        .expect("the exposure field");
    let before = h
        .state()
        .state
        .root()
        .node("tonemap")
        .expect("tonemap")
        .params
        .get("exposure")
        .cloned();
    let from = field.center();
    h.event(egui::Event::PointerMoved(from));
    h.run_steps(1);
    common::editor::press(&mut h, from, true);
    h.run_steps(1);
    for k in 1..=6 {
        h.event(egui::Event::PointerMoved(
            from + egui::vec2(8.0 * k as f32, 0.0),
        ));
        h.run_steps(1);
    }
    // Still held: what the viewer shows is a proxy, at 1/f of the size, said in the status.
    settle(&mut h);
    let after = h
        .state()
        .state
        .root()
        .node("tonemap")
        .expect("tonemap")
        .params
        .get("exposure")
        .cloned();
    assert_ne!(before, after, "the drag changed the exposure");
    let (f, size) = h.state().proxy.shown;
    assert!(f > 1, "a proxy is shown while dragging");
    let shown = &h.state().pictures.as_ref().expect("picture").1[0].1;
    assert_eq!(shown.size(), size);
    assert_eq!(
        size,
        (
            tyndall::editor::VIEW_SIZE.0 / f,
            tyndall::editor::VIEW_SIZE.1 / f
        )
    );
    assert!(
        h.state().status.starts_with("proxy"),
        "{}",
        h.state().status
    );
    // Released: the full picture of the same document replaces it.
    common::editor::press(&mut h, from + egui::vec2(48.0, 0.0), false);
    h.run_steps(2);
    settle(&mut h);
    assert_eq!(h.state().proxy.shown, (1, tyndall::editor::VIEW_SIZE));
    assert!(h.state().status.starts_with("full"), "{}", h.state().status);
    let shown = h.state().pictures.as_ref().expect("picture").1[0].1.clone();
    let shown = shown.pixels().expect("read back").clone();
    let gpu = common::gpu().expect("gpu");
    // (The editor resolves relative paths against the graph's folder; this graph has none.)
    let doc = h.state().state.root().clone();
    assert_eq!(
        shown.data,
        direct(&gpu, &doc, tyndall::editor::VIEW_SIZE).data
    );
}

#[test]
fn tool_jobs_run_on_the_worker_evaluator_with_its_cache_and_the_newest_ask_wins() {
    let Some(gpu) = common::gpu() else {
        return;
    };
    use tyndall::editor::worker::{Request, Worker};
    use tyndall::editor::Jobs;
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let g = tyndall::graph::load_file(&path, &cat).expect("load");
    let mut w = Worker::start(registry.clone(), gpu.clone());
    let size = (96, 54);
    w.request(Request {
        generation: 0,
        graph: g.clone(),
        time: 0.0,
        size,
        view: Some("tonemap".into()),
        compare: None,
        proxy: 1,
        textures: false,
    });
    outcomes(&mut w);
    // Two asks under one key: the first one's answer is dropped, the second's is the tonemap
    // picture evaluated by the worker's own evaluator, reusing the document's evaluation.
    let mut jobs = Jobs::default();
    jobs.ask("test/first", Box::new(|_| Ok(Box::new(1u32))));
    jobs.ask("test/first", Box::new(|_| Ok(Box::new(2u32))));
    let graph = g.clone();
    jobs.ask(
        "test/tonemap",
        Box::new(move |ev| {
            let opts = tyndall::eval::EvalOptions {
                size,
                ..Default::default()
            };
            let target = tyndall::eval::Target::Port("tonemap".into(), "out".into());
            let r = ev
                .evaluate(&graph, &[target], &opts)
                .map_err(|e| e.to_string())?;
            let status = r.stats.status("tonemap");
            let picture = tyndall::eval::download(
                &ev.gpu().recorder(),
                &r.outputs[&("tonemap".into(), "out".into())],
            )
            .map_err(|e| e.to_string())?;
            Ok(Box::new((status, picture.data)))
        }),
    );
    assert!(jobs.waiting_for("test/tonemap"));
    for _ in 0..6000 {
        jobs.exchange(Some(&mut w));
        if !jobs.waiting() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    assert!(!jobs.waiting() && w.idle(), "every job answered");
    assert_eq!(jobs.take::<u32>("test/first"), Some(Ok(2)));
    let (status, data) = jobs
        .take::<(Option<tyndall::eval::Status>, Vec<f32>)>("test/tonemap")
        .expect("answered")
        .expect("evaluated");
    assert_eq!(
        status,
        Some(tyndall::eval::Status::Reused),
        "the worker's cache"
    );
    assert_eq!(data, direct(&gpu, &g, size).data);
    assert!(jobs.take::<u32>("test/tonemap").is_none(), "taken once");
    // Without a worker every job fails with a reason.
    jobs.ask("test/none", Box::new(|_| Ok(Box::new(3u32))));
    jobs.exchange(None);
    let err = jobs
        .take::<u32>("test/none")
        .expect("answered")
        .expect_err("no GPU");
    assert!(err.contains("no GPU"), "{err}");
}

/// "Record trace" in the top bar: on, the worker's evaluations are recorded; off, the trace is
/// written beside the document and names the nodes that ran meanwhile.
#[test]
fn record_trace_writes_a_chrome_trace_beside_the_document() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("g.ron");
    std::fs::write(
        &path,
        r#"(version: 3, nodes: {
            "c": (kind: "Constant", params: {"value": 0.5}),
            "b": (kind: "Blur", params: {"sigma": 1.0}),
        }, edges: [("c.value", "b.in")])"#,
    )
    .expect("write graph");
    let mut h = common::editor::open(&path, (1400.0, 1000.0));
    h.get_by_label("Record trace").click();
    h.run_steps(2);
    // A change while recording: the blur runs again (the constant is reused).
    h.state_mut()
        .state
        .set_param("b", "sigma", ParamValue::Float(2.0))
        .expect("sigma");
    settle(&mut h);
    h.get_by_label("Record trace").click();
    h.run_steps(2);
    assert!(
        h.state().status.contains("trace written"),
        "{}",
        h.state().status
    );
    let file = std::fs::read_dir(dir.path())
        .expect("dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.to_string_lossy().contains("tyndall-trace-"))
        .expect("the trace file beside the document");
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&file).expect("read")).expect("JSON");
    let nodes: Vec<&str> = doc["traceEvents"]
        .as_array()
        .expect("events")
        .iter()
        .filter(|e| e["cat"] == "node")
        .filter_map(|e| e["name"].as_str())
        .collect();
    // (The recorder is process-wide: other tests of this binary may add their nodes.)
    assert!(nodes.contains(&"b"), "{nodes:?}");
}

/// With the window on the evaluation's device (as `tyndall edit` opens it on every backend but
/// GL), the viewer and the thumbnails are drawn from the evaluated textures: a knob change reads
/// nothing back (the probe's hovered pixel would be at most 16 bytes a port), the pictures are
/// textures, and the window shows the change. On GL the editor keeps reading back.
#[test]
fn the_viewer_draws_the_evaluated_texture_without_a_readback() {
    if common::gpu().is_none() {
        return;
    }
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let mut h = common::editor::open_sharing(&path, (1200.0, 760.0));
    h.state_mut().selected = Some("tonemap".into());
    settle(&mut h);
    let gl = common::gpu().expect("adapter").info.backend == wgpu::Backend::Gl;
    assert_eq!(h.state().shares_window_device(), !gl);
    if gl {
        return;
    }
    let textures = |h: &Harness<'static, EditorApp>| {
        let (_, pictures) = h.state().pictures.clone().expect("the viewer's picture");
        pictures
            .iter()
            .all(|(_, p)| matches!(p, tyndall::editor::worker::Picture::Texture(_)))
    };
    assert!(textures(&h));
    for id in ["shadow", "gbuffer", "scatter", "tonemap"] {
        assert!(h.state().has_thumbnail(id), "{id} has no thumbnail");
    }
    h.run_steps(2);
    let before_image = h.render().expect("render");
    // The evaluation now runs on the window's device (a context of this window alone): what it
    // reads back is counted there.
    let gpu = h.state().evaluation_gpu().expect("evaluating").clone();
    let (reads, bytes) = gpu.readbacks();
    h.state_mut()
        .state
        .set_param("tonemap", "exposure", ParamValue::Float(2.0))
        .expect("param");
    settle(&mut h);
    h.run_steps(2);
    let (reads_after, bytes_after) = gpu.readbacks();
    assert!(
        bytes_after - bytes <= 64,
        "a knob change read back {} bytes in {} reads",
        bytes_after - bytes,
        reads_after - reads
    );
    assert!(textures(&h));
    assert_eq!(
        h.state().reports["tonemap"].status,
        tyndall::eval::Status::Ran
    );
    let after_image = h.render().expect("render");
    let changed = before_image
        .pixels()
        .zip(after_image.pixels())
        .filter(|(a, b)| a != b)
        .count();
    // The viewer (and the tonemap's thumbnail) got brighter: thousands of pixels.
    assert!(changed > 5_000, "only {changed} pixels changed");
}

/// The window's device lost while the evaluation shares it: the editor restarts its evaluation
/// on a new device of its own (the process-wide one) and reads pictures back from then on; the
/// window keeps running frames.
#[test]
fn a_lost_window_device_moves_evaluation_to_a_new_one_read_back() {
    if common::gpu().is_none() {
        return;
    }
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let mut h = common::editor::open_sharing(&path, (1200.0, 760.0));
    h.state_mut().selected = Some("tonemap".into());
    settle(&mut h);
    if !h.state().shares_window_device() {
        return; // GL: nothing shared to lose
    }
    let window = h.state().evaluation_gpu().expect("evaluating").clone();
    window.simulate_loss();
    h.state_mut()
        .state
        .set_param("tonemap", "exposure", ParamValue::Float(1.25))
        .expect("param");
    settle(&mut h);
    assert_eq!(h.state().device_restarts, 1, "{}", h.state().status);
    assert!(!h.state().shares_window_device());
    let evaluation = h.state().evaluation_gpu().expect("a new worker").clone();
    assert!(!Arc::ptr_eq(&evaluation, &window), "a new context");
    let (_, pictures) = h.state().pictures.clone().expect("the viewer's picture");
    assert!(pictures
        .iter()
        .all(|(_, p)| matches!(p, tyndall::editor::worker::Picture::Pixels(_))));
    h.run_steps(3);
}
