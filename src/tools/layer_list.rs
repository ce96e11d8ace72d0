//! The layer-list tool (id `layer_list`; shown under the parameters of a node naming it, such
//! as `TransferFunction`):
//! the layer list (add, remove, reorder, blend, opacity, colours), the TF square (a preview of
//! the baked table; a click adds a diffusion constraint, a drag moves one), key-frames of the
//! layer stack, and the arming of 3D constraints (a click in the viewer adds a constraint
//! anchored to the surface under that pixel, picked by the editor's evaluation worker). Every edit is one undoable step on the node's data
//! block; a drag is one step.

use std::any::Any;

use eframe::egui;

use tyndall_editor::{panel, EditorState, Tool, ToolContext};
use tyndall_engine::eval::pick::{pick, Pick};
use tyndall_engine::eval::EvalOptions;
use tyndall_nodes::transfer_function::{
    bake_reference, layer_name, Anchor, Blend, Constraint, Layer, LayerEntry, TfData, TfKey,
};

/// Side of the TF square on screen, in points.
pub const SQUARE: f32 = 200.0;
/// Resolution of the square's CPU preview.
const PREVIEW: u32 = 64;

/// The tool's own state (what is selected, the brush colour, the preview texture).
pub struct TfPanel {
    /// The layer edited by clicks in the square (index in the stack).
    pub layer: usize,
    /// Colour of new constraints.
    pub brush: [f32; 4],
    /// A click in the viewer adds an anchored 3D constraint.
    pub arm_3d: bool,
    /// The node (id of the graph shown) and time a 3D constraint is being picked for, while
    /// the worker evaluates the pick.
    picking: Option<(String, f64)>,
    dragging: Option<usize>,
    preview: Option<(String, egui::TextureHandle)>,
}

impl Default for TfPanel {
    fn default() -> Self {
        Self {
            layer: 0,
            brush: [1.0, 0.5, 0.1, 1.0],
            arm_3d: false,
            picking: None,
            dragging: None,
            preview: None,
        }
    }
}

impl Tool for TfPanel {
    fn id(&self) -> &'static str {
        "layer_list"
    }

    fn panel(&mut self, ui: &mut egui::Ui, cx: &mut ToolContext) -> Option<String> {
        show(ui, cx.state, cx.node, cx.time, self)
    }

    /// While 3D constraints are armed, a click adds one anchored to the surface under it.
    fn viewer(
        &mut self,
        _ui: &egui::Ui,
        response: &egui::Response,
        size: (u32, u32),
        cx: &mut ToolContext,
    ) -> Option<String> {
        if let Some(answer) = cx.jobs.take::<Pick>(PICK_JOB) {
            let picked = answer.and_then(|p| add_3d_constraint(cx, self, &p));
            self.picking = None;
            return Some(picked.unwrap_or_else(|e| e));
        }
        if !self.arm_3d {
            return None;
        }
        let (true, Some(p)) = (response.clicked(), response.interact_pointer_pos()) else {
            return None;
        };
        let [x, y] = tyndall_editor::tool::picture_pixel(response, size, p);
        let px = ((x as u32).min(size.0 - 1), (y as u32).min(size.1 - 1));
        ask_pick(cx, px, size);
        self.picking = Some((cx.node.to_string(), cx.time));
        Some(format!("picking the surface under pixel {px:?}…"))
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// The key of the 3D constraint's pick job.
const PICK_JOB: &str = "layer_list/pick";

/// A click in the viewer while 3D constraints are armed: ask the evaluation worker to pick
/// the surface under `pixel` of a `size` picture, reading the node `cx.node`'s inputs.
fn ask_pick(cx: &mut ToolContext, pixel: (u32, u32), size: (u32, u32)) {
    let graph = cx.state.root().clone();
    let node = cx.state.full_id(cx.node);
    let opts = EvalOptions {
        time: cx.time,
        size,
        ..Default::default()
    };
    cx.jobs.ask(
        PICK_JOB,
        Box::new(move |ev| {
            pick(ev, &graph, Some(&node), pixel, &opts)
                .map(|p| Box::new(p) as Box<dyn Any + Send>)
                .map_err(|e| e.to_string())
        }),
    );
}

/// The pick `p` answered: add a constraint anchored to its surface point, in the brush colour,
/// to the panel's layer of the node the pick was asked for. Returns what was added.
pub fn add_3d_constraint(
    cx: &mut ToolContext,
    panel: &mut TfPanel,
    p: &Pick,
) -> Result<String, String> {
    let (id, time) = panel
        .picking
        .clone()
        .unwrap_or_else(|| (cx.node.to_string(), cx.time));
    let s = p
        .surface
        .as_ref()
        .ok_or("no surface under this pixel (sky): nothing to anchor to")?;
    let tf = p.tf.as_ref().ok_or("not a TransferFunction")?;
    let mut data = cx.state.node_data::<TfData>(&id)?;
    let stack = editable(&mut data, time).ok_or("add a key at this frame to edit the stack")?;
    let c = Constraint {
        at: [tf.u, tf.v],
        colour: panel.brush,
        anchor: Some(Anchor {
            object: s.object.clone(),
            triangle: s.triangle,
            bary: s.bary,
        }),
    };
    panel.layer = add_constraint(stack, panel.layer, c);
    cx.state.store_node_data(&id, &data, None)?;
    Ok(format!(
        "3D constraint on {:?} triangle {} at V̄ {:.3}, depth {:.2} m",
        s.object, s.triangle, p.visibility, p.depth
    ))
}

/// The stack edited at `time`: the plain layers, or the key at exactly `time`; `None` when the
/// stack is key-framed and no key sits at `time` (it is then shown interpolated, read-only).
pub fn editable(data: &mut TfData, time: f64) -> Option<&mut Vec<LayerEntry>> {
    if data.keys.is_empty() {
        return Some(&mut data.layers);
    }
    data.keys
        .iter_mut()
        .find(|k| k.t == time)
        .map(|k| &mut k.layers)
}

/// Add a constraint to the stack's diffusion layer `layer` (or, when that layer is not a
/// diffusion layer, to a new diffusion layer on top); returns the layer it went to.
pub fn add_constraint(stack: &mut Vec<LayerEntry>, layer: usize, c: Constraint) -> usize {
    if let Some(LayerEntry {
        layer: Layer::Diffusion { constraints },
        ..
    }) = stack.get_mut(layer)
    {
        constraints.push(c);
        return layer;
    }
    stack.push(LayerEntry {
        layer: Layer::Diffusion {
            constraints: vec![c],
        },
        blend: Blend::Alpha,
        opacity: 1.0,
    });
    stack.len() - 1
}

fn new_layer(kind: &str, brush: [f32; 4]) -> Layer {
    match kind {
        "Gradient" => Layer::Gradient {
            from: [0.0, 0.0],
            to: [1.0, 0.0],
            from_colour: [0.0, 0.0, 0.0, 1.0],
            to_colour: brush,
        },
        "Diffusion" => Layer::Diffusion {
            constraints: vec![],
        },
        "Image" => Layer::Image {
            path: "tf.png".into(),
        },
        _ => Layer::Solid { colour: brush },
    }
}

fn colour_button(ui: &mut egui::Ui, c: &mut [f32; 4]) -> bool {
    ui.color_edit_button_rgba_unmultiplied(c).changed()
}

/// Draw the panel for node `id` at `time`; returns a status message when an edit was refused.
pub fn show(
    ui: &mut egui::Ui,
    state: &mut EditorState,
    id: &str,
    time: f64,
    panel: &mut TfPanel,
) -> Option<String> {
    ui.separator();
    ui.heading("Transfer function");
    let mut data = panel::data_block::<TfData>(ui, state, id)?;
    let before = data.clone();
    let mut message = key_bar(ui, &mut data, time);
    ui.horizontal(|ui| {
        ui.label("brush");
        colour_button(ui, &mut panel.brush);
        ui.toggle_value(&mut panel.arm_3d, "3D constraint")
            .on_hover_text(
                "Click in the viewer to add a constraint anchored to that surface point",
            );
    });
    let (merge, refused) = constraint_field(ui, state, &mut data, time, panel);
    message = message.or(refused);
    layer_list(ui, &mut data, time, panel);
    if data != before {
        if let Err(e) = state.store_node_data(id, &data, merge) {
            message = Some(e);
        }
    }
    message
}

/// The key-frame buttons of the stack (key it, add or remove a key at this frame).
fn key_bar(ui: &mut egui::Ui, data: &mut TfData, time: f64) -> Option<String> {
    let mut message = None;
    ui.horizontal(|ui| {
        if data.keys.is_empty() {
            if ui
                .button("Key stack")
                .on_hover_text("Turn the stack into key-frames, with a key at this frame")
                .clicked()
            {
                data.keys.push(TfKey {
                    t: time,
                    layers: std::mem::take(&mut data.layers),
                });
            }
        } else if data.keys.iter().any(|k| k.t == time) {
            if ui.button("Remove key").clicked() {
                data.keys.retain(|k| k.t != time);
                if data.keys.len() == 1 {
                    data.layers = data.keys.remove(0).layers;
                }
            }
        } else if ui
            .button("Add key")
            .on_hover_text("Key the interpolated stack at this frame")
            .clicked()
        {
            match data.stack_at(time) {
                Ok(layers) => data.keys.push(TfKey { t: time, layers }),
                Err(e) => message = Some(e),
            }
        }
        let keys: Vec<String> = data.keys.iter().map(|k| format!("{}", k.t)).collect();
        if !keys.is_empty() {
            ui.label(format!("keys at {}", keys.join(", ")));
        }
    });
    message
}

/// The TF square: the baked preview with the selected diffusion layer's constraints — a click
/// adds one at the brush colour, a drag moves one. Returns the undo-merge tag of a drag in
/// progress and a refusal message.
fn constraint_field(
    ui: &mut egui::Ui,
    state: &mut EditorState,
    data: &mut TfData,
    time: f64,
    panel: &mut TfPanel,
) -> (Option<&'static str>, Option<String>) {
    let mut merge: Option<&'static str> = None;
    let mut message = None;
    let shown = data.stack_at(time).unwrap_or_default();
    preview(ui, &shown, panel);
    let (rect, response) =
        ui.allocate_exact_size(egui::vec2(SQUARE, SQUARE), egui::Sense::click_and_drag());
    let response = response.on_hover_text(
        "x: average visibility V̄, y: depth (down = far). Click: add a constraint; drag: move one",
    );
    response.widget_info(|| egui::WidgetInfo::labeled(egui::WidgetType::Other, true, "TF square"));
    let painter = ui.painter_at(rect);
    if let Some((_, tex)) = &panel.preview {
        painter.image(
            tex.id(),
            rect,
            egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
            egui::Color32::WHITE,
        );
    }
    let to_screen = |at: [f32; 2]| rect.min + egui::vec2(at[0], at[1]) * rect.size();
    let to_tf = |p: egui::Pos2| {
        let r = (p - rect.min) / rect.size();
        [r.x.clamp(0.0, 1.0), r.y.clamp(0.0, 1.0)]
    };
    let markers = draw_constraints(&painter, &shown, panel.layer, to_screen);
    let near = |pos: egui::Pos2| {
        markers
            .iter()
            .filter(|(_, p)| p.distance(pos) <= 8.0)
            .min_by(|a, b| a.1.distance(pos).total_cmp(&b.1.distance(pos)))
            .map(|(i, _)| *i)
    };
    if response.drag_started() {
        // Where the button went down (egui reports a drag only after the pointer has moved).
        let origin = ui.input(|i| i.pointer.press_origin());
        panel.dragging = origin.or(response.interact_pointer_pos()).and_then(near);
    }
    if let (Some(i), Some(pos)) = (panel.dragging, response.interact_pointer_pos()) {
        if response.dragged() {
            if let Some(stack) = editable(data, time) {
                if let Some(LayerEntry {
                    layer: Layer::Diffusion { constraints },
                    ..
                }) = stack.get_mut(panel.layer)
                {
                    if let Some(c) = constraints.get_mut(i) {
                        c.at = to_tf(pos);
                        merge = Some("drag");
                    }
                }
            }
        }
    }
    if response.drag_stopped() {
        panel.dragging = None;
        state.end_merge();
    }
    if response.clicked() {
        if let Some(pos) = response.interact_pointer_pos() {
            if near(pos).is_none() {
                match editable(data, time) {
                    Some(stack) => {
                        let c = Constraint {
                            at: to_tf(pos),
                            colour: panel.brush,
                            anchor: None,
                        };
                        panel.layer = add_constraint(stack, panel.layer, c);
                    }
                    None => message = Some("add a key at this frame to edit the stack".into()),
                }
            }
        }
    }
    (merge, message)
}

/// The layer list, top of the stack first: add, select, blend, opacity, reorder, remove, and
/// each layer's own settings.
fn layer_list(ui: &mut egui::Ui, data: &mut TfData, time: f64, panel: &mut TfPanel) {
    let read_only = editable(data, time).is_none();
    ui.horizontal(|ui| {
        ui.label("Layers");
        ui.menu_button("Add layer", |ui| {
            for kind in ["Solid", "Gradient", "Diffusion", "Image"] {
                if ui.button(kind).clicked() {
                    if let Some(stack) = editable(data, time) {
                        stack.push(LayerEntry {
                            layer: new_layer(kind, panel.brush),
                            blend: Blend::Alpha,
                            opacity: 1.0,
                        });
                        panel.layer = stack.len() - 1;
                    }
                    ui.close();
                }
            }
        });
    });
    if read_only {
        ui.label("(between keys: the stack shown is interpolated; add a key to edit it)");
    } else if let Some(stack) = editable(data, time) {
        let n = stack.len();
        let mut action: Option<(&str, usize)> = None;
        for i in (0..n).rev() {
            if let Some(a) = layer_row(ui, i, n, &mut stack[i], panel) {
                action = Some(a);
            }
        }
        match action {
            Some(("up", i)) => stack.swap(i, i + 1),
            Some(("down", i)) => stack.swap(i, i - 1),
            Some((_, i)) => {
                stack.remove(i);
                panel.layer = panel.layer.min(stack.len().saturating_sub(1));
            }
            None => {}
        }
    }
}

/// The baked preview of the stack shown, re-baked when the stack changed.
fn preview(ui: &egui::Ui, shown: &[LayerEntry], panel: &mut TfPanel) {
    let key = format!("{:?}", shown);
    if panel.preview.as_ref().is_none_or(|(k, _)| *k != key) {
        let lut = bake_reference(shown, PREVIEW, 4, &[]);
        let pixels: Vec<egui::Color32> = lut
            .data
            .chunks(4)
            .map(|p| {
                let c = |v: f32| (v.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8;
                egui::Color32::from_rgb(c(p[0]), c(p[1]), c(p[2]))
            })
            .collect();
        let image = egui::ColorImage::new([PREVIEW as usize, PREVIEW as usize], pixels);
        let tex = ui
            .ctx()
            .load_texture("tf-square", image, egui::TextureOptions::LINEAR);
        panel.preview = Some((key, tex));
    }
}

/// Draw the constraints of diffusion layer `layer` of `shown` on the square; their screen
/// positions, by index.
fn draw_constraints(
    painter: &egui::Painter,
    shown: &[LayerEntry],
    layer: usize,
    to_screen: impl Fn([f32; 2]) -> egui::Pos2,
) -> Vec<(usize, egui::Pos2)> {
    let mut markers = Vec::new();
    if let Some(LayerEntry {
        layer: Layer::Diffusion { constraints },
        ..
    }) = shown.get(layer)
    {
        for (i, c) in constraints.iter().enumerate() {
            let p = to_screen(c.at);
            let fill = egui::Color32::from_rgb(
                (c.colour[0].clamp(0.0, 1.0) * 255.0) as u8,
                (c.colour[1].clamp(0.0, 1.0) * 255.0) as u8,
                (c.colour[2].clamp(0.0, 1.0) * 255.0) as u8,
            );
            painter.circle(p, 5.0, fill, egui::Stroke::new(1.5, egui::Color32::WHITE));
            if c.anchor.is_some() {
                painter.circle_stroke(p, 8.0, egui::Stroke::new(1.0, egui::Color32::WHITE));
            }
            markers.push((i, p));
        }
    }
    markers
}

/// One layer's rows (select, blend, opacity, reorder, remove; its own settings); the
/// reordering or removal asked for, if any.
fn layer_row(
    ui: &mut egui::Ui,
    i: usize,
    n: usize,
    e: &mut LayerEntry,
    panel: &mut TfPanel,
) -> Option<(&'static str, usize)> {
    let mut action = None;
    ui.push_id(("tf-layer", i), |ui| {
        ui.horizontal(|ui| {
            if ui
                .selectable_label(
                    panel.layer == i,
                    format!("{i} {}", layer_name(&e.layer, false)),
                )
                .clicked()
            {
                panel.layer = i;
            }
            egui::ComboBox::from_id_salt("blend")
                .selected_text(format!("{:?}", e.blend))
                .width(70.0)
                .show_ui(ui, |ui| {
                    for b in [Blend::Alpha, Blend::Multiply, Blend::Add] {
                        ui.selectable_value(&mut e.blend, b, format!("{b:?}"));
                    }
                });
            let label = ui.label("α");
            ui.add(
                egui::DragValue::new(&mut e.opacity)
                    .range(0.0..=1.0)
                    .speed(0.01),
            )
            .labelled_by(label.id)
            .on_hover_text("opacity");
            if ui.small_button("▲").on_hover_text("move up").clicked() && i + 1 < n {
                action = Some(("up", i));
            }
            if ui.small_button("▼").on_hover_text("move down").clicked() && i > 0 {
                action = Some(("down", i));
            }
            if ui.small_button("✕").on_hover_text("remove layer").clicked() {
                action = Some(("remove", i));
            }
        });
        ui.horizontal(|ui| match &mut e.layer {
            Layer::Solid { colour } => {
                colour_button(ui, colour);
            }
            Layer::Gradient {
                from,
                to,
                from_colour,
                to_colour,
            } => {
                colour_button(ui, from_colour);
                for v in from.iter_mut() {
                    ui.add(egui::DragValue::new(v).range(0.0..=1.0).speed(0.01));
                }
                ui.label("→");
                colour_button(ui, to_colour);
                for v in to.iter_mut() {
                    ui.add(egui::DragValue::new(v).range(0.0..=1.0).speed(0.01));
                }
            }
            Layer::Diffusion { constraints } => {
                let mut remove = None;
                for (k, c) in constraints.iter_mut().enumerate() {
                    colour_button(ui, &mut c.colour);
                    if ui
                        .small_button("✕")
                        .on_hover_text("remove constraint")
                        .clicked()
                    {
                        remove = Some(k);
                    }
                }
                if let Some(k) = remove {
                    constraints.remove(k);
                }
            }
            Layer::Image { path } => {
                ui.text_edit_singleline(path);
            }
        });
    });
    action
}
