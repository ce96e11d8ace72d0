//! The editor's groups: entering and leaving them (the scope the canvas shows), and the
//! group edits — Group, Ungroup, Expose, Publish, adding a library group — each one undo step.

use std::path::{Path, PathBuf};

use super::{EditorError, EditorState};
use tyndall_engine::graph::{GraphError, Node};

impl EditorState {
    /// The group instances entered, from the document down (empty: the document itself).
    pub fn scope(&self) -> &[String] {
        &self.scope
    }

    /// The flattened id of node `id` of the graph shown: `look/fill` inside `look` (the id
    /// evaluation, statistics and `--output` use).
    pub fn full_id(&self, id: &str) -> String {
        self.scope
            .iter()
            .map(String::as_str)
            .chain([id])
            .collect::<Vec<_>>()
            .join("/")
    }

    /// The node at flattened path `path` (`look/fill`), looking inside groups.
    pub fn node_at(&self, path: &str) -> Option<&Node> {
        let parts: Vec<String> = path.split('/').map(str::to_string).collect();
        let (last, scope) = parts.split_last()?;
        self.graph.inside(scope)?.node(last)
    }

    /// Enter group instance `id` of the graph shown (Tab): the canvas shows its inside.
    pub fn enter(&mut self, id: &str) -> Result<(), EditorError> {
        let g = self.graph();
        let kind = g
            .node(id)
            .map(|n| n.kind.clone())
            .ok_or_else(|| GraphError::UnknownNode {
                node: id.to_string(),
            })?;
        if !g.groups().contains_key(&kind) {
            return Err(GraphError::Group {
                group: kind,
                message: format!("node '{id}' is a built-in kind, not a group: nothing to enter"),
            }
            .into());
        }
        self.scope.push(id.to_string());
        Ok(())
    }

    /// Leave the group entered last (Tab, or the breadcrumb); returns its instance id.
    pub fn leave(&mut self) -> Option<String> {
        self.scope.pop()
    }

    /// Leave groups until `depth` are entered (the breadcrumb: 0 is the document).
    pub fn leave_to(&mut self, depth: usize) {
        self.scope.truncate(depth);
    }

    /// The definition of the group entered last (`None` at the document).
    pub fn enclosing(&self) -> Option<std::sync::Arc<tyndall_engine::graph::GroupDef>> {
        let (last, outer) = self.scope.split_last()?;
        let g = self.graph.inside(outer)?;
        g.groups().get(&g.node(last)?.kind).cloned()
    }

    /// The knob of the group entered that drives `node.param` of the graph shown, if any.
    pub fn driving_knob(&self, node: &str, param: &str) -> Option<String> {
        let target = (node.to_string(), param.to_string());
        self.enclosing()?
            .knobs
            .iter()
            .find(|k| k.targets.contains(&target))
            .map(|k| k.name.clone())
    }

    /// Expose `node.param` of the graph shown (inside a group) as a knob of the group entered
    /// (named after the parameter, `node_param` when that name is taken); one undo step.
    /// Returns the knob's name.
    pub fn expose_here(&mut self, node: &str, param: &str) -> Result<String, EditorError> {
        let def = self.enclosing().ok_or_else(|| GraphError::Group {
            group: String::new(),
            message: "no group is entered: Expose works on the parameters inside one".into(),
        })?;
        let knob = if def.knobs.iter().any(|k| k.name == param) {
            format!("{node}_{param}")
        } else {
            param.to_string()
        };
        let instance = self.scope.pop().unwrap_or_default();
        let result = self.expose(&instance, node, param, &knob);
        self.scope.push(instance);
        result.map(|()| knob)
    }

    /// Keep the scope on groups that exist (after undo, redo or recovery).
    pub(super) fn fix_scope(&mut self) {
        while self.graph.inside(&self.scope).is_none() {
            self.scope.pop();
        }
    }

    /// Add an instance of group `def` (a library group from the Add-node menu) at a canvas
    /// position; returns its id. Refused when the graph shown already has a different group of
    /// that name (its instances would change).
    pub fn add_group_node(
        &mut self,
        def: std::sync::Arc<tyndall_engine::graph::GroupDef>,
        pos: [f32; 2],
    ) -> Result<String, EditorError> {
        self.apply(|g, c| {
            match g.groups().get(&def.name) {
                Some(have) if **have != *def => {
                    return Err(GraphError::Group {
                        group: def.name.clone(),
                        message: "this graph already has a different group of that name: \
                                  rename or ungroup it first"
                            .into(),
                    })
                }
                Some(_) => {}
                None => g.add_group(def.clone()),
            }
            let id = g.add_node(c, &def.name)?;
            g.set_pos(&id, Some(pos))?;
            Ok(id)
        })
    }

    /// Collapse the nodes `ids` into a new embedded group (Ctrl+G): the cut edges become its
    /// ports; it is named `Group1`, `Group2`, … and its instance `group1`, …; one undo step.
    /// Returns the instance's id.
    pub fn group(&mut self, ids: &[String]) -> Result<String, EditorError> {
        let mut n = 1;
        let name = loop {
            let name = format!("Group{n}");
            if self.catalog.get(&name).is_none() && !self.graph().groups().contains_key(&name) {
                break name;
            }
            n += 1;
        };
        let instance = self.graph().fresh_id("group");
        self.apply(|g, cat| {
            let (_, outer) = g.group_nodes(cat, ids, &name, 1, "", Vec::new(), &instance, None)?;
            *g = outer;
            Ok(())
        })?;
        Ok(instance)
    }

    /// Replace group instance `id` by its nodes (Ungroup); one undo step.
    pub fn ungroup(&mut self, id: &str) -> Result<(), EditorError> {
        self.apply(|g, cat| g.ungroup(cat, id).map(|_| ()))
    }

    /// Expose inner `node.param` of group instance `instance`'s group as knob `knob`; one
    /// undo step.
    pub fn expose(
        &mut self,
        instance: &str,
        node: &str,
        param: &str,
        knob: &str,
    ) -> Result<(), EditorError> {
        let kind = self
            .graph()
            .node(instance)
            .map(|n| n.kind.clone())
            .unwrap_or_default();
        self.apply(|g, cat| g.expose_knob(cat, &kind, node, param, knob))
    }

    /// Publish group instance `instance`'s group to the library folder `lib` (a `lib/` folder:
    /// `graphs/lib`, the user's): writes `lib/<reference>.ron` and makes the graph reference it;
    /// one undo step (the file stays). Returns the file.
    pub fn publish(
        &mut self,
        instance: &str,
        lib: &Path,
        reference: &str,
    ) -> Result<PathBuf, EditorError> {
        let kind = self
            .graph()
            .node(instance)
            .map(|n| n.kind.clone())
            .unwrap_or_default();
        let path = lib.join(format!("{reference}.ron"));
        self.apply(|g, _| {
            let def = g.publish_group(&kind, reference, path.clone())?;
            if let Some(dir) = path.parent() {
                std::fs::create_dir_all(dir)
                    .map_err(|e| GraphError::Io(format!("cannot create {}: {e}", dir.display())))?;
            }
            tyndall_engine::graph::write_atomic(
                &path,
                tyndall_engine::graph::library_text(&def).as_bytes(),
            )
        })?;
        Ok(path)
    }
}
