//! The window's bar along the top and its node canvas (framing, selection, node moves).

use super::*;

impl EditorApp {
    /// The bar along the top: the document's name, undo/redo, save, framing, the worker's
    /// progress and the status line.
    pub(super) fn top_bar(&mut self, root: &mut egui::Ui) {
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
                if ui.button("Undo").on_hover_text("Ctrl+Z").clicked() {
                    self.state.undo();
                }
                if ui
                    .button("Redo")
                    .on_hover_text("Ctrl+Y / Ctrl+Shift+Z")
                    .clicked()
                {
                    self.state.redo();
                }
                if ui.button("Save").on_hover_text("Ctrl+S").clicked() {
                    self.save();
                }
                let mut recording = self.trace_file.is_some();
                if ui
                    .toggle_value(&mut recording, "Record trace")
                    .on_hover_text(
                        "Record what evaluations do (node runs, GPU passes, pipelines, \
                         read-backs, writes) into a Chrome trace beside the document: open it \
                         in Perfetto",
                    )
                    .changed()
                {
                    self.toggle_trace();
                }
                if ui.button("Save as…").clicked() {
                    self.save_as = Some(
                        self.state
                            .path()
                            .map(|p| p.display().to_string())
                            .unwrap_or_else(|| "graphs/untitled.ron".into()),
                    );
                }
                if ui
                    .button("Frame all")
                    .on_hover_text("F, or double-click the canvas")
                    .clicked()
                {
                    self.frame_all = true;
                }
                ui.separator();
                if !self.idle() {
                    ui.spinner();
                    if let Some(p) = &self.progress {
                        ui.label(format!("{} {}/{} {}", p.node, p.done, p.total, p.message));
                    }
                }
                ui.label(&self.status);
            });
        });
    }

    /// The node canvas: framing on request, the document's nodes, selection and node moves
    /// (one undoable change when the drag ends).
    pub(super) fn canvas_panel(&mut self, root: &mut egui::Ui) {
        egui::CentralPanel::default().show(root, |ui| {
            self.breadcrumb(ui);
            let canvas = self.canvas_id();
            // Frame from the document's positions with a nominal node size, so the framing does
            // not depend on when thumbnails (which change node sizes) arrive.
            let frame = if self.frame_all && self.snarl.nodes_pos_ids().next().is_some() {
                self.frame_all = false;
                let bb = self
                    .snarl
                    .nodes_pos_ids()
                    .map(|(_, pos, _)| {
                        egui::Rect::from_min_size(
                            pos,
                            egui::vec2(tyndall_engine::graph::NODE_WIDTH, 200.0),
                        )
                    })
                    .fold(egui::Rect::NOTHING, |a, r| a.union(r));
                Some((bb, ui.max_rect()))
            } else {
                None
            };
            let mut view = CanvasView {
                state: &mut self.state,
                status: &mut self.status,
                reports: &self.reports,
                show_timings: self.show_timings,
                thumbs: &self.thumbs,
                aliases: &self.aliases,
                types: &self.port_types,
                frame,
                transform: &mut self.canvas_transform,
                restore: self.restore_transform.take(),
            };
            // Titles and port names are not selectable text, so a click on them reaches the
            // node (Shift+click selects it).
            ui.style_mut().interaction.selectable_labels = false;
            // Zoomed out far enough to frame a big graph (egui-snarl's default stops at 0.2: a
            // 400-pixel canvas then shows 2,000 units, five columns of the layered layout).
            let mut style = egui_snarl::ui::SnarlStyle::new();
            style.min_scale = Some(MIN_CANVAS_SCALE);
            SnarlWidget::new()
                .id(canvas)
                .style(style)
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
