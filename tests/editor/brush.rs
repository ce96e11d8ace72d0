//! The editor's 3D brush, driven like a user would (egui_kittest): a `BlendVolume` selected
//! shows the nearest picture downstream; drags over it leave splats on the camera-facing plane
//! in the chosen volume's data block, one undo step per drag; the eraser and the choice of
//! volume.

use crate::common;
use std::path::Path;

use eframe::egui;
use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use tyndall::editor::EditorApp;
use tyndall::nodes::blend_volume::BlendData;
use tyndall::tools::splat_brush::{camera_rotation, view_depth, BrushPanel};

use crate::common::editor::{drag, settle};

fn splats(h: &Harness<'static, EditorApp>, id: &str) -> BlendData {
    h.state()
        .state
        .graph()
        .node(id)
        .and_then(|n| n.data.as_ref())
        .map(|d| d.parse().expect("BlendData"))
        .unwrap_or_default()
}

/// The painted-heterogeneity preset as a flat graph (the preset before it used groups): the
/// brush is aimed from the Heterogeneity node, which the preset now keeps inside its group.
fn open_fence(dir: &Path) -> Harness<'static, EditorApp> {
    let text = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/flat/fence_painted.ron"),
    )
    .expect("preset");
    let path = dir.join("g.ron");
    std::fs::write(&path, text).expect("write graph");
    common::editor::open(&path, (1400.0, 1000.0))
}

#[test]
fn brush_drags_leave_splats_on_the_plane_in_one_undo_step() {
    if common::gpu_for(&["BlendVolume"]).is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = open_fence(dir.path());
    h.state_mut().selected = Some("painted_alpha".into());
    settle(&mut h);
    assert_eq!(
        h.state().viewed().as_deref(),
        Some("het"),
        "a volume shows the nearest picture downstream"
    );
    {
        let b = &mut brush_mut(&mut h);
        b.depth = 12.0;
        b.radii = [0.5, 0.4, 2.0];
        b.opacity = 0.8;
        b.hardness = 0.25;
    }
    h.get_by_label("Paint").click();
    // Armed, the brush asks the worker for the scene's depth; it paints once that arrived.
    settle(&mut h);
    let before = splats(&h, "painted_alpha").splats.len();
    let steps = h.state().state.undo_depth();
    let rect = h.get_by_label("viewer picture").rect();
    let a = rect.center() - egui::vec2(60.0, 10.0);
    drag(&mut h, a, egui::vec2(120.0, 24.0), 8);
    let view = h
        .state()
        .tool::<BrushPanel>()
        .expect("the brush tool")
        .view()
        .expect("the brush rendered its view")
        .clone();
    assert_eq!(view.size, (480, 270));
    let d = splats(&h, "painted_alpha");
    let new = &d.splats[before..];
    // 120 points of a picture shown rect.width() points wide for 480 pixels at 12 m: several
    // radii long, so every one of the 9 pointer positions is farther than the spacing (0.2 m).
    assert_eq!(new.len(), 9, "{new:?}");
    let rot = camera_rotation(&view.camera).to_array();
    for s in new {
        let c = glam::Vec3::from_array(s.centre);
        assert!((view_depth(&view.camera, c) - 12.0).abs() < 1e-3, "{s:?}");
        assert_eq!(
            (s.radii, s.opacity, s.hardness, s.erase),
            ([0.5, 0.4, 2.0], 0.8, 0.25, false)
        );
        assert!(rot
            .iter()
            .zip(s.rotation)
            .all(|(a, b)| (a - b).abs() < 1e-6));
    }
    // The first splat lies under the pixel pressed.
    let c = view
        .camera
        .view_proj()
        .project_point3(glam::Vec3::from_array(new[0].centre));
    let px = [(c.x + 1.0) * 240.0, (1.0 - c.y) * 135.0];
    let want = [
        (a.x - rect.min.x) / rect.width() * 480.0,
        (a.y - rect.min.y) / rect.height() * 270.0,
    ];
    assert!(
        (px[0] - want[0]).abs() < 0.5 && (px[1] - want[1]).abs() < 0.5,
        "{px:?} vs {want:?}"
    );
    assert_eq!(
        h.state().state.undo_depth(),
        steps + 1,
        "one drag, one step"
    );
    h.get_by_label("Undo").click();
    h.run_steps(2);
    assert_eq!(splats(&h, "painted_alpha").splats.len(), before);
    h.get_by_label("Redo").click();
    h.run_steps(2);
    assert_eq!(splats(&h, "painted_alpha").splats.len(), before + 9);

    // The eraser: a second drag is a second step, of erasing splats.
    h.get_by_label("eraser").click();
    h.run_steps(2);
    drag(&mut h, a, egui::vec2(0.0, 40.0), 4);
    let d = splats(&h, "painted_alpha");
    assert!(d.splats.len() > before + 9);
    assert!(d.splats[before + 9..].iter().all(|s| s.erase));
    assert_eq!(h.state().state.undo_depth(), steps + 2);
    // The painted graph still evaluates.
    settle(&mut h);
    let errors: Vec<_> = h
        .state()
        .reports
        .iter()
        .filter_map(|(id, r)| r.error.as_ref().map(|e| format!("{id}: {e}")))
        .collect();
    assert!(errors.is_empty(), "{errors:?}");
}

#[test]
fn the_brush_paints_into_the_chosen_volume() {
    if common::gpu_for(&["BlendVolume"]).is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = open_fence(dir.path());
    let other = h
        .state_mut()
        .state
        .add_node("BlendVolume", [0.0, 600.0])
        .expect("add");
    h.state_mut().selected = Some("het".into());
    settle(&mut h);
    // From Heterogeneity, the default volume is the one feeding it.
    h.get_by_label("Paint").click();
    // Armed, the brush asks the worker for the scene's depth; it paints once that arrived.
    settle(&mut h);
    let default = tyndall::tools::splat_brush::target_for(
        &tyndall::nodes::registry(),
        h.state().state.graph(),
        brush(&h),
        "het",
    );
    assert_eq!(default.as_deref(), Some("painted_alpha"));
    brush_mut(&mut h).target = Some(other.clone());
    settle(&mut h);
    let before = splats(&h, "painted_alpha").splats.len();
    let rect = h.get_by_label("viewer picture").rect();
    drag(&mut h, rect.center(), egui::vec2(30.0, 0.0), 3);
    assert_eq!(
        splats(&h, "painted_alpha").splats.len(),
        before,
        "untouched"
    );
    assert!(!splats(&h, &other).splats.is_empty(), "painted");
}

/// The brush tool's state in the window.
fn brush<'a>(h: &'a Harness<'static, EditorApp>) -> &'a BrushPanel {
    h.state().tool::<BrushPanel>().expect("the brush tool")
}

/// The brush tool's state, to change it.
fn brush_mut<'a>(h: &'a mut Harness<'static, EditorApp>) -> &'a mut BrushPanel {
    h.state_mut()
        .tool_mut::<BrushPanel>()
        .expect("the brush tool")
}
