//! Helpers for the editor's kittest tests.

use std::path::Path;
use std::sync::Arc;

use egui_kittest::Harness;
use tyndall::editor::{EditorApp, EditorState};

/// An editor window of `size` points on the graph file at `path`, after its first frames.
pub fn open(path: &Path, size: (f32, f32)) -> Harness<'static, EditorApp> {
    let registry = Arc::new(tyndall::nodes::registry());
    let state = EditorState::open(registry.catalog().clone(), path).expect("open");
    let mut h = Harness::builder()
        .with_size(eframe::egui::vec2(size.0, size.1))
        .wgpu()
        .build_eframe(move |_cc| EditorApp::new(state, registry));
    h.run_steps(4);
    h
}

/// Run frames until the evaluation worker has delivered everything asked for.
pub fn settle(h: &mut Harness<'static, EditorApp>) {
    for _ in 0..3000 {
        h.run_steps(1);
        if h.state().idle() {
            h.run_steps(2);
            if h.state().idle() {
                return;
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    panic!("the evaluation worker did not finish");
}
