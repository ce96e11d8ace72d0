//! The stroke-painting tool (id `stroke_painting`; shown under the parameters of a node naming
//! it, such as `LightMapSolve`): its views, the
//! brush (colour, width, eraser), and painting in the viewer. A view is added from the scene's
//! camera at the viewer's size; while painting is armed a drag over the viewer paints a stroke
//! for the active view, with pixel coordinates of the viewer's picture scaled to the view's
//! size. Painted strokes wait (drawn over the viewer) until "Solve" writes them into the node's
//! data block — one undoable step — which runs the solve in the evaluation worker (the top bar's
//! spinner is its progress; the solved light map is the node's thumbnail, its `residual` output
//! the convergence). "Discard" drops the waiting strokes.

use std::any::Any;

use eframe::egui;

use tyndall_editor::tool::{picture_pixel, stroke_points};
use tyndall_editor::{panel, EditorState, Tool, ToolContext};
use tyndall_nodes::light_map_solve::{SolveData, Stroke, View, ViewCamera};

/// The tool's own state.
pub struct StrokePanel {
    /// The view strokes go into.
    pub view: usize,
    /// Brush colour (linear RGB).
    pub colour: [f32; 3],
    /// Brush diameter in view pixels.
    pub width: f32,
    /// Paint erasing strokes.
    pub erase: bool,
    /// A drag in the viewer paints.
    pub armed: bool,
    /// Strokes painted since the last solve: (view index, stroke in that view's pixels).
    pub pending: Vec<(usize, Stroke)>,
}

impl Default for StrokePanel {
    fn default() -> Self {
        Self {
            view: 0,
            colour: [1.0, 0.4, 0.1],
            width: 12.0,
            erase: false,
            armed: false,
            pending: Vec::new(),
        }
    }
}

impl Tool for StrokePanel {
    fn id(&self) -> &'static str {
        "stroke_painting"
    }

    fn panel(&mut self, ui: &mut egui::Ui, cx: &mut ToolContext) -> Option<String> {
        show(ui, cx.state, cx.node, self, cx.view_size)
    }

    /// While armed, a drag paints a stroke; the waiting strokes are drawn over the picture.
    fn viewer(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        size: (u32, u32),
        cx: &mut ToolContext,
    ) -> Option<String> {
        let mut message = None;
        if self.armed {
            for (p, start) in stroke_points(ui, response) {
                let at = picture_pixel(response, size, p);
                if let Err(e) = paint(cx.state, cx.node, self, at, size, start) {
                    message = Some(e);
                }
            }
        }
        let painter = ui.painter_at(response.rect);
        let r = response.rect;
        for (s, (w, h)) in pending_in(cx.state, cx.node, self, size) {
            let (w, h) = (w.max(1) as f32, h.max(1) as f32);
            let to = |q: &[f32; 2]| r.min + egui::vec2(q[0] / w * r.width(), q[1] / h * r.height());
            let c8 = |v: f32| (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0) as u8;
            let c = if s.erase {
                egui::Color32::from_black_alpha(160)
            } else {
                egui::Color32::from_rgba_unmultiplied(
                    c8(s.colour[0]),
                    c8(s.colour[1]),
                    c8(s.colour[2]),
                    160,
                )
            };
            let width = (s.width / w * r.width()).max(1.0);
            let pts: Vec<egui::Pos2> = s.points.iter().map(to).collect();
            if pts.len() == 1 {
                painter.circle_filled(pts[0], width * 0.5, c);
            } else {
                painter.add(egui::Shape::line(pts, egui::Stroke::new(width, c)));
            }
        }
        message
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// The size of view `i` (a view not yet made takes the picture's size).
fn view_size_of(data: &SolveData, i: usize, picture: (u32, u32)) -> (u32, u32) {
    data.views.get(i).map_or(picture, |v| (v.width, v.height))
}

/// Paint: `start` begins a new waiting stroke at `point` (pixels of a `picture`-sized image),
/// otherwise the point extends the stroke begun last.
pub fn paint(
    state: &EditorState,
    id: &str,
    panel: &mut StrokePanel,
    point: [f32; 2],
    picture: (u32, u32),
    start: bool,
) -> Result<(), String> {
    let data = state.node_data::<SolveData>(id)?;
    let (w, h) = view_size_of(&data, panel.view, picture);
    let p = [
        point[0] * w as f32 / picture.0.max(1) as f32,
        point[1] * h as f32 / picture.1.max(1) as f32,
    ];
    match panel.pending.last_mut() {
        Some((_, s)) if !start => s.points.push(p),
        _ => panel.pending.push((
            panel.view,
            Stroke {
                colour: panel.colour,
                width: panel.width,
                points: vec![p],
                erase: panel.erase,
            },
        )),
    }
    Ok(())
}

/// Write the waiting strokes into the data block (one undoable step; a view is made from the
/// scene camera at the picture's size when there is none).
pub fn solve(
    state: &mut EditorState,
    id: &str,
    panel: &mut StrokePanel,
    picture: (u32, u32),
) -> Result<(), String> {
    let mut data = state.node_data::<SolveData>(id)?;
    for (view, stroke) in panel.pending.drain(..) {
        if data.views.is_empty() {
            data.views.push(View {
                camera: ViewCamera::Scene,
                width: picture.0,
                height: picture.1,
                strokes: vec![],
            });
        }
        let i = view.min(data.views.len() - 1);
        data.views[i].strokes.push(stroke);
    }
    state.store_node_data(id, &data, None)
}

/// The waiting strokes with the size of the view each belongs to.
pub fn pending_in(
    state: &EditorState,
    id: &str,
    panel: &StrokePanel,
    picture: (u32, u32),
) -> Vec<(Stroke, (u32, u32))> {
    let data = state.node_data::<SolveData>(id).unwrap_or_default();
    panel
        .pending
        .iter()
        .map(|(v, s)| (s.clone(), view_size_of(&data, *v, picture)))
        .collect()
}

/// Draw the panel for node `id`; returns a status message when an edit was refused.
pub fn show(
    ui: &mut egui::Ui,
    state: &mut EditorState,
    id: &str,
    panel: &mut StrokePanel,
    view_size: (u32, u32),
) -> Option<String> {
    ui.separator();
    ui.heading("Strokes");
    let mut data = panel::data_block::<SolveData>(ui, state, id)?;
    let before = data.clone();
    ui.horizontal(|ui| {
        ui.label("brush");
        ui.color_edit_button_rgb(&mut panel.colour);
        ui.add(
            egui::DragValue::new(&mut panel.width)
                .range(1.0..=200.0)
                .suffix(" px"),
        )
        .on_hover_text("brush diameter");
        ui.toggle_value(&mut panel.erase, "eraser");
        ui.toggle_value(&mut panel.armed, "Paint")
            .on_hover_text("Drag over the viewer to paint into the active view");
    });
    ui.horizontal(|ui| {
        if ui
            .button("Add view")
            .on_hover_text("A view from the scene's camera, at the viewer's size")
            .clicked()
        {
            data.views.push(View {
                camera: ViewCamera::Scene,
                width: view_size.0,
                height: view_size.1,
                strokes: vec![],
            });
            panel.view = data.views.len() - 1;
        }
        let total: usize = data.views.iter().map(|v| v.strokes.len()).sum();
        ui.label(format!("{} view(s), {total} stroke(s)", data.views.len()));
    });
    let mut solve_now = false;
    ui.horizontal(|ui| {
        let waiting = panel.pending.len();
        if ui
            .add_enabled(waiting > 0, egui::Button::new("Solve"))
            .on_hover_text("Add the painted strokes to the node and solve")
            .clicked()
        {
            solve_now = true;
        }
        if ui
            .add_enabled(waiting > 0, egui::Button::new("Discard"))
            .on_hover_text("Drop the strokes painted since the last solve")
            .clicked()
        {
            panel.pending.clear();
        }
        ui.label(format!("{waiting} stroke(s) waiting"));
    });
    view_list(ui, &mut data, panel);
    if data != before {
        if let Err(e) = state.store_node_data(id, &data, None) {
            return Some(e);
        }
    }
    if solve_now {
        return Some(match solve(state, id, panel, view_size) {
            Ok(()) => "solving the light map…".into(),
            Err(e) => e,
        });
    }
    None
}

/// The views, one row each: select, undo its last stroke, remove.
fn view_list(ui: &mut egui::Ui, data: &mut SolveData, panel: &mut StrokePanel) {
    let mut remove = None;
    for (i, v) in data.views.iter_mut().enumerate() {
        ui.horizontal(|ui| {
            let camera = match &v.camera {
                ViewCamera::Scene => "scene camera".to_string(),
                ViewCamera::Look { position, .. } => {
                    format!(
                        "camera at ({:.1}, {:.1}, {:.1})",
                        position[0], position[1], position[2]
                    )
                }
            };
            if ui
                .selectable_label(
                    panel.view == i,
                    format!("view {i}: {camera}, {}×{}", v.width, v.height),
                )
                .clicked()
            {
                panel.view = i;
            }
            ui.label(format!("{} stroke(s)", v.strokes.len()));
            if ui.small_button("undo stroke").clicked() {
                v.strokes.pop();
            }
            if ui.small_button("✕").on_hover_text("remove view").clicked() {
                remove = Some(i);
            }
        });
    }
    if let Some(i) = remove {
        data.views.remove(i);
        panel.view = panel.view.min(data.views.len().saturating_sub(1));
    }
}
