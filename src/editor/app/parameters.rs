//! The parameters panel: every parameter of the selected node with its range, key-frames,
//! measured settings, then the editor tools its declaration names.

use super::*;
use tyndall_engine::graph::ParamSpec;

impl EditorApp {
    /// Set node `id`'s parameters to a measured setting (`name → value` text, as in
    /// `bench/results.csv`) as one undoable step; a value that no longer parses is reported in
    /// the status line and nothing changes.
    pub(super) fn use_measured(&mut self, id: &str, setting: &BTreeMap<String, String>) {
        let result = self.state.apply(|g, c| {
            for (name, text) in setting {
                g.set_param_text(c, id, name, text)?;
            }
            Ok(())
        });
        self.status = match result {
            Ok(()) => format!("{id}: measured setting applied"),
            Err(e) => e.to_string(),
        };
    }

    pub(super) fn parameters(&mut self, ui: &mut egui::Ui) {
        let Some(id) = self.selected.clone() else {
            ui.label("Select a node to edit its parameters.");
            return;
        };
        let Some(node) = self.state.graph().node(&id).cloned() else {
            return;
        };
        let Some(schema) = self
            .state
            .graph()
            .kind_schema(self.state.catalog(), &node.kind)
        else {
            return;
        };
        ui.heading(format!("{id} - {}", node.kind));
        ui.label(schema.doc);
        if let Some(err) = self.report(&id).and_then(|r| r.error) {
            ui.colored_label(crate::panel::ERROR, err);
        }
        ui.separator();
        for p in schema.params {
            self.parameter(ui, &node, p);
        }
        if let Some(def) = self.state.graph().groups().get(&node.kind).cloned() {
            self.group_panel(ui, &id, &def);
        }
        self.measured_and_tools(ui, &node, schema);
    }

    /// A group instance's actions: Ungroup, Publish to library, and every inner parameter with
    /// an Expose button (it becomes a knob of the group).
    fn group_panel(&mut self, ui: &mut egui::Ui, id: &str, def: &tyndall_engine::graph::GroupDef) {
        ui.separator();
        match &def.library {
            Some(l) => ui.label(format!(
                "Library group {} version {} ({})",
                l.name,
                def.version,
                l.path.display()
            )),
            None => ui.label(format!("Group {} (embedded in this graph)", def.name)),
        };
        ui.horizontal(|ui| {
            if ui
                .button("Enter")
                .on_hover_text("Tab: show and edit the group's inside")
                .clicked()
            {
                self.enter_or_leave();
            }
            if ui.button("Ungroup").clicked() {
                self.status = match self.state.ungroup(id) {
                    Ok(()) => format!("{id}: ungrouped"),
                    Err(e) => e.to_string(),
                };
            }
            if ui
                .button("Publish to library")
                .on_hover_text(format!(
                    "Write the group to {} and reference it from this graph",
                    self.publish_folder().display()
                ))
                .clicked()
            {
                let lib = self.publish_folder();
                let reference = snake(&def.name);
                self.status = match self.state.publish(id, &lib, &reference) {
                    Ok(path) => format!("published {} to {}", def.name, path.display()),
                    Err(e) => e.to_string(),
                };
            }
        });
        egui::CollapsingHeader::new(format!("Inside {} ({} nodes)", def.name, def.graph.len()))
            .id_salt(("group-inside", id))
            .show(ui, |ui| {
                let cat = self.state.catalog().clone();
                for n in def.graph.nodes() {
                    let Some(schema) = def.graph.kind_schema(&cat, &n.kind) else {
                        continue;
                    };
                    ui.label(egui::RichText::new(format!("{} - {}", n.id, n.kind)).strong());
                    for p in schema.params {
                        let exposed = def
                            .knobs
                            .iter()
                            .any(|k| k.targets.contains(&(n.id.clone(), p.name.to_string())));
                        ui.horizontal(|ui| {
                            ui.label(format!("  {}", p.name));
                            if exposed {
                                ui.weak("exposed");
                            } else if ui.small_button("Expose").clicked() {
                                self.status = match self.state.expose(id, &n.id, p.name, p.name) {
                                    Ok(()) => format!("{}: {}.{} exposed", def.name, n.id, p.name),
                                    Err(e) => e.to_string(),
                                };
                            }
                        });
                    }
                }
            });
    }

    /// Where Publish writes: the `lib/` folder the document's graphs find (beside it or one
    /// folder up), else the user's (`$TYNDALL_PRESETS/lib`), else `graphs/lib`.
    fn publish_folder(&self) -> std::path::PathBuf {
        self.state
            .path()
            .map(tyndall_engine::graph::library_folders)
            .and_then(|f| f.into_iter().next())
            .or_else(tyndall_engine::graph::user_library)
            .unwrap_or_else(|| std::path::PathBuf::from("graphs/lib"))
    }

    /// The measured settings of the node's kind, then the tools its declaration names.
    fn measured_and_tools(
        &mut self,
        ui: &mut egui::Ui,
        node: &tyndall_engine::graph::Node,
        schema: &tyndall_engine::graph::NodeSchema,
    ) {
        let id = node.id.clone();
        let current: BTreeMap<String, String> = schema
            .params
            .iter()
            .map(|p| {
                let v = self
                    .state
                    .graph()
                    .param_at(self.state.catalog(), &id, p.name, self.time)
                    .unwrap_or(p.default.value());
                (p.name.to_string(), v.to_string())
            })
            .collect();
        if let Some(setting) = self.bench.show(ui, &node.kind, &current) {
            self.use_measured(&id, &setting);
        }
        self.each_tool(&id, |tool, cx| tool.panel(ui, cx));
    }

    /// One parameter's row: its widget (greyed out, with the reason, while the parameter is
    /// not in effect), its key-frame button, and the edit it makes.
    fn parameter(&mut self, ui: &mut egui::Ui, node: &tyndall_engine::graph::Node, p: &ParamSpec) {
        let id = node.id.as_str();
        let current = self
            .state
            .graph()
            .param_at(self.state.catalog(), id, p.name, self.time)
            .unwrap_or(p.default.value());
        let in_effect =
            self.state
                .graph()
                .param_in_effect(self.state.catalog(), id, p.name, self.time);
        // Inside a group, a parameter a knob drives is set on the group node instead.
        let driven = self.state.driving_knob(id, p.name);
        let inside = !self.state.scope().is_empty();
        let mut changed: Option<ParamValue> = None;
        let mut toggle_key = false;
        let mut expose = false;
        ui.horizontal(|ui| {
            let label = ui.add_enabled(in_effect.is_ok(), egui::Label::new(p.name));
            match &in_effect {
                Ok(()) => label.on_hover_text(format!("{} ({})", p.doc, p.expected())),
                Err(why) => {
                    label.on_disabled_hover_text(format!("{} — not in effect: counts {why}", p.doc))
                }
            };
            ui.add_enabled_ui(in_effect.is_ok() && driven.is_none(), |ui| {
                changed = param_widget(ui, p, &current);
            });
            match &driven {
                Some(k) => {
                    ui.weak(format!("knob {k}")).on_hover_text(
                        "the group node's knob sets this parameter: change it there (Tab leaves)",
                    );
                }
                None if inside => {
                    expose = ui
                        .small_button("Expose")
                        .on_hover_text("make this parameter a knob of the group entered")
                        .clicked();
                }
                None => {}
            }
            toggle_key = key_button(ui, node, p, self.time);
        });
        if expose {
            self.status = match self.state.expose_here(id, p.name) {
                Ok(k) => format!("{id}.{} exposed as knob '{k}'", p.name),
                Err(e) => e.to_string(),
            };
            return;
        }
        let keys = node.keys.get(p.name).cloned();
        let numeric = |v: &ParamValue| match v {
            ParamValue::Float(x) => Some(*x),
            ParamValue::Int(x) => Some(*x as f64),
            _ => None,
        };
        let result = if toggle_key {
            let mut k = keys.unwrap_or_default();
            if let Some(i) = k.iter().position(|k| k.t == self.time) {
                k.remove(i);
            } else if let Some(v) = numeric(&current) {
                k.push(Key {
                    t: self.time,
                    v,
                    interp: Interp::Linear,
                });
            }
            Some(self.state.set_keys(id, p.name, k))
        } else if let Some(v) = changed {
            // A keyed parameter edits (or adds) its key at this frame, as in Blender.
            match (keys, numeric(&v)) {
                (Some(mut k), Some(x)) => {
                    match k.iter_mut().find(|k| k.t == self.time) {
                        Some(key) => key.v = x,
                        None => k.push(Key {
                            t: self.time,
                            v: x,
                            interp: Interp::Linear,
                        }),
                    }
                    Some(self.state.set_keys(id, p.name, k))
                }
                _ => Some(self.state.set_param(id, p.name, v)),
            }
        } else {
            None
        };
        if let Some(Err(e)) = result {
            self.status = e.to_string();
        }
    }
}

/// The widget of one parameter for its kind; `Some(value)` when the user changed it.
fn param_widget(ui: &mut egui::Ui, p: &ParamSpec, current: &ParamValue) -> Option<ParamValue> {
    let mut changed = None;
    match (&p.kind, current) {
        (ParamKind::Float, ParamValue::Float(v)) => {
            let mut x = *v;
            let speed = ((p.max - p.min) / 500.0).clamp(1e-4, 1.0);
            if ui
                .add(
                    egui::DragValue::new(&mut x)
                        .range(p.min..=p.max)
                        .speed(speed),
                )
                .on_hover_text(p.doc)
                .changed()
            {
                changed = Some(ParamValue::Float(x));
            }
        }
        (ParamKind::Int, ParamValue::Int(v)) => {
            let mut x = *v;
            if ui
                .add(egui::DragValue::new(&mut x).range(p.min as i64..=p.max as i64))
                .on_hover_text(p.doc)
                .changed()
            {
                changed = Some(ParamValue::Int(x));
            }
        }
        (ParamKind::Bool, ParamValue::Bool(v)) => {
            let mut x = *v;
            if ui.checkbox(&mut x, "").on_hover_text(p.doc).changed() {
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
        (ParamKind::Vec3, ParamValue::Vec3(c)) => {
            let mut v = *c;
            let mut edited = false;
            for x in &mut v {
                edited |= ui
                    .add(egui::DragValue::new(x).range(p.min..=p.max).speed(0.05))
                    .on_hover_text(p.doc)
                    .changed();
            }
            if edited {
                changed = Some(ParamValue::Vec3(v));
            }
        }
        _ => {
            ui.label(current.to_string());
        }
    }
    changed
}

/// `HoleFilling` → `hole_filling`: a group's name as a library file name.
fn snake(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            out.push('_');
        }
        out.extend(c.to_lowercase());
    }
    out
}

/// The key-frame button after a numeric parameter's widget (◆ key at `time`, ◇ animated, ○
/// not keyed); returns whether it was clicked (add or remove the key at `time`).
fn key_button(
    ui: &mut egui::Ui,
    node: &tyndall_engine::graph::Node,
    p: &ParamSpec,
    time: f64,
) -> bool {
    if !matches!(p.kind, ParamKind::Float | ParamKind::Int) {
        return false;
    }
    let keys = node.keys.get(p.name);
    let here = keys.is_some_and(|k| k.iter().any(|k| k.t == time));
    let (mark, tip) = match (keys.is_some(), here) {
        (_, true) => ("◆", "key at this frame: click to remove it"),
        (true, false) => ("◇", "animated: click to add a key at this frame"),
        (false, _) => ("○", "click to key this parameter at this frame"),
    };
    ui.add(egui::Button::new(mark).small())
        .on_hover_text(tip)
        .clicked()
}
