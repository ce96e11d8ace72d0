//! The editor's frame time on a large document: a chain of N Math nodes in rows of 40
//! ([`tyndall::bench::documents::math_chain`], as `scripts/make_chain.py N --grid` writes it),
//! drawn headless by egui_kittest (the UI's CPU work: layout, the canvas, the panels; no
//! painting, which a real GPU does in well under a millisecond). Prints the median and
//! 90th-percentile frame time and the frame rate, first at the view the file opens with, then
//! with every node framed (`F`). egui_kittest keeps AccessKit on (it finds widgets through
//! it), which a desktop editor does only while a screen reader asks; so the same frames are
//! then timed once more on a bare `egui::Context` without it, tessellation included (what
//! eframe does before it hands the triangles to the GPU).
//!
//! ```sh
//! cargo run --release --example editor_frames -- 1000
//! ```

use std::sync::Arc;
use std::time::Instant;

use eframe::egui;
use egui_kittest::Harness;
use tyndall::editor::{EditorApp, EditorState};

/// Median and 90th percentile of `frames` frames, ms (the pointer moves a little each frame so
/// every frame does the work a hover does).
fn measure(h: &mut Harness<'static, EditorApp>, frames: usize) -> (f64, f64) {
    let mut ms = Vec::with_capacity(frames);
    for k in 0..frames {
        h.event(egui::Event::PointerMoved(egui::pos2(
            600.0 + (k % 7) as f32,
            400.0,
        )));
        let start = Instant::now();
        h.step();
        ms.push(start.elapsed().as_secs_f64() * 1e3);
    }
    ms.sort_by(f64::total_cmp);
    (ms[frames / 2], ms[frames * 9 / 10])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: usize = std::env::args()
        .nth(1)
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or(1000);
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("chain.ron");
    std::fs::write(&path, tyndall::bench::documents::math_chain(n, true))?;
    let registry = Arc::new(tyndall::nodes::registry());
    let state = EditorState::open(registry.catalog().clone(), &path)?;
    // No evaluation worker: only the UI's own work is timed.
    let mut h = Harness::builder()
        .with_size(egui::vec2(1600.0, 900.0))
        .build_eframe(move |_cc| {
            EditorApp::on_gpu(state, registry, None).with_tools(tyndall::tools::registry())
        });
    h.run_steps(10);
    let report = |what: &str, (median, p90): (f64, f64)| {
        println!(
            "{n} nodes, {what}: median {median:.1} ms ({:.0} frames/s), 90th percentile {p90:.1} ms",
            1e3 / median
        );
    };
    report("as opened", measure(&mut h, 60));
    h.key_press(egui::Key::F);
    h.run_steps(10);
    report("all framed", measure(&mut h, 60));

    let state = EditorState::open(registry_catalog(), &path)?;
    let mut app = EditorApp::on_gpu(state, Arc::new(tyndall::nodes::registry()), None)
        .with_tools(tyndall::tools::registry());
    let ctx = egui::Context::default();
    let mut frame = eframe::Frame::_new_kittest();
    let mut step = |k: usize, events: Vec<egui::Event>| {
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(1600.0, 900.0),
            )),
            events: [
                vec![egui::Event::PointerMoved(egui::pos2(
                    600.0 + (k % 7) as f32,
                    400.0,
                ))],
                events,
            ]
            .concat(),
            ..Default::default()
        };
        let start = Instant::now();
        let out = ctx.run_ui(input, |ui| eframe::App::ui(&mut app, ui, &mut frame));
        let _ = ctx.tessellate(out.shapes, out.pixels_per_point);
        start.elapsed().as_secs_f64() * 1e3
    };
    let mut bare = |from: usize, events: Vec<egui::Event>| {
        step(from, events);
        for k in 1..10 {
            step(from + k, Vec::new());
        }
        let mut ms: Vec<f64> = (0..60).map(|k| step(from + 10 + k, Vec::new())).collect();
        ms.sort_by(f64::total_cmp);
        (ms[30], ms[54])
    };
    report("as opened, no AccessKit", bare(0, Vec::new()));
    let f = egui::Event::Key {
        key: egui::Key::F,
        physical_key: None,
        pressed: true,
        repeat: false,
        modifiers: Default::default(),
    };
    report("all framed, no AccessKit", bare(100, vec![f]));
    Ok(())
}

fn registry_catalog() -> tyndall::graph::Catalog {
    tyndall::nodes::registry().catalog().clone()
}
