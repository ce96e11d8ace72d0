//! Helpers for the editor's kittest tests.

use std::path::Path;
use std::sync::Arc;

use eframe::egui;
use egui_kittest::Harness;
use tyndall::editor::{EditorApp, EditorState};

/// An editor window of `size` points on the graph file at `path`, after its first frames.
pub fn open(path: &Path, size: (f32, f32)) -> Harness<'static, EditorApp> {
    let registry = Arc::new(tyndall::nodes::registry());
    let state = EditorState::open(registry.catalog().clone(), path).expect("open");
    let mut h = Harness::builder()
        .with_size(eframe::egui::vec2(size.0, size.1))
        .wgpu()
        .build_eframe(move |_cc| {
            EditorApp::new(state, registry).with_tools(tyndall::tools::registry())
        });
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

/// Press or release the primary button at `pos`.
pub fn press(h: &mut Harness<'static, EditorApp>, pos: egui::Pos2, pressed: bool) {
    h.event(egui::Event::PointerButton {
        pos,
        button: egui::PointerButton::Primary,
        pressed,
        modifiers: egui::Modifiers::NONE,
    });
}

/// A drag as a user makes it: move to `from`, press, `moves` equal moves adding up to `by`
/// (one frame each), release.
pub fn drag(h: &mut Harness<'static, EditorApp>, from: egui::Pos2, by: egui::Vec2, moves: u32) {
    h.event(egui::Event::PointerMoved(from));
    h.run_steps(1);
    press(h, from, true);
    h.run_steps(1);
    for k in 1..=moves {
        h.event(egui::Event::PointerMoved(
            from + by * (k as f32 / moves as f32),
        ));
        h.run_steps(1);
    }
    press(h, from + by, false);
    h.run_steps(3);
}

/// [`open`], with the harness drawing on a device of the evaluation's adapter created with
/// Tyndall's request (as `tyndall edit` creates its window's): the editor moves its evaluation
/// onto that device and draws pictures from their textures (not on GL, where it cannot).
pub fn open_sharing(path: &Path, size: (f32, f32)) -> Harness<'static, EditorApp> {
    let registry = Arc::new(tyndall::nodes::registry());
    let state = EditorState::open(registry.catalog().clone(), path).expect("open");
    let gpu = crate::common::gpu().expect("adapter");
    let (name, backend) = (gpu.info.name.clone(), gpu.info.backend);
    let mut setup = eframe::egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    setup.instance_descriptor.backends = backend.into();
    setup.instance_descriptor.flags =
        tyndall::gpu::instance_flags(tyndall::gpu::GpuOptions::from_env().validation);
    setup.native_adapter_selector = Some(Arc::new(move |adapters, _surface| {
        adapters
            .iter()
            .find(|a| {
                let i = a.get_info();
                i.name == name && i.backend == backend
            })
            .cloned()
            .ok_or_else(|| "the evaluation's adapter is not listed".to_string())
    }));
    setup.device_descriptor = Arc::new(|adapter| {
        let (features, limits) = tyndall::gpu::device_request(adapter);
        wgpu::DeviceDescriptor {
            label: Some("editor test window"),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        }
    });
    let renderer = egui_kittest::wgpu::WgpuTestRenderer::from_setup(setup.into());
    let mut h = Harness::builder()
        .with_size(eframe::egui::vec2(size.0, size.1))
        .renderer(renderer)
        .build_eframe(move |_cc| {
            EditorApp::new(state, registry).with_tools(tyndall::tools::registry())
        });
    h.run_steps(4);
    h
}
