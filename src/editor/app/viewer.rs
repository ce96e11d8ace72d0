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
            ui.separator();
            if self.viewer_colour.display_menu(ui) {
                self.view_tex = None;
                self.wipe_tex = None;
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
        if !self.viewer_colour.display.is_empty() {
            ui.horizontal(|ui| {
                if self.viewer_colour.view_menus(ui) {
                    self.view_tex = None;
                    self.wipe_tex = None;
                }
            });
        }
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
        let key = format!(
            "{b}.{bport}:{:?}:{}:{}",
            self.channel,
            self.exposure,
            self.viewer_colour.key()
        );
        if self.wipe_tex.as_ref().is_none_or(|(k, _)| *k != key) {
            let transform = self
                .viewer_colour
                .transform(self.state.graph().working_space());
            let window = self.window.as_ref();
            let how = (self.channel, self.exposure, transform.as_deref());
            self.wipe_tex = shown::viewer_texture(ui.ctx(), window, "viewer-wipe", raster, how)
                .map(|tex| (key, tex));
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
        pictures: &[(String, Picture)],
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
        let tex_key = format!(
            "{node}.{port}:{:?}:{}:{}",
            self.channel,
            self.exposure,
            self.viewer_colour.key()
        );
        if self.view_tex.as_ref().is_none_or(|(k, _)| *k != tex_key) {
            let transform = self.viewer_transform();
            let window = self.window.as_ref();
            let how = (self.channel, self.exposure, transform.as_deref());
            self.view_tex = shown::viewer_texture(ui.ctx(), window, "viewer", raster, how)
                .map(|tex| (tex_key, tex));
        }
        let Some((_, tex)) = &self.view_tex else {
            return;
        };
        let (width, height) = raster.size();
        // A proxy picture is drawn at the size of the full one.
        let size = egui::vec2(width as f32, height as f32) * self.proxy.display_scale();
        let shown = match self.zoom {
            Zoom::Fit => size * (ui.available_width() / size.x).min(300.0 / size.y),
            Zoom::One => size,
        };
        let image = egui::Image::new((tex.id(), tex.size_vec2()))
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
            let x = (rel.x * width as f32).floor().max(0.0) as u32;
            let y = (rel.y * height as f32).floor().max(0.0) as u32;
            self.probe_pixel(ui.ctx(), pictures, x, y);
        }
        let size = (width, height);
        // The selected node's tools take the pointer over the picture and draw over it.
        if let Some(id) = self.selected.clone() {
            self.each_tool(&id, |tool, cx| tool.viewer(ui, &response, size, cx));
        }
        let probe = if self.probe.is_empty() {
            String::new()
        } else {
            // The values are the picture's own: in the graph's working space, before exposure
            // and the display transform.
            format!("{}   [{}]", self.probe, self.state.graph().working_space())
        };
        ui.label(egui::RichText::new(probe).monospace().small());
    }

    /// The viewer's display transform for the graph's working space (None: plain sRGB).
    fn viewer_transform(&mut self) -> Option<Arc<tyndall_engine::colour_pass::ViewTransform>> {
        let working = self.state.graph().working_space().to_string();
        self.viewer_colour.transform(&working)
    }
}

impl EditorApp {
    /// The probe's line for pixel (`x`, `y`): from read-back pixels at once; from textures by
    /// reading that texel back without waiting (the line follows a frame or two later).
    fn probe_pixel(&mut self, ctx: &egui::Context, pictures: &[(String, Picture)], x: u32, y: u32) {
        if pictures.iter().all(|(_, p)| p.pixels().is_some()) {
            let values: Vec<(String, Vec<f32>)> = pictures
                .iter()
                .filter_map(|(n, p)| Some((n.clone(), texel(p.pixels()?, x, y)?)))
                .collect();
            self.probe = crate::view::probe_line(x, y, &values);
            return;
        }
        let Some(window) = self.window.as_ref() else {
            return;
        };
        if let Some(line) = self.probe_reads.update(&window.gpu, pictures, x, y) {
            self.probe = line;
        }
        if self.probe_reads.waiting() {
            ctx.request_repaint_after(std::time::Duration::from_millis(16));
        }
    }
}

/// The values of pixel (`x`, `y`) of `r`, when inside.
fn texel(r: &Raster, x: u32, y: u32) -> Option<Vec<f32>> {
    (x < r.width && y < r.height).then(|| {
        let i = (y * r.width + x) as usize * r.channels as usize;
        r.data[i..i + r.channels as usize].to_vec()
    })
}

/// An egui picture of `r` as the viewer shows it.
pub(super) fn colour_image(r: &Raster, how: shown::ViewerLook<'_>) -> egui::ColorImage {
    let (channel, stops, transform) = how;
    let pixels = crate::view::to_display8(r, channel, stops, transform)
        .into_iter()
        .map(|p| egui::Color32::from_rgb(p[0], p[1], p[2]))
        .collect();
    egui::ColorImage::new([r.width as usize, r.height as usize], pixels)
}
