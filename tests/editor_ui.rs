//! The editor window, headless through egui_kittest (rendered with wgpu on lavapipe).

mod common;

use std::path::Path;
use std::sync::Arc;

use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use tyndall::editor::{EditorApp, EditorState};
use tyndall::graph::{save_string, ParamValue};

fn harness(graph: &str) -> Harness<'static, EditorApp> {
    let registry = Arc::new(tyndall::nodes::registry());
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(graph);
    let state = EditorState::open(registry.catalog().clone(), &path).expect("open");
    let mut h = Harness::builder()
        .with_size(egui::vec2(1200.0, 760.0))
        .wgpu()
        .build_eframe(move |_cc| EditorApp::new(state, registry));
    h.run_steps(4);
    h
}

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
    h.run_steps(4);
    // The node's title on the canvas and the parameters panel's heading.
    assert_eq!(h.query_all_by_label("tonemap - Tonemap").count(), 2);
    let _ = h.get_by_label("exposure");
    let _ = h.get_by_label("operator");
    // Snapshot of the whole editor (1200×760 = 912 000 pixels). The status line is cleared (it
    // counts evaluated nodes, which depends on frame timing); the wires' anti-aliased edges
    // differ from run to run in a few hundred pixels even on lavapipe (measured 449–592 at
    // threshold 0.6), so up to 1 500 pixels (0.16 %) may differ: a missing panel, node or
    // picture changes tens of thousands.
    h.state_mut().status.clear();
    h.run_steps(4);
    h.snapshot_options(
        "editor_window",
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
            let mut app = EditorApp::new(state, registry);
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
