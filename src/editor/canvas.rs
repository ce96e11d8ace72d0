//! The node canvas: egui-snarl drawing the document, every edit sent to [`EditorState`].

use std::collections::BTreeMap;

use eframe::egui;
use eframe::egui::emath;
use egui_snarl::ui::{PinInfo, SnarlViewer};
use egui_snarl::{InPin, NodeId, OutPin, Snarl};

use super::worker::NodeReport;
use super::EditorState;
use tyndall_engine::eval::Status;
use tyndall_engine::graph::{Graph, PortType};

/// The smallest on-screen height (points) at which a node's thumbnail is drawn: below it (a
/// canvas zoomed far out) the picture is too small to read and only costs drawing time.
pub const THUMB_MIN_PX: f32 = 16.0;

/// Colour of a port type's pins and wires.
pub fn port_colour(t: PortType) -> egui::Color32 {
    match t {
        PortType::ShadowMap => egui::Color32::from_rgb(230, 160, 60),
        PortType::Depth => egui::Color32::from_rgb(90, 160, 230),
        PortType::Scalar => egui::Color32::from_rgb(180, 180, 180),
        PortType::Image => egui::Color32::from_rgb(230, 220, 90),
        PortType::Volume => egui::Color32::from_rgb(160, 110, 220),
        PortType::SoftShadow => egui::Color32::from_rgb(200, 160, 90),
        PortType::Lut2D => egui::Color32::from_rgb(220, 100, 160),
        PortType::LightMap => egui::Color32::from_rgb(250, 240, 200),
        PortType::Scene => egui::Color32::from_rgb(100, 200, 120),
        PortType::Phase => egui::Color32::from_rgb(120, 210, 210),
        PortType::Layers => egui::Color32::from_rgb(235, 235, 235),
    }
}

/// The canvas's view of the document: every edit goes through [`EditorState`]; bodies show
/// the worker's thumbnails, timings and errors.
pub(super) struct CanvasView<'a> {
    pub state: &'a mut EditorState,
    pub status: &'a mut String,
    pub reports: &'a BTreeMap<String, NodeReport>,
    pub show_timings: bool,
    pub thumbs: &'a BTreeMap<String, super::app::shown::ShownTexture>,
    /// Group instance (flattened path) → the flattened node whose thumbnail it shows.
    pub aliases: &'a BTreeMap<String, String>,
    /// Every output's type (`(node, port)`), as [`Graph::output_types`] resolved it.
    pub types: &'a BTreeMap<(String, String), PortType>,
    /// When set, the view is moved so this graph-space rectangle fills the canvas.
    pub frame: Option<(egui::Rect, egui::Rect)>,
    /// The canvas's graph-to-screen transform, as last drawn.
    pub transform: &'a mut emath::TSTransform,
    /// A transform to put back (the view, carried over to a rebuilt canvas).
    pub restore: Option<emath::TSTransform>,
}

impl CanvasView<'_> {
    fn port(&self, node: &str, input: bool, index: usize) -> Option<(String, PortType)> {
        let kind = &self.state.graph().node(node)?.kind;
        let schema = self.state.graph().kind_schema(self.state.catalog(), kind)?;
        let p = if input {
            schema.inputs.get(index)?
        } else {
            schema.outputs.get(index)?
        };
        let ty = if input {
            p.types[0]
        } else {
            self.types
                .get(&(node.to_string(), p.name.to_string()))
                .copied()
                .unwrap_or(p.types[0])
        };
        Some((p.name.to_string(), ty))
    }

    /// A pin's label (type as tooltip) and its circle in the type's colour.
    fn pin(&self, ui: &mut egui::Ui, node: &str, input: bool, index: usize) -> PinInfo {
        let (name, ty) = self
            .port(node, input, index)
            .unwrap_or(("?".into(), PortType::Scalar));
        ui.label(name).on_hover_text(ty.name());
        PinInfo::circle().with_fill(port_colour(ty))
    }

    /// Remove the edge into input `index` of `node` (one undo step).
    fn clear_input(&mut self, node: &str, index: usize) {
        if let Some((port, _)) = self.port(node, true, index) {
            let _ = self.state.apply(|g, _| {
                g.disconnect(node, &port);
                Ok(())
            });
        }
    }

    fn counts(&self, node: &str) -> (usize, usize) {
        let g: &Graph = self.state.graph();
        g.node(node)
            .and_then(|n| g.kind_schema(self.state.catalog(), &n.kind))
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
        self.pin(ui, &snarl[pin.id.node], true, pin.id.input)
    }

    fn show_output(
        &mut self,
        pin: &OutPin,
        ui: &mut egui::Ui,
        snarl: &mut Snarl<String>,
    ) -> impl egui_snarl::ui::SnarlPin + 'static {
        self.pin(ui, &snarl[pin.id.node], false, pin.id.output)
    }

    fn connect(&mut self, from: &OutPin, to: &InPin, snarl: &mut Snarl<String>) {
        let (a, b) = (snarl[from.id.node].clone(), snarl[to.id.node].clone());
        if let (Some((fp, _)), Some((tp, _))) = (
            self.port(&a, false, from.id.output),
            self.port(&b, true, to.id.input),
        ) {
            // Connecting to a taken input replaces its edge, as in other compositors.
            let res = self
                .state
                .connect_replacing(&format!("{a}.{fp}"), &format!("{b}.{tp}"));
            *self.status = match res {
                Ok(()) => String::new(),
                Err(e) => format!("refused: {e}"),
            };
        }
    }

    fn disconnect(&mut self, _from: &OutPin, to: &InPin, snarl: &mut Snarl<String>) {
        self.clear_input(&snarl[to.id.node].clone(), to.id.input);
    }

    fn drop_inputs(&mut self, pin: &InPin, snarl: &mut Snarl<String>) {
        self.clear_input(&snarl[pin.id.node].clone(), pin.id.input);
    }

    fn has_body(&mut self, _node: &String) -> bool {
        true
    }

    fn show_body(
        &mut self,
        node: NodeId,
        _inputs: &[InPin],
        _outputs: &[OutPin],
        ui: &mut egui::Ui,
        snarl: &mut Snarl<String>,
    ) {
        // Reports and thumbnails are by flattened id; a group node shows its inner nodes'.
        let id = self.state.full_id(&snarl[node]);
        let thumb = self
            .thumbs
            .get(&id)
            .or_else(|| self.aliases.get(&id).and_then(|f| self.thumbs.get(f)));
        let report = self
            .reports
            .get(&id)
            .cloned()
            .or_else(|| super::worker::group_report(self.reports, &id));
        ui.vertical(|ui| {
            if let Some(t) = thumb {
                let size = t.size_vec2();
                let scale = (96.0 / size.x.max(size.y)).min(1.0);
                // The space is kept either way (nodes keep their size); the picture is drawn
                // only on screen and when it is at least `THUMB_MIN_PX` points tall there.
                let (rect, _) = ui.allocate_exact_size(size * scale, egui::Sense::hover());
                let on_screen = rect.height() * self.transform.scaling;
                if ui.is_rect_visible(rect) && on_screen >= THUMB_MIN_PX {
                    egui::Image::new((t.id(), t.size_vec2())).paint_at(ui, rect);
                }
            }
            match &report {
                Some(r) if r.error.is_some() => {
                    let msg = r.error.clone().unwrap_or_default();
                    ui.add(
                        egui::Label::new(
                            egui::RichText::new(msg).color(super::panel::ERROR).small(),
                        )
                        .wrap(),
                    );
                }
                Some(r) if self.show_timings => {
                    let text = match r.status {
                        Status::Ran => format!("{:.1} ms", r.time.as_secs_f64() * 1e3),
                        Status::PassedThrough => {
                            format!("{:.1} ms (passed through)", r.time.as_secs_f64() * 1e3)
                        }
                        Status::Reused => format!("{:.1} ms (cached)", r.time.as_secs_f64() * 1e3),
                        Status::NotNeeded => String::new(),
                    };
                    if !text.is_empty() {
                        ui.small(text);
                    }
                }
                _ => {}
            }
        });
    }

    fn current_transform(
        &mut self,
        to_global: &mut emath::TSTransform,
        _snarl: &mut Snarl<String>,
    ) {
        if let Some(t) = self.restore.take() {
            *to_global = t;
        }
        if let Some((bb, canvas)) = self.frame.take() {
            let bb = bb.expand(40.0);
            let scale = (canvas.width() / bb.width())
                .min(canvas.height() / bb.height())
                .clamp(super::app::MIN_CANVAS_SCALE, 1.2);
            *to_global = emath::TSTransform::new(
                canvas.center().to_vec2() - bb.center().to_vec2() * scale,
                scale,
            );
        }
        *self.transform = *to_global;
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
