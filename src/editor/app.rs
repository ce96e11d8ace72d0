//! The editor window: node canvas (egui-snarl, a view of the document), parameters panel and
//! a viewer of the selected node's output. Early state: see the module notes in `mod.rs`.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use eframe::egui;
use egui_snarl::ui::{get_selected_nodes, PinInfo, SnarlViewer, SnarlWidget};
use egui_snarl::{InPin, NodeId, OutPin, Snarl};

use super::EditorState;
use crate::eval::{download, EvalOptions, Evaluator, PortValue, Registry, Target};
use crate::gpu::Gpu;
use crate::graph::{save_string, Graph, ParamKind, ParamValue, PortType};

/// Colour of a port type's pins and wires.
pub fn port_colour(t: PortType) -> egui::Color32 {
    match t {
        PortType::ShadowMap => egui::Color32::from_rgb(230, 160, 60),
        PortType::Depth => egui::Color32::from_rgb(90, 160, 230),
        PortType::Scalar => egui::Color32::from_rgb(180, 180, 180),
        PortType::Image => egui::Color32::from_rgb(230, 220, 90),
        PortType::Volume => egui::Color32::from_rgb(160, 110, 220),
        PortType::Lut2D => egui::Color32::from_rgb(220, 100, 160),
        PortType::LightMap => egui::Color32::from_rgb(250, 240, 200),
        PortType::Scene => egui::Color32::from_rgb(100, 200, 120),
        PortType::Phase => egui::Color32::from_rgb(120, 210, 210),
    }
}

/// The editor application.
pub struct EditorApp {
    /// The document and its history.
    pub state: EditorState,
    snarl: Snarl<String>,
    synced: Option<String>,
    /// Id of the node shown in the viewer and the parameters panel.
    pub selected: Option<String>,
    /// Last message (refused connection, save result…).
    pub status: String,
    evaluator: Option<Evaluator>,
    preview: Option<egui::TextureHandle>,
    preview_key: String,
    time: f64,
    /// An autosave left by a session that did not save, offered for recovery at start.
    pub recovery: Option<PathBuf>,
    /// The window was asked to close with unsaved changes: the save/discard/cancel prompt.
    pub confirm_quit: bool,
    allow_close: bool,
}

impl EditorApp {
    /// An editor on `state`.
    pub fn new(state: EditorState, registry: Arc<Registry>) -> Self {
        let evaluator = Gpu::shared()
            .ok()
            .map(|g| Evaluator::new(registry.clone(), g));
        Self {
            state,
            snarl: Snarl::new(),
            synced: None,
            selected: None,
            status: String::new(),
            evaluator,
            preview: None,
            preview_key: String::new(),
            time: 0.0,
            recovery: None,
            confirm_quit: false,
            allow_close: false,
        }
    }

    /// Rebuild the canvas from the document when the document changed.
    fn sync(&mut self) {
        let text = save_string(self.state.graph());
        if self.synced.as_deref() == Some(text.as_str()) {
            return;
        }
        let g = self.state.graph();
        let mut snarl = Snarl::new();
        let mut ids = std::collections::BTreeMap::new();
        for (i, n) in g.nodes().enumerate() {
            let pos = n.pos.unwrap_or([i as f32 * 40.0, i as f32 * 30.0]);
            ids.insert(
                n.id.clone(),
                snarl.insert_node(egui::pos2(pos[0], pos[1]), n.id.clone()),
            );
        }
        let cat = self.state.catalog();
        for e in g.edges() {
            let (Some(a), Some(b)) = (ids.get(&e.from_node), ids.get(&e.to_node)) else {
                continue;
            };
            let out_ix = g
                .node(&e.from_node)
                .and_then(|n| cat.get(&n.kind))
                .and_then(|s| s.outputs.iter().position(|p| p.name == e.from_port));
            let in_ix = g
                .node(&e.to_node)
                .and_then(|n| cat.get(&n.kind))
                .and_then(|s| s.inputs.iter().position(|p| p.name == e.to_port));
            if let (Some(o), Some(i)) = (out_ix, in_ix) {
                snarl.connect(
                    egui_snarl::OutPinId {
                        node: *a,
                        output: o,
                    },
                    egui_snarl::InPinId { node: *b, input: i },
                );
            }
        }
        self.snarl = snarl;
        self.synced = Some(text);
    }

    fn viewer_image(&mut self, ctx: &egui::Context) {
        let Some(id) = self.selected.clone() else {
            return;
        };
        let key = format!(
            "{id}@{}:{}",
            self.time,
            self.synced.as_deref().unwrap_or("")
        );
        if key == self.preview_key {
            return;
        }
        self.preview_key = key;
        self.preview = None;
        let (Some(ev), Some(node)) = (self.evaluator.as_mut(), self.state.graph().node(&id)) else {
            return;
        };
        let Some(schema) = self.state.catalog().get(&node.kind) else {
            return;
        };
        let Some(port) = schema
            .outputs
            .iter()
            .find(|p| !matches!(p.types[0], PortType::Scene))
        else {
            return;
        };
        let opts = EvalOptions {
            time: self.time,
            size: (320, 180),
            ..Default::default()
        };
        match ev.evaluate(
            self.state.graph(),
            &[Target::Port(id.clone(), port.name.to_string())],
            &opts,
        ) {
            Ok(r) => {
                if let Some(v) = r.outputs.get(&(id.clone(), port.name.to_string())) {
                    if let Some(image) = to_colour_image(ev.gpu(), v) {
                        self.preview =
                            Some(ctx.load_texture("viewer", image, egui::TextureOptions::NEAREST));
                    }
                }
                self.status = format!(
                    "{} ran",
                    r.stats.with_status(crate::eval::Status::Ran).len()
                );
            }
            Err(e) => self.status = e.to_string(),
        }
    }

    fn parameters(&mut self, ui: &mut egui::Ui) {
        let Some(id) = self.selected.clone() else {
            ui.label("Select a node to edit its parameters.");
            return;
        };
        let Some(node) = self.state.graph().node(&id).cloned() else {
            return;
        };
        let Some(schema) = self.state.catalog().get(&node.kind) else {
            return;
        };
        ui.heading(format!("{id} - {}", node.kind));
        ui.label(schema.doc);
        ui.separator();
        for p in schema.params {
            let current = self
                .state
                .graph()
                .param_at(self.state.catalog(), &id, p.name, self.time)
                .unwrap_or(p.default.value());
            let mut changed: Option<ParamValue> = None;
            ui.horizontal(|ui| {
                ui.label(p.name)
                    .on_hover_text(format!("{} ({})", p.doc, p.expected()));
                match (&p.kind, &current) {
                    (ParamKind::Float, ParamValue::Float(v)) => {
                        let mut x = *v;
                        if ui
                            .add(
                                egui::DragValue::new(&mut x)
                                    .range(p.min..=p.max)
                                    .speed(0.01),
                            )
                            .changed()
                        {
                            changed = Some(ParamValue::Float(x));
                        }
                    }
                    (ParamKind::Int, ParamValue::Int(v)) => {
                        let mut x = *v;
                        if ui
                            .add(egui::DragValue::new(&mut x).range(p.min as i64..=p.max as i64))
                            .changed()
                        {
                            changed = Some(ParamValue::Int(x));
                        }
                    }
                    (ParamKind::Bool, ParamValue::Bool(v)) => {
                        let mut x = *v;
                        if ui.checkbox(&mut x, "").changed() {
                            changed = Some(ParamValue::Bool(x));
                        }
                    }
                    (ParamKind::Enum(names), ParamValue::Enum(v)) => {
                        egui::ComboBox::from_id_salt(p.name)
                            .selected_text(v.as_str())
                            .show_ui(ui, |ui| {
                                for n in *names {
                                    if ui.selectable_label(v == n, *n).clicked() {
                                        changed = Some(ParamValue::Enum(n.to_string()));
                                    }
                                }
                            });
                    }
                    (ParamKind::Text, ParamValue::Text(v)) => {
                        let mut x = v.clone();
                        if ui.text_edit_singleline(&mut x).lost_focus() && &x != v {
                            changed = Some(ParamValue::Text(x));
                        }
                    }
                    (ParamKind::Colour, ParamValue::Colour(c)) => {
                        let mut rgba = [c[0] as f32, c[1] as f32, c[2] as f32, c[3] as f32];
                        if ui.color_edit_button_rgba_unmultiplied(&mut rgba).changed() {
                            changed = Some(ParamValue::Colour(rgba.map(|x| x as f64)));
                        }
                    }
                    _ => {
                        ui.label(current.to_string());
                    }
                }
                if node.keys.contains_key(p.name) {
                    ui.label("◆").on_hover_text("key-framed");
                }
            });
            if let Some(v) = changed {
                if let Err(e) = self.state.set_param(&id, p.name, v) {
                    self.status = e.to_string();
                }
            }
        }
    }
}

impl EditorApp {
    /// The recovery offer and the unsaved-changes prompt.
    fn dialogs(&mut self, ctx: &egui::Context) {
        if let Some(side) = self.recovery.clone() {
            egui::Window::new("Recover unsaved changes?")
                .collapsible(false)
                .resizable(false)
                .show(ctx, |ui| {
                    ui.label(format!(
                        "An autosave newer than the graph was found: {}",
                        side.display()
                    ));
                    ui.horizontal(|ui| {
                        if ui.button("Recover").clicked() {
                            self.status = match self.state.recover(&side) {
                                Ok(()) => "recovered the autosave (not saved yet)".into(),
                                Err(e) => e.to_string(),
                            };
                            self.recovery = None;
                        }
                        if ui.button("Ignore").clicked() {
                            self.recovery = None;
                        }
                    });
                });
        }
        if ctx.input(|i| i.viewport().close_requested())
            && self.state.is_dirty()
            && !self.allow_close
        {
            ctx.send_viewport_cmd(egui::ViewportCommand::CancelClose);
            self.confirm_quit = true;
        }
        if self.confirm_quit {
            egui::Window::new("Unsaved changes")
                .collapsible(false)
                .resizable(false)
                .show(ctx, |ui| {
                    ui.label("The graph has changes that are not saved.");
                    ui.horizontal(|ui| {
                        if ui.button("Save and quit").clicked() {
                            match self.state.save() {
                                Ok(()) => {
                                    self.allow_close = true;
                                    ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                                }
                                Err(e) => self.status = e.to_string(),
                            }
                            self.confirm_quit = false;
                        }
                        if ui.button("Discard and quit").clicked() {
                            self.allow_close = true;
                            self.confirm_quit = false;
                            ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                        }
                        if ui.button("Cancel").clicked() {
                            self.confirm_quit = false;
                        }
                    });
                });
        }
    }
}

/// Read a 2D value back as an 8-bit sRGB picture for the viewer.
fn to_colour_image(gpu: &Gpu, v: &PortValue) -> Option<egui::ColorImage> {
    let r = download(gpu, v).ok()?;
    let enc = |x: f32| (crate::io::linear_to_srgb(x) * 255.0).round() as u8;
    let pixels: Vec<egui::Color32> = (0..(r.width * r.height) as usize)
        .map(|i| {
            if r.channels == 1 {
                let g = enc(r.data[i]);
                egui::Color32::from_rgb(g, g, g)
            } else {
                let p = &r.data[i * 4..i * 4 + 4];
                egui::Color32::from_rgb(enc(p[0]), enc(p[1]), enc(p[2]))
            }
        })
        .collect();
    Some(egui::ColorImage::new(
        [r.width as usize, r.height as usize],
        pixels,
    ))
}

/// The canvas's view of the document: every edit goes through [`EditorState`].
struct CanvasView<'a> {
    state: &'a mut EditorState,
    status: &'a mut String,
}

impl CanvasView<'_> {
    fn port(&self, node: &str, input: bool, index: usize) -> Option<(String, PortType)> {
        let kind = &self.state.graph().node(node)?.kind;
        let schema = self.state.catalog().get(kind)?;
        let p = if input {
            schema.inputs.get(index)?
        } else {
            schema.outputs.get(index)?
        };
        let ty = if input {
            p.types[0]
        } else {
            self.state
                .graph()
                .output_type(self.state.catalog(), node, p.name)
                .unwrap_or(p.types[0])
        };
        Some((p.name.to_string(), ty))
    }

    fn counts(&self, node: &str) -> (usize, usize) {
        let g: &Graph = self.state.graph();
        g.node(node)
            .and_then(|n| self.state.catalog().get(&n.kind))
            .map_or((0, 0), |s| (s.inputs.len(), s.outputs.len()))
    }
}

impl SnarlViewer<String> for CanvasView<'_> {
    fn title(&mut self, node: &String) -> String {
        let kind = self
            .state
            .graph()
            .node(node)
            .map(|n| n.kind.clone())
            .unwrap_or_default();
        format!("{node} - {kind}")
    }

    fn inputs(&mut self, node: &String) -> usize {
        self.counts(node).0
    }

    fn outputs(&mut self, node: &String) -> usize {
        self.counts(node).1
    }

    fn show_input(
        &mut self,
        pin: &InPin,
        ui: &mut egui::Ui,
        snarl: &mut Snarl<String>,
    ) -> impl egui_snarl::ui::SnarlPin + 'static {
        let (name, ty) = self
            .port(&snarl[pin.id.node], true, pin.id.input)
            .unwrap_or(("?".into(), PortType::Scalar));
        ui.label(name).on_hover_text(ty.name());
        PinInfo::circle().with_fill(port_colour(ty))
    }

    fn show_output(
        &mut self,
        pin: &OutPin,
        ui: &mut egui::Ui,
        snarl: &mut Snarl<String>,
    ) -> impl egui_snarl::ui::SnarlPin + 'static {
        let (name, ty) = self
            .port(&snarl[pin.id.node], false, pin.id.output)
            .unwrap_or(("?".into(), PortType::Scalar));
        ui.label(name).on_hover_text(ty.name());
        PinInfo::circle().with_fill(port_colour(ty))
    }

    fn connect(&mut self, from: &OutPin, to: &InPin, snarl: &mut Snarl<String>) {
        let (a, b) = (snarl[from.id.node].clone(), snarl[to.id.node].clone());
        if let (Some((fp, _)), Some((tp, _))) = (
            self.port(&a, false, from.id.output),
            self.port(&b, true, to.id.input),
        ) {
            // Connecting to a taken input replaces its edge, as in other compositors.
            let res = self.state.apply(|g, c| {
                g.disconnect(&b, &tp);
                g.connect(c, &format!("{a}.{fp}"), &format!("{b}.{tp}"))
            });
            *self.status = match res {
                Ok(()) => String::new(),
                Err(e) => format!("refused: {e}"),
            };
        }
    }

    fn disconnect(&mut self, _from: &OutPin, to: &InPin, snarl: &mut Snarl<String>) {
        let b = snarl[to.id.node].clone();
        if let Some((tp, _)) = self.port(&b, true, to.id.input) {
            let _ = self.state.apply(|g, _| {
                g.disconnect(&b, &tp);
                Ok(())
            });
        }
    }

    fn drop_inputs(&mut self, pin: &InPin, snarl: &mut Snarl<String>) {
        let b = snarl[pin.id.node].clone();
        if let Some((tp, _)) = self.port(&b, true, pin.id.input) {
            let _ = self.state.apply(|g, _| {
                g.disconnect(&b, &tp);
                Ok(())
            });
        }
    }

    fn has_graph_menu(&mut self, _pos: egui::Pos2, _snarl: &mut Snarl<String>) -> bool {
        true
    }

    fn show_graph_menu(&mut self, pos: egui::Pos2, ui: &mut egui::Ui, _snarl: &mut Snarl<String>) {
        ui.label("Add node");
        let mut by_category: std::collections::BTreeMap<&str, Vec<&str>> =
            std::collections::BTreeMap::new();
        for s in self.state.catalog().iter() {
            by_category.entry(s.category).or_default().push(s.kind);
        }
        for (category, kinds) in by_category {
            ui.menu_button(category, |ui| {
                for kind in kinds {
                    if ui.button(kind).clicked() {
                        if let Err(e) = self.state.add_node(kind, [pos.x, pos.y]) {
                            *self.status = e.to_string();
                        }
                        ui.close();
                    }
                }
            });
        }
    }

    fn has_node_menu(&mut self, _node: &String) -> bool {
        true
    }

    fn show_node_menu(
        &mut self,
        node: NodeId,
        _inputs: &[InPin],
        _outputs: &[OutPin],
        ui: &mut egui::Ui,
        snarl: &mut Snarl<String>,
    ) {
        let id = snarl[node].clone();
        if ui.button("Duplicate").clicked() {
            let _ = self.state.duplicate(std::slice::from_ref(&id));
            ui.close();
        }
        if ui.button("Delete").clicked() {
            let _ = self.state.delete(std::slice::from_ref(&id));
            ui.close();
        }
    }
}

impl eframe::App for EditorApp {
    fn ui(&mut self, root: &mut egui::Ui, _frame: &mut eframe::Frame) {
        let ctx = root.ctx().clone();
        self.dialogs(&ctx);
        self.sync();
        let (undo, redo, save) = ctx.input(|i| {
            let cmd = i.modifiers.command;
            (
                cmd && i.key_pressed(egui::Key::Z) && !i.modifiers.shift,
                cmd && (i.key_pressed(egui::Key::Y)
                    || (i.modifiers.shift && i.key_pressed(egui::Key::Z))),
                cmd && i.key_pressed(egui::Key::S),
            )
        });
        if undo {
            self.state.undo();
        }
        if redo {
            self.state.redo();
        }
        if save {
            self.status = match self.state.save() {
                Ok(()) => "saved".into(),
                Err(e) => e.to_string(),
            };
        }
        if let Err(e) = self.state.tick_autosave(Instant::now()) {
            self.status = e.to_string();
        }
        egui::Panel::top("bar").show(root, |ui| {
            ui.horizontal(|ui| {
                let title = self
                    .state
                    .path()
                    .and_then(|p| p.file_name())
                    .map(|n| n.to_string_lossy().into_owned())
                    .unwrap_or_else(|| "untitled".into());
                ui.strong(format!(
                    "Tyndall — {title}{}",
                    if self.state.is_dirty() { " •" } else { "" }
                ));
                if ui.button("Undo").clicked() {
                    self.state.undo();
                }
                if ui.button("Redo").clicked() {
                    self.state.redo();
                }
                if ui.button("Save").clicked() {
                    self.status = match self.state.save() {
                        Ok(()) => "saved".into(),
                        Err(e) => e.to_string(),
                    };
                }
                ui.separator();
                ui.label("time");
                ui.add(egui::DragValue::new(&mut self.time).speed(0.1));
                ui.separator();
                ui.label(&self.status);
            });
        });
        egui::Panel::right("params")
            .default_size(320.0)
            .show(root, |ui| {
                ui.heading("Viewer");
                self.viewer_image(&ctx);
                match &self.preview {
                    Some(t) => {
                        ui.add(egui::Image::new(t).fit_to_exact_size(egui::vec2(300.0, 169.0)));
                    }
                    None => {
                        ui.label("(no image)");
                    }
                }
                ui.separator();
                self.parameters(ui);
            });
        egui::CentralPanel::default().show(root, |ui| {
            let canvas = egui::Id::new("tyndall-canvas");
            let mut view = CanvasView {
                state: &mut self.state,
                status: &mut self.status,
            };
            SnarlWidget::new()
                .id(canvas)
                .show(&mut self.snarl, &mut view, ui);
            let selected = get_selected_nodes(canvas, ui.ctx());
            if let Some(n) = selected.first() {
                self.selected = self.snarl.get_node(*n).cloned();
            }
            // Node moves become one undoable change when the drag ends.
            if ui.input(|i| i.pointer.any_released()) {
                let moved: Vec<(String, [f32; 2])> = self
                    .snarl
                    .nodes_pos_ids()
                    .filter_map(|(_, pos, id)| {
                        let doc = self.state.graph().node(id)?.pos;
                        (doc != Some([pos.x, pos.y])).then(|| (id.clone(), [pos.x, pos.y]))
                    })
                    .collect();
                if !moved.is_empty() {
                    let _ = self.state.apply(|g, _| {
                        for (id, p) in &moved {
                            g.set_pos(id, Some(*p))?;
                        }
                        Ok(())
                    });
                }
            }
        });
    }
}

/// Open the editor window on `path` (or an empty graph).
pub fn run(path: Option<PathBuf>) -> Result<(), String> {
    let registry = Arc::new(crate::nodes::registry());
    let state = match &path {
        Some(p) => EditorState::open(registry.catalog().clone(), p).map_err(|e| e.to_string())?,
        None => EditorState::new(registry.catalog().clone()),
    };
    let mut app = EditorApp::new(state, registry.clone());
    app.recovery = path.as_deref().and_then(EditorState::recoverable);
    // Start on the picture: the node feeding the graph's first output, else the last node.
    let g = app.state.graph();
    let sink = g
        .nodes()
        .find(|n| registry.get(&n.kind).is_some_and(|k| k.is_sink()));
    app.selected = sink
        .and_then(|n| g.source_of(&n.id, "image").map(|(src, _)| src.to_string()))
        .or_else(|| g.topo_order().last().cloned());
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size([1400.0, 860.0])
            .with_title("Tyndall"),
        renderer: eframe::Renderer::Wgpu,
        ..Default::default()
    };
    eframe::run_native("Tyndall", options, Box::new(|_cc| Ok(Box::new(app))))
        .map_err(|e| e.to_string())
}
