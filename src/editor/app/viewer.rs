//! The viewer panel: the selected node's picture, the pixel probe, and the tools that work
//! over the picture (constraint clicks, stroke painting, the 3D brush), as the node's
//! declaration names them.

use super::*;

impl EditorApp {
    pub(super) fn viewer(&mut self, ui: &mut egui::Ui) {
        let viewed = self.viewed();
        ui.horizontal(|ui| {
            ui.heading("Viewer");
            ui.label(viewed.as_deref().unwrap_or("(nothing selected)"));
            let selected = self.selected.as_deref().map(|s| self.state.full_id(s));
            if self.active_pin.is_none() && viewed.is_some() && viewed != selected {
                if let Some(s) = &self.selected {
                    ui.weak(format!("(the nearest picture downstream of {s})"));
                }
            }
        });
        ui.horizontal(|ui| {
            for i in 0..9 {
                let label = format!("{}", i + 1);
                let text = match &self.pins[i] {
                    Some(id) => format!("pin {} → {id} (key {})", i + 1, i + 1),
                    None => format!("pin {}: Shift+{} pins the selected node", i + 1, i + 1),
                };
                let on = self.active_pin == Some(i);
                let b = ui
                    .add_enabled(self.pins[i].is_some(), egui::Button::selectable(on, label))
                    .on_hover_text(text);
                if b.clicked() {
                    self.active_pin = if on { None } else { Some(i) };
                }
            }
        });
        ui.horizontal(|ui| {
            let ports: Vec<String> = self
                .pictures
                .as_ref()
                .map(|(_, p)| p.iter().map(|(n, _)| n.clone()).collect())
                .unwrap_or_default();
            let current = self
                .view_port
                .clone()
                .filter(|p| ports.contains(p))
                .or_else(|| ports.first().cloned());
            egui::ComboBox::from_id_salt("view-port")
                .selected_text(current.clone().unwrap_or_else(|| "-".into()))
                .show_ui(ui, |ui| {
                    for p in &ports {
                        if ui
                            .selectable_label(current.as_ref() == Some(p), p)
                            .clicked()
                        {
                            self.view_port = Some(p.clone());
                            self.view_tex = None;
                        }
                    }
                });
            egui::ComboBox::from_id_salt("view-channel")
                .selected_text(self.channel.label())
                .show_ui(ui, |ui| {
                    for c in Channel::ALL {
                        if ui.selectable_label(self.channel == c, c.label()).clicked() {
                            self.channel = c;
                            self.view_tex = None;
                        }
                    }
                });
            ui.label("exposure");
            if ui
                .add(
                    egui::DragValue::new(&mut self.exposure)
                        .range(-16.0..=16.0)
                        .speed(0.05)
                        .suffix(" stops"),
                )
                .changed()
            {
                self.view_tex = None;
            }
            ui.selectable_value(&mut self.zoom, Zoom::Fit, "Fit");
            ui.selectable_value(&mut self.zoom, Zoom::One, "1:1");
            let on = self.wipe.is_some();
            if ui
                .add(egui::Button::selectable(on, "A/B wipe"))
                .on_hover_text("W: compare with the node viewed now (B, right of the split); then view another (A)")
                .clicked()
            {
                self.toggle_wipe();
            }
            if let Some(b) = &self.wipe {
                ui.label(format!("B = {b}"));
                ui.add(egui::Slider::new(&mut self.wipe_split, 0.0..=1.0).text("split"));
            }
        });
        // Borrow the pictures out for the frame instead of copying them.
        let Some((node, pictures)) = self.pictures.take() else {
            ui.label("(no picture yet)");
            return;
        };
        self.show_picture(ui, &node, &pictures);
        self.pictures = Some((node, pictures));
    }

    /// `W` and the A/B wipe button: compare with the node viewed now (B), or stop comparing.
    pub fn toggle_wipe(&mut self) {
        self.wipe = match self.wipe {
            Some(_) => None,
            None => self.viewed(),
        };
        self.compare = None;
        self.wipe_tex = None;
    }

    /// The wipe's B picture (the same port when it has one, else its first) over the right of
    /// `rect`, from the split on, with the split line and the two names.
    fn paint_wipe(&mut self, ui: &mut egui::Ui, rect: egui::Rect, a: &str, port: &str) {
        let Some((b, pictures)) = self.compare.as_ref() else {
            return;
        };
        let Some((bport, raster)) = pictures
            .iter()
            .find(|(n, _)| n == port)
            .or_else(|| pictures.first())
        else {
            return;
        };
        let key = format!("{b}.{bport}:{:?}:{}", self.channel, self.exposure);
        if self.wipe_tex.as_ref().is_none_or(|(k, _)| *k != key) {
            let image = colour_image(raster, self.channel, self.exposure);
            let tex = ui
                .ctx()
                .load_texture("viewer-wipe", image, egui::TextureOptions::NEAREST);
            self.wipe_tex = Some((key, tex));
        }
        let Some((_, tex)) = &self.wipe_tex else {
            return;
        };
        let s = self.wipe_split.clamp(0.0, 1.0);
        let x = rect.left() + rect.width() * s;
        let right = egui::Rect::from_min_max(egui::pos2(x, rect.top()), rect.max);
        let uv = egui::Rect::from_min_max(egui::pos2(s, 0.0), egui::pos2(1.0, 1.0));
        let painter = ui.painter_at(rect);
        painter.image(tex.id(), right, uv, egui::Color32::WHITE);
        painter.line_segment(
            [egui::pos2(x, rect.top()), egui::pos2(x, rect.bottom())],
            egui::Stroke::new(1.5, egui::Color32::YELLOW),
        );
        let font = egui::FontId::proportional(12.0);
        painter.text(
            rect.left_top() + egui::vec2(4.0, 4.0),
            egui::Align2::LEFT_TOP,
            format!("A {a}"),
            font.clone(),
            egui::Color32::YELLOW,
        );
        painter.text(
            rect.right_top() + egui::vec2(-4.0, 4.0),
            egui::Align2::RIGHT_TOP,
            format!("B {b}.{bport}"),
            font,
            egui::Color32::YELLOW,
        );
    }

    pub(super) fn show_picture(
        &mut self,
        ui: &mut egui::Ui,
        node: &str,
        pictures: &[(String, Raster)],
    ) {
        let port = self
            .view_port
            .clone()
            .filter(|p| pictures.iter().any(|(n, _)| n == p))
            .or_else(|| pictures.first().map(|(n, _)| n.clone()));
        let Some((port, raster)) = port.and_then(|p| pictures.iter().find(|(n, _)| *n == p)) else {
            ui.label("(this node has no picture output)");
            return;
        };
        let tex_key = format!("{node}.{port}:{:?}:{}", self.channel, self.exposure);
        if self.view_tex.as_ref().is_none_or(|(k, _)| *k != tex_key) {
            let image = colour_image(raster, self.channel, self.exposure);
            let tex = ui
                .ctx()
                .load_texture("viewer", image, egui::TextureOptions::NEAREST);
            self.view_tex = Some((tex_key, tex));
        }
        let Some((_, tex)) = &self.view_tex else {
            return;
        };
        // A proxy picture is drawn at the size of the full one.
        let size =
            egui::vec2(raster.width as f32, raster.height as f32) * self.proxy.display_scale();
        let shown = match self.zoom {
            Zoom::Fit => size * (ui.available_width() / size.x).min(300.0 / size.y),
            Zoom::One => size,
        };
        let image = egui::Image::new(tex)
            .fit_to_exact_size(shown)
            .sense(egui::Sense::click_and_drag());
        let response = match self.zoom {
            Zoom::Fit => ui.add(image),
            Zoom::One => {
                egui::ScrollArea::both()
                    .max_height(300.0)
                    .show(ui, |ui| ui.add(image))
                    .inner
            }
        };
        let response = response.on_hover_cursor(egui::CursorIcon::Crosshair);
        self.paint_wipe(ui, response.rect, node, port);
        response.widget_info(|| {
            egui::WidgetInfo::labeled(egui::WidgetType::Other, true, "viewer picture")
        });
        if let Some(pos) = response.hover_pos() {
            let rel = (pos - response.rect.min) / response.rect.size();
            let x = (rel.x * raster.width as f32).floor().max(0.0) as u32;
            let y = (rel.y * raster.height as f32).floor().max(0.0) as u32;
            self.probe = probe(pictures, x, y);
        }
        let size = (raster.width, raster.height);
        let at = |p: egui::Pos2| {
            let rel = (p - response.rect.min) / response.rect.size();
            [rel.x * size.0 as f32, rel.y * size.1 as f32]
        };
        let selected = self
            .selected
            .as_ref()
            .and_then(|id| self.state.graph().node(id))
            .and_then(|n| Some((n.id.clone(), self.registry.get(&n.kind)?.clone())));
        let tool = |t: EditorTool| selected.as_ref().is_some_and(|(_, k)| k.has_tool(t));
        let id = selected.as_ref().map(|(id, _)| id.clone());
        match id {
            Some(id) if tool(EditorTool::LayerList) && self.tf.arm_3d => {
                if let (true, Some(p)) = (response.clicked(), response.interact_pointer_pos()) {
                    let [x, y] = at(p);
                    let px = ((x as u32).min(size.0 - 1), (y as u32).min(size.1 - 1));
                    self.add_3d_constraint(&id, px, size);
                }
            }
            Some(id) if tool(EditorTool::StrokePainting) => {
                if self.strokes.armed {
                    for (p, start) in stroke_points(ui, &response) {
                        if let Err(e) = crate::stroke_panel::paint(
                            &self.state,
                            &id,
                            &mut self.strokes,
                            at(p),
                            size,
                            start,
                        ) {
                            self.status = e;
                        }
                    }
                }
                // The waiting strokes, drawn over the picture.
                let painter = ui.painter_at(response.rect);
                let r = response.rect;
                for (s, (w, h)) in
                    crate::stroke_panel::pending_in(&self.state, &id, &self.strokes, size)
                {
                    let (w, h) = (w.max(1) as f32, h.max(1) as f32);
                    let to = |q: &[f32; 2]| {
                        r.min + egui::vec2(q[0] / w * r.width(), q[1] / h * r.height())
                    };
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
            }
            Some(id) if tool(EditorTool::SplatBrush) => {
                self.brush_in_viewer(ui, &response, &id, size);
            }
            _ => {}
        }
        ui.label(egui::RichText::new(&self.probe).monospace().small());
    }

    /// The 3D brush over the viewer picture (`size` pixels shown in `response.rect`) while it is
    /// armed: the plane's tint, the outline under the pointer, and painting on drags.
    pub(super) fn brush_in_viewer(
        &mut self,
        ui: &egui::Ui,
        response: &egui::Response,
        selected: &str,
        size: (u32, u32),
    ) {
        use crate::brush_panel as brush;
        if !self.brush.armed {
            return;
        }
        let Some(target) =
            brush::target_for(&self.registry, self.state.graph(), &self.brush, selected)
        else {
            return;
        };
        // The view is rendered from the whole document, so a scene wired in from outside the
        // group entered is found; the painting goes to the node of the graph shown.
        let flat = match self.state.root().flatten(self.registry.catalog()) {
            Ok(f) => f,
            Err(e) => {
                self.status = e.to_string();
                return;
            }
        };
        let full = self.state.full_id(&target);
        let view = match self.brush.view_for(&self.registry, &flat, &full, size) {
            Ok(v) => v.clone(),
            Err(e) => {
                self.status = e;
                return;
            }
        };
        let r = response.rect;
        let at = |p: egui::Pos2| {
            let rel = (p - r.min) / r.size();
            [rel.x * size.0 as f32, rel.y * size.1 as f32]
        };
        // The plane: pixels whose surface lies behind it are tinted.
        let tex_key = format!("{}@{}", view.key, self.brush.depth);
        if self.brush_tex.as_ref().is_none_or(|(k, _)| *k != tex_key) {
            let tint = egui::Color32::from_rgba_unmultiplied(60, 130, 255, 100);
            let pixels = brush::plane_mask(&view, self.brush.depth)
                .iter()
                .map(|m| if *m { tint } else { egui::Color32::TRANSPARENT })
                .collect();
            let image = egui::ColorImage::new([view.size.0 as usize, view.size.1 as usize], pixels);
            let tex = ui
                .ctx()
                .load_texture("brush-plane", image, egui::TextureOptions::NEAREST);
            self.brush_tex = Some((tex_key, tex));
        }
        let Some((_, tex)) = &self.brush_tex else {
            return;
        };
        let painter = ui.painter_at(r);
        painter.image(
            tex.id(),
            r,
            egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
            egui::Color32::WHITE,
        );
        self.brush.hover = response.hover_pos().map(at);
        if let Some(p) = response.hover_pos() {
            let [rx, ry] = brush::outline_radii(&self.brush, &view.camera, view.size);
            let scale = r.width() / size.0.max(1) as f32;
            let colour = if self.brush.erase {
                egui::Color32::from_gray(20)
            } else {
                egui::Color32::WHITE
            };
            painter.add(egui::epaint::EllipseShape::stroke(
                p,
                egui::vec2(rx, ry) * scale,
                egui::Stroke::new(1.5, colour),
            ));
        }
        for (p, start) in stroke_points(ui, response) {
            if let Err(e) = brush::paint(
                &mut self.state,
                &mut self.brush,
                &target,
                &view.camera,
                at(p),
                size,
                start,
            ) {
                self.status = e;
            }
        }
        if response.drag_stopped() || response.clicked() {
            brush::end_stroke(&mut self.state, &mut self.brush);
        }
    }

    /// A click in the viewer while a TF's 3D constraint is armed: pick the surface under the
    /// pixel (an evaluation on this thread) and add a constraint anchored to it.
    pub fn add_3d_constraint(&mut self, id: &str, pixel: (u32, u32), size: (u32, u32)) {
        use tyndall_engine::eval::pick::pick;
        use tyndall_nodes::transfer_function::{Anchor, Constraint};
        let result = (|| -> Result<String, String> {
            let gpu = Gpu::shared().map_err(|e| e.to_string())?;
            let mut ev = tyndall_engine::eval::Evaluator::new(self.registry.clone(), gpu);
            let opts = tyndall_engine::eval::EvalOptions {
                time: self.time,
                size,
                ..Default::default()
            };
            let p = pick(
                &mut ev,
                self.state.root(),
                Some(&self.state.full_id(id)),
                pixel,
                &opts,
            )
            .map_err(|e| e.to_string())?;
            let s = p
                .surface
                .ok_or("no surface under this pixel (sky): nothing to anchor to")?;
            let tf = p.tf.ok_or("not a TransferFunction")?;
            let mut data = self
                .state
                .node_data::<tyndall_nodes::transfer_function::TfData>(id)?;
            let stack = crate::tf_panel::editable(&mut data, self.time)
                .ok_or("add a key at this frame to edit the stack")?;
            let c = Constraint {
                at: [tf.u, tf.v],
                colour: self.tf.brush,
                anchor: Some(Anchor {
                    object: s.object.clone(),
                    triangle: s.triangle,
                    bary: s.bary,
                }),
            };
            self.tf.layer = crate::tf_panel::add_constraint(stack, self.tf.layer, c);
            self.state.store_node_data(id, &data, None)?;
            Ok(format!(
                "3D constraint on {:?} triangle {} at V̄ {:.3}, depth {:.2} m",
                s.object, s.triangle, p.visibility, p.depth
            ))
        })();
        self.status = result.unwrap_or_else(|e| e);
    }
}

/// The pointer positions a painting stroke takes from `response` this frame, each with whether
/// it starts a stroke. egui recognises a drag only once the pointer has moved, so a stroke
/// starts where the button was pressed, then follows the pointer; a click is a one-point stroke.
pub(super) fn stroke_points(ui: &egui::Ui, response: &egui::Response) -> Vec<(egui::Pos2, bool)> {
    let mut points = Vec::new();
    if response.drag_started() || response.clicked() {
        let origin = ui.input(|i| i.pointer.press_origin());
        points.extend(
            origin
                .or(response.interact_pointer_pos())
                .map(|p| (p, true)),
        );
    }
    if response.dragged() {
        points.extend(response.interact_pointer_pos().map(|p| (p, false)));
    }
    points
}

/// An egui picture of `r` as the viewer shows it.
pub(super) fn colour_image(r: &Raster, channel: Channel, stops: f32) -> egui::ColorImage {
    let pixels = to_srgb8(r, channel, stops)
        .into_iter()
        .map(|p| egui::Color32::from_rgb(p[0], p[1], p[2]))
        .collect();
    egui::ColorImage::new([r.width as usize, r.height as usize], pixels)
}
