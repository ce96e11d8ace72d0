//! Groups on the canvas: Tab enters the selected group node and leaves the group entered; the
//! breadcrumb at the top of the canvas shows where the canvas is and leaves to any level.

use super::*;

impl EditorApp {
    /// Enter the selected group node (Tab), or leave the group entered when the selection is
    /// not a group; the canvas is framed on what it shows now.
    pub fn enter_or_leave(&mut self) {
        let group = self.selected.clone().filter(|id| {
            let g = self.state.graph();
            g.node(id).is_some_and(|n| g.groups().contains_key(&n.kind))
        });
        match group {
            Some(id) => {
                self.status = match self.state.enter(&id) {
                    Ok(()) => format!("inside {} (Tab leaves)", self.state.full_id("")),
                    Err(e) => e.to_string(),
                };
                self.selected = None;
            }
            None => {
                if let Some(left) = self.state.leave() {
                    self.selected = Some(left);
                    self.status.clear();
                }
            }
        }
        self.frame_all = true;
    }

    /// The path of groups entered (`Document › look (Shafts)`, each level a link back to it),
    /// the group's ports, and whether it comes from a library; nothing at the document.
    pub(super) fn breadcrumb(&mut self, ui: &mut egui::Ui) {
        let scope = self.state.scope().to_vec();
        if scope.is_empty() {
            return;
        }
        let mut go = None;
        ui.horizontal(|ui| {
            if ui.link("Document").clicked() {
                go = Some(0);
            }
            for (i, id) in scope.iter().enumerate() {
                ui.label("›");
                let kind = self
                    .state
                    .root()
                    .inside(&scope[..i])
                    .and_then(|g| g.node(id))
                    .map(|n| n.kind.clone())
                    .unwrap_or_default();
                let text = format!("{id} ({kind})");
                if i + 1 == scope.len() {
                    ui.strong(text);
                } else if ui.link(text).clicked() {
                    go = Some(i + 1);
                }
            }
            ui.weak("— Tab leaves");
        });
        if let Some(def) = self.state.enclosing() {
            let list = |ports: &[tyndall_engine::graph::GroupPort], arrow: &str| {
                ports
                    .iter()
                    .map(|p| {
                        let ends: Vec<String> =
                            p.targets.iter().map(|(n, q)| format!("{n}.{q}")).collect();
                        format!("{} {arrow} {}", p.name, ends.join(", "))
                    })
                    .collect::<Vec<_>>()
                    .join("; ")
            };
            ui.weak(format!(
                "inputs: {}   outputs: {}",
                list(&def.inputs, "→"),
                list(&def.outputs, "←")
            ));
            if let Some(l) = &def.library {
                ui.weak(format!(
                    "library group {}: an edit here makes an embedded copy (it stops following {})",
                    l.name,
                    l.path.display()
                ));
            }
        }
        if let Some(depth) = go {
            self.state.leave_to(depth);
            self.selected = None;
            self.frame_all = true;
        }
    }
}
