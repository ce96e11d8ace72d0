//! Keyboard shortcuts, the clipboard, saving, and the dialogs (GPU recovery, unsaved changes).

use super::*;

impl EditorApp {
    /// Ids of the nodes selected on the canvas.
    pub(super) fn selection(&self, ctx: &egui::Context) -> Vec<String> {
        get_selected_nodes(self.canvas_id(), ctx)
            .into_iter()
            .filter_map(|n| self.snarl.get_node(n).cloned())
            .collect()
    }

    /// Keyboard shortcuts (when no text field has the keyboard) and clipboard events.
    pub(super) fn shortcuts(&mut self, ctx: &egui::Context) {
        // Only a text field takes the keys (a focused button or node frame does not).
        let typing = ctx.text_edit_focused();
        let selection = self.selection(ctx);
        if !typing {
            self.clipboard_events(ctx, &selection);
        }
        let (undo, redo, save) = ctx.input(|i| {
            let cmd = i.modifiers.command;
            (
                cmd && i.key_pressed(egui::Key::Z) && !i.modifiers.shift,
                cmd && (i.key_pressed(egui::Key::Y)
                    || (i.modifiers.shift && i.key_pressed(egui::Key::Z))),
                cmd && i.key_pressed(egui::Key::S),
            )
        });
        if undo && !typing {
            self.state.undo();
        }
        if redo && !typing {
            self.state.redo();
        }
        if save {
            self.save();
        }
        if typing {
            return;
        }
        let mut enter_or_leave = false;
        ctx.input(|i| {
            self.pin_keys(i);
            if i.key_pressed(egui::Key::F) && !i.modifiers.command {
                self.frame_all = true;
            }
            if i.key_pressed(egui::Key::W) && !i.modifiers.command {
                self.toggle_wipe();
            }
            if i.key_pressed(egui::Key::Tab) && !i.modifiers.any() {
                enter_or_leave = true;
            }
            if i.key_pressed(egui::Key::Space) {
                self.playing = !self.playing;
            }
            if i.key_pressed(egui::Key::D) && i.modifiers.command && !selection.is_empty() {
                let _ = self.state.duplicate(&selection);
            }
            if i.key_pressed(egui::Key::G) && i.modifiers.command {
                self.group_key(i.modifiers.shift, &selection);
            }
            if (i.key_pressed(egui::Key::Delete) || i.key_pressed(egui::Key::Backspace))
                && !selection.is_empty()
            {
                let _ = self.state.delete(&selection);
            }
        });
        if enter_or_leave {
            // Tab is ours here, not egui's move to the next widget.
            ctx.memory_mut(|m| m.move_focus(egui::FocusDirection::None));
            self.enter_or_leave();
        }
    }

    /// Copy, cut and paste events (the keyboard's or the menu's), outside text fields.
    fn clipboard_events(&mut self, ctx: &egui::Context, selection: &[String]) {
        let events = ctx.input(|i| i.events.clone());
        for e in &events {
            match e {
                egui::Event::Copy | egui::Event::Cut if !selection.is_empty() => {
                    self.clipboard = self.state.copy(selection);
                    ctx.copy_text(self.clipboard.clone());
                    if matches!(e, egui::Event::Cut) {
                        let _ = self.state.delete(selection);
                    }
                    self.status = format!("copied {} node(s)", selection.len());
                }
                egui::Event::Paste(text) => {
                    let text = if text.trim_start().starts_with('(') {
                        text.clone()
                    } else {
                        self.clipboard.clone()
                    };
                    self.status = match self.state.paste(&text, [40.0, 40.0]) {
                        Ok(ids) => format!("pasted {} node(s)", ids.len()),
                        Err(e) => format!("nothing to paste: {e}"),
                    };
                }
                _ => {}
            }
        }
    }

    /// Keys 1–9 show pin 1–9 (again: the selection); Shift+1–9 pins the selected node.
    fn pin_keys(&mut self, i: &egui::InputState) {
        let keys = [
            egui::Key::Num1,
            egui::Key::Num2,
            egui::Key::Num3,
            egui::Key::Num4,
            egui::Key::Num5,
            egui::Key::Num6,
            egui::Key::Num7,
            egui::Key::Num8,
            egui::Key::Num9,
        ];
        for (slot, k) in keys.iter().enumerate() {
            if i.key_pressed(*k) && !i.modifiers.command {
                if i.modifiers.shift {
                    if let Some(id) = self.selected.clone() {
                        self.pins[slot] = Some(self.state.full_id(&id));
                        self.active_pin = Some(slot);
                    }
                } else if self.pins[slot].is_some() {
                    self.active_pin = if self.active_pin == Some(slot) {
                        None
                    } else {
                        Some(slot)
                    };
                }
            }
        }
    }

    /// Ctrl+G groups the selection; Ctrl+Shift+G (`shift`) ungroups the selected group node.
    fn group_key(&mut self, shift: bool, selection: &[String]) {
        if shift {
            if let Some(id) = self.selected.clone() {
                self.status = match self.state.ungroup(&id) {
                    Ok(()) => format!("{id}: ungrouped"),
                    Err(e) => e.to_string(),
                };
            }
        } else if !selection.is_empty() {
            self.status = match self.state.group(selection) {
                Ok(g) => {
                    self.selected = Some(g.clone());
                    format!("grouped {} node(s) into {g}", selection.len())
                }
                Err(e) => e.to_string(),
            };
        }
    }

    /// Save to the document's file, or ask for one.
    pub fn save(&mut self) {
        if self.state.path().is_none() {
            self.save_as = Some("graphs/untitled.ron".into());
            return;
        }
        self.status = match self.state.save() {
            Ok(()) => "saved".into(),
            Err(e) => e.to_string(),
        };
    }
}

impl EditorApp {
    /// The recovery offer and the unsaved-changes prompt.
    pub(super) fn dialogs(&mut self, ctx: &egui::Context) {
        if let Some(problem) = &self.gpu_problem {
            let mut open = true;
            egui::Window::new("No usable GPU adapter")
                .collapsible(false)
                .open(&mut open)
                .show(ctx, |ui| {
                    ui.label(problem);
                    ui.label("The graph can be edited and saved; pictures are off. `tyndall info` says more.");
                });
            if !open {
                self.gpu_problem = None;
            }
        }
        if let Some(mut path) = self.save_as.take() {
            let mut keep = true;
            egui::Window::new("Save as")
                .collapsible(false)
                .resizable(false)
                .show(ctx, |ui| {
                    ui.text_edit_singleline(&mut path);
                    ui.horizontal(|ui| {
                        if ui.button("Save").clicked() {
                            self.status = match self.state.save_as(Path::new(&path)) {
                                Ok(()) => format!("saved {path}"),
                                Err(e) => e.to_string(),
                            };
                            keep = false;
                        }
                        if ui.button("Cancel").clicked() {
                            keep = false;
                        }
                    });
                });
            if keep {
                self.save_as = Some(path);
            }
        }
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
