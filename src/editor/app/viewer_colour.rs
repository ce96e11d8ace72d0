//! The viewer's display, view and look menus (issue #45; Nuke's viewer process, Blender's view
//! transform): the colour config's display / view with a look, applied after the viewer's
//! exposure — on the GPU ([`tyndall_engine::colour_pass::view`]) when pictures are textures,
//! on the CPU ([`crate::view::to_display8`]) when they are read back. No display chosen is
//! Tyndall's plain sRGB encoding, as before. The pixel probe keeps showing the picture's own
//! values, in the graph's working space.

use std::sync::Arc;

use eframe::egui;
use tyndall_engine::colour_pass::ViewTransform;

/// Label of the display menu's first entry: no transform, the plain sRGB encoding.
pub const PLAIN: &str = "plain sRGB";

/// The viewer's display, view and look, and the transform made of them.
#[derive(Default)]
pub struct ViewerColour {
    /// A display of the colour config; empty: the plain sRGB encoding (no transform).
    pub display: String,
    /// A view of `display`; empty: the display's default view.
    pub view: String,
    /// A look of the config applied before the view; empty: none.
    pub look: String,
    /// The transform last made, by what it was made of, or why it could not be.
    built: Option<(String, Result<Arc<ViewTransform>, String>)>,
}

impl ViewerColour {
    /// What the picture depends on (part of the shown textures' keys).
    pub fn key(&self) -> String {
        format!("{}|{}|{}", self.display, self.view, self.look)
    }

    /// The transform from `working` (the graph's working space), made when the choice or the
    /// space changed; None for the plain encoding or when it cannot be made ([`Self::error`]).
    pub fn transform(&mut self, working: &str) -> Option<Arc<ViewTransform>> {
        if self.display.is_empty() {
            self.built = None;
            return None;
        }
        let key = format!("{working}|{}", self.key());
        if self.built.as_ref().is_none_or(|(k, _)| *k != key) {
            let made = tyndall_engine::colour::current()
                .and_then(|c| {
                    ViewTransform::new(&c, working, &self.display, &self.view, &self.look)
                })
                .map(Arc::new)
                .map_err(|e| e.to_string());
            self.built = Some((key, made));
        }
        self.built.as_ref()?.1.as_ref().ok().cloned()
    }

    /// Why the chosen transform could not be made (the picture then shows plain sRGB).
    pub fn error(&self) -> Option<&str> {
        self.built.as_ref()?.1.as_ref().err().map(String::as_str)
    }

    /// The display menu, from the current colour config (at the end of the pins' row, so the
    /// viewer keeps its height with plain sRGB); true when the choice changed.
    pub fn display_menu(&mut self, ui: &mut egui::Ui) -> bool {
        let config = match tyndall_engine::colour::current() {
            Ok(c) => c,
            Err(e) => {
                ui.colored_label(ui.visuals().error_fg_color, "no colour config")
                    .on_hover_text(e.to_string());
                return false;
            }
        };
        let mut changed = false;
        let shown = if self.display.is_empty() {
            PLAIN
        } else {
            &self.display
        };
        ui.label("display");
        egui::ComboBox::from_id_salt("view-display")
            .width(130.0)
            .truncate()
            .selected_text(shown)
            .show_ui(ui, |ui| {
                let mut pick = |ui: &mut egui::Ui, value: &str, label: &str| {
                    if ui.selectable_label(self.display == value, label).clicked() {
                        self.display = value.to_string();
                        self.view.clear();
                        changed = true;
                    }
                };
                pick(ui, "", PLAIN);
                for d in config.displays() {
                    pick(ui, &d, &d);
                }
            })
            .response
            .on_hover_text(format!(
                "Display of the colour config ({}), after the exposure",
                config.source()
            ));
        changed
    }

    /// The view and look menus of the chosen display (a row of their own, shown only once a
    /// display is chosen); true when the choice changed.
    pub fn view_menus(&mut self, ui: &mut egui::Ui) -> bool {
        let Ok(config) = tyndall_engine::colour::current() else {
            return false;
        };
        let mut changed = false;
        let views = config.views(&self.display);
        let view = if self.view.is_empty() {
            views.first().cloned().unwrap_or_default()
        } else {
            self.view.clone()
        };
        ui.label("view");
        egui::ComboBox::from_id_salt("view-view")
            .width(190.0)
            .truncate()
            .selected_text(&view)
            .show_ui(ui, |ui| {
                for v in &views {
                    if ui.selectable_label(*v == view, v).clicked() {
                        self.view = v.clone();
                        changed = true;
                    }
                }
            });
        ui.label("look");
        egui::ComboBox::from_id_salt("view-look")
            .width(140.0)
            .truncate()
            .selected_text(if self.look.is_empty() {
                "None"
            } else {
                &self.look
            })
            .show_ui(ui, |ui| {
                if ui.selectable_label(self.look.is_empty(), "None").clicked() {
                    self.look.clear();
                    changed = true;
                }
                for l in config.looks() {
                    if ui.selectable_label(self.look == l, &l).clicked() {
                        self.look = l;
                        changed = true;
                    }
                }
            });
        if let Some(e) = self.error() {
            ui.colored_label(ui.visuals().error_fg_color, "⚠")
                .on_hover_text(e.to_string());
        }
        changed
    }
}
