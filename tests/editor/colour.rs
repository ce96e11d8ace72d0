//! The editor's colour panels, driven like a user would (egui_kittest): the transfer-function
//! layer list, the TF square (click adds a constraint, drag moves it in one undo step), 3D
//! constraints picked in the viewer, and stroke painting for the light-map solve.

use crate::common;
use std::path::Path;

use eframe::egui;
use egui_kittest::kittest::Queryable;
use egui_kittest::Harness;
use tyndall::editor::EditorApp;
use tyndall::nodes::light_map_solve::SolveData;
use tyndall::nodes::transfer_function::{Layer, TfData};
use tyndall::tools::layer_list::TfPanel;
use tyndall::tools::stroke_painting::StrokePanel;

fn harness_for(text: &str, dir: &Path) -> Harness<'static, EditorApp> {
    let path = dir.join("g.ron");
    std::fs::write(&path, text).expect("write graph");
    common::editor::open(&path, (1400.0, 1000.0))
}

use crate::common::editor::{drag, settle};

fn tf_data(h: &Harness<'static, EditorApp>, id: &str) -> TfData {
    h.state()
        .state
        .graph()
        .node(id)
        .and_then(|n| n.data.as_ref())
        .map(|d| d.parse().expect("TfData"))
        .unwrap_or_default()
}

/// The editor on [`TF_ONLY`] with its TransferFunction selected.
fn tf_selected(dir: &Path) -> Harness<'static, EditorApp> {
    let mut h = harness_for(TF_ONLY, dir);
    h.state_mut().selected = Some("tf".into());
    h.run_steps(3);
    h
}

const TF_ONLY: &str = r#"(version: 2, nodes: {
    "tf": (kind: "TransferFunction", params: {"resolution": 16},
           data: (layers: [(layer: Solid(colour: (0.1, 0.2, 0.3, 1.0)))])),
})"#;

/// The opacity field of the top layer (drawn first, highest on screen): the node labelled "α"
/// that has a value.
fn top_field<'a>(h: &'a Harness<'static, EditorApp>) -> egui_kittest::Node<'a> {
    h.get_all_by_label("α")
        .filter(|n| n.value().is_some())
        .min_by(|a, b| a.rect().top().total_cmp(&b.rect().top()))
        .expect("opacity field")
}

#[test]
fn tf_layers_add_reorder_remove_and_undo() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = tf_selected(dir.path());
    h.get_by_label("Add layer").click();
    h.run_steps(2);
    h.get_by_label("Gradient").click();
    h.run_steps(2);
    let d = tf_data(&h, "tf");
    assert_eq!(d.layers.len(), 2);
    assert!(matches!(d.layers[1].layer, Layer::Gradient { .. }));
    // The list shows the top layer first: its "▼" moves the gradient below the solid.
    h.get_all_by_label("▼").next().expect("▼").click();
    h.run_steps(2);
    let d = tf_data(&h, "tf");
    assert!(matches!(d.layers[0].layer, Layer::Gradient { .. }));
    assert!(matches!(d.layers[1].layer, Layer::Solid { .. }));
    // Remove the top (solid) layer, then undo it.
    h.get_all_by_label("✕").next().expect("✕").click();
    h.run_steps(2);
    assert_eq!(tf_data(&h, "tf").layers.len(), 1);
    h.get_by_label("Undo").click();
    h.run_steps(2);
    assert_eq!(tf_data(&h, "tf").layers.len(), 2, "undo restores the layer");
    // Blend of the top layer (the solid): Alpha → Multiply from its combo box.
    h.get_all_by_value("Alpha")
        .next()
        .expect("blend combo")
        .click();
    h.run_steps(2);
    h.get_by_label("Multiply").click();
    h.run_steps(2);
    let d = tf_data(&h, "tf");
    assert_eq!(
        d.layers[1].blend,
        tyndall::nodes::transfer_function::Blend::Multiply
    );
    // Opacity of the top layer (drawn first, highest on screen), typed into its field.
    top_field(&h).click();
    h.run_steps(2);
    top_field(&h).type_text("0.25");
    h.run_steps(1);
    h.key_press(egui::Key::Enter);
    h.run_steps(2);
    let o = tf_data(&h, "tf")
        .layers
        .iter()
        .map(|l| l.opacity)
        .collect::<Vec<_>>();
    assert!((o[1] - 0.25).abs() < 1e-6, "{o:?}");
    // The solid's colour well opens egui's picker on the layer's colour (linear 0.1, 0.2, 0.3
    // is sRGB 89, 124, 149). (Typing into the picker's fields did not register under kittest;
    // the edit path is the same `changed()` → data block as the other widgets.)
    // Colour wells from the top: the brush, then the top layer's (the solid), then the
    // gradient's two.
    let mut wells: Vec<_> = h
        .get_all_by_role(egui::accesskit::Role::ColorWell)
        .collect();
    wells.sort_by(|a, b| a.rect().top().total_cmp(&b.rect().top()));
    assert_eq!(wells.len(), 4);
    wells[1].click();
    h.run_steps(3);
    let fields: Vec<String> = h
        .get_all_by_role(egui::accesskit::Role::SpinButton)
        .filter_map(|n| n.value())
        .filter(|v| v.len() > 2 && v.as_bytes()[1] == b' ')
        .collect();
    assert_eq!(fields, ["R 89", "G 124", "B 149", "A 255"]);
    h.key_press(egui::Key::Escape);
    h.run_steps(2);
    // Key the stack at this frame: the data becomes key-frames, shown on the timeline.
    h.get_by_label("Key stack").click();
    h.run_steps(2);
    let d = tf_data(&h, "tf");
    assert_eq!(d.keys.len(), 1);
    assert!(d.layers.is_empty());
}

#[test]
fn tf_square_click_adds_and_drag_moves_a_constraint_in_one_step() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = tf_selected(dir.path());
    let rect = h.get_by_label("TF square").rect();
    h.get_by_label("TF square").click();
    h.run_steps(3);
    let d = tf_data(&h, "tf");
    let Layer::Diffusion { constraints } = &d.layers[1].layer else {
        panic!("a click adds a diffusion layer with the constraint: {d:?}");
    };
    assert_eq!(constraints.len(), 1);
    assert!((constraints[0].at[0] - 0.5).abs() < 0.02 && (constraints[0].at[1] - 0.5).abs() < 0.02);
    let steps = h.state().state.undo_depth();
    // Drag the marker from the centre by (+40, +20) points in small moves.
    drag(&mut h, rect.center(), egui::vec2(40.0, 20.0), 10);
    let d = tf_data(&h, "tf");
    let Layer::Diffusion { constraints } = &d.layers[1].layer else {
        panic!("diffusion layer");
    };
    let want = [0.5 + 40.0 / rect.width(), 0.5 + 20.0 / rect.height()];
    assert!(
        (constraints[0].at[0] - want[0]).abs() < 0.02
            && (constraints[0].at[1] - want[1]).abs() < 0.02,
        "{:?} vs {want:?}",
        constraints[0].at
    );
    assert_eq!(
        h.state().state.undo_depth(),
        steps + 1,
        "the drag is one undo step"
    );
    h.get_by_label("Undo").click();
    h.run_steps(2);
    let d = tf_data(&h, "tf");
    let Layer::Diffusion { constraints } = &d.layers[1].layer else {
        panic!("diffusion layer");
    };
    assert!(
        (constraints[0].at[0] - 0.5).abs() < 0.02,
        "undo returns to before the drag"
    );
}

const TREE_TF: &str = r#"(version: 2, nodes: {
    "scene": (kind: "Scene", params: {"name": "tree"}),
    "shadow": (kind: "ShadowMap", params: {"resolution": 512}),
    "gbuffer": (kind: "GBuffer"),
    "scatter": (kind: "SingleScattering", params: {"steps": 16}),
    "tf": (kind: "TransferFunction", params: {"resolution": 32, "depth_range": "auto"},
           data: (layers: [(layer: Diffusion(constraints: []))])),
}, edges: [
    ("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"), ("scene.scene", "tf.scene"),
    ("shadow.map", "scatter.shadow"), ("gbuffer.depth", "scatter.depth"),
    ("scatter.visibility", "tf.visibility"), ("scatter.depth", "tf.depth"),
])"#;

#[test]
fn viewer_click_adds_an_anchored_3d_constraint() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness_for(TREE_TF, dir.path());
    h.state_mut().selected = Some("tf".into());
    settle(&mut h);
    h.get_by_label("3D constraint").click();
    h.run_steps(2);
    assert!(h.state().tool::<TfPanel>().expect("the layer list").arm_3d);
    // The centre of the viewer's 480×270 picture: the tree's trunk.
    h.get_by_label("viewer picture").click();
    // The worker picks the surface; the constraint lands when its answer is taken.
    settle(&mut h);
    let d = tf_data(&h, "tf");
    let Layer::Diffusion { constraints } = &d.layers[0].layer else {
        panic!("diffusion layer");
    };
    assert_eq!(constraints.len(), 1, "status: {}", h.state().status);
    let a = constraints[0].anchor.as_ref().expect("anchored");
    assert_eq!(a.object, "trunk");
    assert!((a.bary.iter().sum::<f32>() - 1.0).abs() < 1e-4);
    h.get_by_label("Undo").click();
    h.run_steps(2);
    let d = tf_data(&h, "tf");
    let Layer::Diffusion { constraints } = &d.layers[0].layer else {
        panic!("diffusion layer");
    };
    assert!(constraints.is_empty(), "undo removes the 3D constraint");
}

const WINDOW_SOLVE: &str = r#"(version: 2, nodes: {
    "scene": (kind: "Scene", params: {"name": "window"}),
    "shadow": (kind: "ShadowMap", params: {"resolution": 256}),
    "gbuffer": (kind: "GBuffer"),
    "scatter": (kind: "SingleScattering", params: {"steps": 16}),
    "solve": (kind: "LightMapSolve", params: {"resolution": 16, "iterations": 2, "steps": 16}),
}, edges: [
    ("scene.scene", "shadow.scene"), ("scene.scene", "gbuffer.scene"), ("scene.scene", "solve.scene"),
    ("shadow.map", "solve.shadow"), ("shadow.map", "scatter.shadow"), ("gbuffer.depth", "scatter.depth"),
])"#;

#[test]
fn painting_in_the_viewer_adds_one_stroke_per_drag() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let mut h = harness_for(WINDOW_SOLVE, dir.path());
    // The viewer shows the scattering (pin 1) while the solve node is selected.
    h.state_mut().pins[0] = Some("scatter".into());
    h.state_mut().active_pin = Some(0);
    h.state_mut().selected = Some("solve".into());
    settle(&mut h);
    h.get_by_label("Add view").click();
    h.run_steps(2);
    h.get_by_label("Paint").click();
    h.run_steps(2);
    let rect = h.get_by_label("viewer picture").rect();
    let steps = h.state().state.undo_depth();
    drag(
        &mut h,
        rect.center() - egui::vec2(60.0, 0.0),
        egui::vec2(120.0, 24.0),
        8,
    );
    let data = |h: &Harness<'static, EditorApp>| -> SolveData {
        h.state()
            .state
            .graph()
            .node("solve")
            .and_then(|n| n.data.as_ref())
            .expect("data")
            .parse()
            .expect("SolveData")
    };
    // The stroke waits (drawn over the viewer) until Solve; then it is one undoable step.
    assert_eq!(
        h.state()
            .tool::<StrokePanel>()
            .expect("stroke painting")
            .pending
            .len(),
        1,
        "one drag, one stroke"
    );
    assert!(data(&h).views[0].strokes.is_empty());
    h.get_by_label("Solve").click();
    h.run_steps(3);
    assert!(h
        .state()
        .tool::<StrokePanel>()
        .expect("stroke painting")
        .pending
        .is_empty());
    let d = data(&h);
    assert_eq!(d.views.len(), 1);
    assert_eq!((d.views[0].width, d.views[0].height), (480, 270));
    assert_eq!(d.views[0].strokes.len(), 1);
    let s = &d.views[0].strokes[0];
    assert!(s.points.len() >= 5, "{:?}", s.points);
    // Points are in the view's pixels: the drag spans 120 points of a picture shown
    // rect.width() points wide for 480 pixels.
    let span = s.points.last().expect("last")[0] - s.points[0][0];
    let want = 120.0 * 480.0 / rect.width();
    // The stroke starts where the button was pressed and ends where it was released: only
    // float rounding separates the two.
    assert!((span - want).abs() < 0.01 * want, "{span} vs {want}");
    assert_eq!(
        h.state().state.undo_depth(),
        steps + 1,
        "the solve is one undo step"
    );
    settle(&mut h);
    let p = h
        .state()
        .progress
        .clone()
        .expect("the solve reported its progress");
    assert_eq!((p.node.as_str(), p.done, p.total), ("solve", 2, 2));
    assert!(p.message.contains("residual"), "{}", p.message);
    settle(&mut h);
    assert!(
        h.state()
            .reports
            .get("solve")
            .is_some_and(|r| r.error.is_none()),
        "the solve ran on the new stroke: {:?}",
        h.state().reports.get("solve").map(|r| r.error.clone())
    );
}
