//! The timeline: frame, range, playback and the key-frames of the document.

use super::*;

impl EditorApp {
    pub(super) fn timeline(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            let play = if self.playing { "⏸" } else { "▶" };
            if ui
                .button(play)
                .on_hover_text("play / pause (Space)")
                .clicked()
            {
                self.playing = !self.playing;
            }
            ui.label("frame");
            ui.add(egui::DragValue::new(&mut self.time).speed(0.25));
            ui.label("range");
            ui.add(egui::DragValue::new(&mut self.range.0).speed(1.0));
            ui.add(egui::DragValue::new(&mut self.range.1).speed(1.0));
            ui.label("fps");
            ui.add(egui::DragValue::new(&mut self.fps).range(1.0..=120.0));
            if self.range.1 <= self.range.0 {
                self.range.1 = self.range.0 + 1.0;
            }
            // The scrub bar with key-frame marks of the selected node (all nodes when none).
            let (rect, response) = ui.allocate_exact_size(
                egui::vec2(ui.available_width().max(100.0), 22.0),
                egui::Sense::click_and_drag(),
            );
            let span = (self.range.1 - self.range.0) as f32;
            let x_of = |t: f64| rect.left() + ((t - self.range.0) as f32 / span) * rect.width();
            let painter = ui.painter_at(rect);
            painter.rect_filled(rect, 3.0, ui.visuals().extreme_bg_color);
            for n in self.state.graph().nodes() {
                if self.selected.as_ref().is_some_and(|s| *s != n.id) {
                    continue;
                }
                for k in n.keys.values().flatten() {
                    let x = x_of(k.t);
                    painter.line_segment(
                        [
                            egui::pos2(x, rect.top() + 3.0),
                            egui::pos2(x, rect.bottom() - 3.0),
                        ],
                        egui::Stroke::new(2.0, egui::Color32::from_rgb(240, 200, 60)),
                    );
                }
                // Key-frames inside the node's data block (a layer stack's), as its kind reads
                // them.
                let kind = self.registry.get(&n.kind);
                let data_keys = match (kind, n.data.as_ref()) {
                    (Some(k), Some(d)) => k.data_key_times(d),
                    _ => Vec::new(),
                };
                for t in data_keys {
                    let x = x_of(t);
                    painter.circle_filled(
                        egui::pos2(x, rect.center().y),
                        4.0,
                        egui::Color32::from_rgb(230, 90, 220),
                    );
                }
            }
            let x = x_of(self.time);
            painter.line_segment(
                [egui::pos2(x, rect.top()), egui::pos2(x, rect.bottom())],
                egui::Stroke::new(2.0, egui::Color32::from_rgb(90, 170, 255)),
            );
            if let Some(pos) = response.interact_pointer_pos() {
                let f = ((pos.x - rect.left()) / rect.width()).clamp(0.0, 1.0) as f64;
                self.time = (self.range.0 + f * span as f64).round();
            }
        });
    }

    pub(super) fn play(&mut self, ctx: &egui::Context) {
        if !self.playing {
            return;
        }
        let dt = ctx.input(|i| i.stable_dt).min(0.1) as f64;
        self.time += dt * self.fps;
        if self.time > self.range.1 {
            self.time = self.range.0;
        }
        ctx.request_repaint();
    }
}

/// The first and last key-frame times of the document, when it has keys.
pub(super) fn key_range(state: &EditorState) -> Option<(f64, f64)> {
    let ts: Vec<f64> = state
        .root()
        .nodes()
        .flat_map(|n| n.keys.values().flatten().map(|k| k.t))
        .collect();
    let lo = ts.iter().cloned().reduce(f64::min)?;
    let hi = ts.iter().cloned().reduce(f64::max)?;
    Some((lo.min(0.0), if hi > lo { hi } else { lo + 48.0 }))
}
