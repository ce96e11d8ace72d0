//! The catalog of node kinds and the preset browser.

use super::*;

impl EditorApp {
    /// The add-node catalog: a search field and the kinds by category; a click adds the node
    /// near the canvas's top-left and selects it.
    pub(super) fn catalog(&mut self, ui: &mut egui::Ui) {
        ui.heading("Add node");
        ui.horizontal(|ui| {
            let label = ui.label("Find");
            ui.add(egui::TextEdit::singleline(&mut self.search).hint_text("node or category"))
                .labelled_by(label.id);
        });
        let needle = self.search.to_lowercase();
        let mut by_category: BTreeMap<&str, Vec<(&str, &str)>> = BTreeMap::new();
        for s in self.state.catalog().iter() {
            if needle.is_empty()
                || s.kind.to_lowercase().contains(&needle)
                || s.category.to_lowercase().contains(&needle)
            {
                by_category
                    .entry(s.category)
                    .or_default()
                    .push((s.kind, s.doc));
            }
        }
        for (category, kinds) in by_category {
            egui::CollapsingHeader::new(category)
                .open((!needle.is_empty()).then_some(true))
                .show(ui, |ui| {
                    for (kind, doc) in kinds {
                        if ui.button(kind).on_hover_text(doc).clicked() {
                            let n = self.state.graph().nodes().count() as f32;
                            match self
                                .state
                                .add_node(kind, [40.0 + 20.0 * n, 40.0 + 10.0 * n])
                            {
                                Ok(id) => self.selected = Some(id),
                                Err(e) => self.status = e.to_string(),
                            }
                        }
                    }
                });
        }
        self.library_menu(ui, &needle);
    }

    /// The library groups (`lib/` folders beside the document and the user's) in the Add-node
    /// list: a click adds an instance referencing the group's file.
    fn library_menu(&mut self, ui: &mut egui::Ui, needle: &str) {
        let library = self.library.get_or_insert_with(|| {
            let here = self
                .state
                .path()
                .map(std::path::Path::to_path_buf)
                .unwrap_or_else(|| PathBuf::from("graphs/untitled.ron"));
            tyndall_engine::graph::list_library(&tyndall_engine::graph::library_folders(&here))
        });
        let shown: Vec<(PathBuf, String)> = library
            .iter()
            .filter(|(_, r)| needle.is_empty() || r.to_lowercase().contains(needle))
            .cloned()
            .collect();
        if shown.is_empty() {
            return;
        }
        egui::CollapsingHeader::new("Library groups")
            .open((!needle.is_empty()).then_some(true))
            .show(ui, |ui| {
                for (folder, reference) in shown {
                    let tip = format!("{reference}.ron in {}", folder.display());
                    if !ui.button(&reference).on_hover_text(tip).clicked() {
                        continue;
                    }
                    let cat = self.state.catalog().clone();
                    let n = self.state.graph().nodes().count() as f32;
                    let pos = [40.0 + 20.0 * n, 40.0 + 10.0 * n];
                    let added =
                        tyndall_engine::graph::load_library_group(&folder, &reference, &cat)
                            .map_err(|e| e.to_string())
                            .and_then(|def| {
                                self.state
                                    .add_group_node(def, pos)
                                    .map_err(|e| e.to_string())
                            });
                    match added {
                        Ok(id) => self.selected = Some(id),
                        Err(e) => self.status = e,
                    }
                }
            });
    }

    /// The preset browser: `graphs/` and the user folder, with thumbnails (the preset's
    /// `NAME.png` beside it, else its render under `docs/`), load / merge, save.
    pub(super) fn presets_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Presets");
        if self.presets.is_empty() || ui.small_button("refresh").clicked() {
            self.presets = list_presets(&self.preset_folders);
            self.library = None;
        }
        ui.horizontal(|ui| {
            ui.add(
                egui::TextEdit::singleline(&mut self.preset_name)
                    .hint_text("name")
                    .desired_width(110.0),
            );
            let selection = self.selection(ui.ctx());
            let folder = user_preset_folder();
            let save = |ids: &[String], what: &str| {
                let Some(dir) = folder.clone() else {
                    return "no user preset folder (set TYNDALL_PRESETS)".to_string();
                };
                let name = self.preset_name.trim();
                if name.is_empty() || name.contains(['/', '\\']) {
                    return "give the preset a name (no slashes)".to_string();
                }
                let path = dir.join(format!("{name}.ron"));
                let res = std::fs::create_dir_all(&dir)
                    .map_err(|e| e.to_string())
                    .and_then(|()| {
                        self.state
                            .save_preset(ids, &path)
                            .map_err(|e| e.to_string())
                    });
                match res {
                    Ok(()) => format!("saved {what} as {}", path.display()),
                    Err(e) => e,
                }
            };
            if ui
                .button("Save graph")
                .on_hover_text("save the whole graph as a preset in the user folder")
                .clicked()
            {
                let all: Vec<String> = self.state.graph().nodes().map(|n| n.id.clone()).collect();
                self.status = save(&all, "the graph");
                self.presets.clear();
            }
            if ui
                .add_enabled(!selection.is_empty(), egui::Button::new("Save selection"))
                .clicked()
            {
                self.status = save(&selection, "the selection");
                self.presets.clear();
            }
        });
        let entries = self.presets.clone();
        egui::ScrollArea::vertical()
            .id_salt("presets")
            .show(ui, |ui| {
                for p in entries {
                    ui.horizontal(|ui| {
                        match self.preset_thumb(ui.ctx(), &p.path) {
                            Some(t) => {
                                ui.add(
                                    egui::Image::new(&t).fit_to_exact_size(egui::vec2(64.0, 36.0)),
                                );
                            }
                            None => {
                                let (r, _) = ui.allocate_exact_size(
                                    egui::vec2(64.0, 36.0),
                                    egui::Sense::hover(),
                                );
                                ui.painter()
                                    .rect_filled(r, 2.0, ui.visuals().faint_bg_color);
                            }
                        }
                        ui.vertical(|ui| {
                            ui.label(&p.name);
                            ui.horizontal(|ui| {
                                if ui.small_button("Load").clicked() {
                                    self.load_preset(&p.path);
                                }
                                if ui.small_button("Merge").clicked() {
                                    self.merge_preset(&p.path);
                                }
                            });
                        });
                    });
                }
            });
    }

    pub(super) fn preset_thumb(
        &mut self,
        ctx: &egui::Context,
        path: &Path,
    ) -> Option<egui::TextureHandle> {
        if let Some(t) = self.preset_thumbs.get(path) {
            return t.clone();
        }
        let tex = crate::preset_thumbnail(path)
            .and_then(|p| image::open(p).ok())
            .map(|img| {
                let img = img.thumbnail(128, 72).to_rgba8();
                let size = [img.width() as usize, img.height() as usize];
                let image = egui::ColorImage::from_rgba_unmultiplied(size, img.as_raw());
                ctx.load_texture(
                    format!("preset-{}", path.display()),
                    image,
                    egui::TextureOptions::LINEAR,
                )
            });
        self.preset_thumbs.insert(path.to_path_buf(), tex.clone());
        tex
    }

    /// Replace the document with a preset (undoable; the file path stays the current one).
    pub fn load_preset(&mut self, path: &Path) {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) => {
                self.status = format!("{}: {e}", path.display());
                return;
            }
        };
        let res = tyndall_engine::graph::load_str(&text, path, self.state.catalog())
            .map_err(|e| e.to_string())
            .and_then(|fresh| {
                self.state
                    .apply(|g, _| {
                        *g = fresh;
                        Ok(())
                    })
                    .map_err(|e| e.to_string())
            });
        self.status = match res {
            Ok(()) => format!("loaded {}", path.display()),
            Err(e) => e,
        };
        self.frame_all = true;
    }

    /// Add a preset's nodes to the document with fresh ids (one undo step).
    pub fn merge_preset(&mut self, path: &Path) {
        // Read from the preset's own folder, so its library groups are found.
        let res = std::fs::read_to_string(path)
            .map_err(|e| e.to_string())
            .and_then(|t| {
                tyndall_engine::graph::load_str(&t, path, self.state.catalog())
                    .map_err(|e| e.to_string())
            })
            .and_then(|clip| {
                self.state
                    .paste_graph(&clip, [60.0, 60.0])
                    .map_err(|e| e.to_string())
            });
        self.status = match res {
            Ok(ids) => format!("merged {} node(s) from {}", ids.len(), path.display()),
            Err(e) => e,
        };
    }
}

/// The user preset folder: `$TYNDALL_PRESETS`, else `~/.config/tyndall/presets`.
pub fn user_preset_folder() -> Option<PathBuf> {
    std::env::var_os("TYNDALL_PRESETS")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config/tyndall/presets"))
        })
}
