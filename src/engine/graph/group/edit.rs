//! Editing with groups: collapse nodes into a group (the editor's Group, `tyndall group`),
//! ungroup an instance, expose an inner parameter as a knob, publish a group to a library.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;

use super::flatten::with_knobs;
use super::{GroupDef, GroupPort, Knob, LibraryRef};
use crate::graph::document::{Graph, Node};
use crate::graph::error::GraphError;
use crate::graph::schema::Catalog;

/// The edges cut by grouping `chosen`: inputs (one per outside source, with every inner port it
/// feeds) and outputs (one per inner source that feeds outside), named after the inner port
/// (`node_port` when taken), in edge order; and the outside endpoints of each.
#[allow(clippy::type_complexity)]
fn cut_ports(
    g: &Graph,
    chosen: &std::collections::BTreeSet<String>,
) -> (Vec<GroupPort>, Vec<(String, String)>, Vec<GroupPort>) {
    let mut inputs: Vec<GroupPort> = Vec::new();
    let mut sources: Vec<(String, String)> = Vec::new();
    let mut outputs: Vec<GroupPort> = Vec::new();
    let unique = |wanted: &str, fallback: String, taken: &[GroupPort]| {
        if taken.iter().any(|t| t.name == wanted) {
            fallback
        } else {
            wanted.to_string()
        }
    };
    for e in g.edges() {
        match (chosen.contains(&e.from_node), chosen.contains(&e.to_node)) {
            (false, true) => {
                let src = (e.from_node.clone(), e.from_port.clone());
                let target = (e.to_node.clone(), e.to_port.clone());
                match sources.iter().position(|s| *s == src) {
                    Some(i) => inputs[i].targets.push(target),
                    None => {
                        let name =
                            unique(&e.to_port, format!("{}_{}", e.to_node, e.to_port), &inputs);
                        sources.push(src);
                        inputs.push(GroupPort {
                            name,
                            doc: String::new(),
                            targets: vec![target],
                        });
                    }
                }
            }
            (true, false) => {
                let src = (e.from_node.clone(), e.from_port.clone());
                if !outputs.iter().any(|o| o.targets[0] == src) {
                    let name = unique(
                        &e.from_port,
                        format!("{}_{}", e.from_node, e.from_port),
                        &outputs,
                    );
                    outputs.push(GroupPort {
                        name,
                        doc: String::new(),
                        targets: vec![src],
                    });
                }
            }
            _ => {}
        }
    }
    (inputs, sources, outputs)
}

impl Graph {
    /// The nodes `chosen` and the edges between them (with the groups they use).
    fn subgraph(
        &self,
        catalog: &Catalog,
        chosen: &std::collections::BTreeSet<String>,
    ) -> Result<Graph, GraphError> {
        let mut inner = Graph::new();
        for n in self.nodes().filter(|n| chosen.contains(&n.id)) {
            if let Some(def) = self.groups.get(&n.kind) {
                inner.add_group(def.clone());
            }
            inner.insert_node(catalog, n.clone())?;
        }
        for e in self.edges() {
            if chosen.contains(&e.from_node) && chosen.contains(&e.to_node) {
                inner.connect_deferred(
                    catalog,
                    &format!("{}.{}", e.from_node, e.from_port),
                    &format!("{}.{}", e.to_node, e.to_port),
                )?;
            }
        }
        Ok(inner)
    }

    /// Collapse the nodes `ids` into a group `name` (the editor's Group, `tyndall group`): the
    /// group's inner graph is those nodes and the edges between them, its inputs and outputs
    /// are the cut edges, its knobs `knobs`. Returns the definition and this graph with the
    /// nodes replaced by one instance `instance` of it, wired where they were (its knobs left
    /// at their defaults: the inner values).
    #[allow(clippy::too_many_arguments)]
    pub fn group_nodes(
        &self,
        catalog: &Catalog,
        ids: &[String],
        name: &str,
        version: u32,
        doc: &str,
        knobs: Vec<Knob>,
        instance: &str,
        library: Option<LibraryRef>,
    ) -> Result<(GroupDef, Graph), GraphError> {
        let chosen: std::collections::BTreeSet<String> = ids.iter().cloned().collect();
        for id in &chosen {
            self.ix(id)?;
        }
        let inner = self.subgraph(catalog, &chosen)?;
        let (inputs, sources, outputs) = cut_ports(self, &chosen);
        let def = GroupDef::new(
            catalog,
            name,
            version,
            doc,
            inputs.clone(),
            outputs.clone(),
            knobs,
            inner,
            library,
        )?;
        let mut outer = Graph::new();
        outer.groups = self.groups.clone();
        outer.retired = self.retired.clone();
        outer.working_space = self.working_space.clone();
        let def_arc = Arc::new(def.clone());
        outer.add_group(def_arc);
        for n in self.nodes().filter(|n| !chosen.contains(&n.id)) {
            outer.insert_node(catalog, n.clone())?;
        }
        let pos = self
            .nodes()
            .filter(|n| chosen.contains(&n.id))
            .find_map(|n| n.pos);
        outer.insert_node(
            catalog,
            Node {
                id: instance.to_string(),
                kind: name.to_string(),
                params: BTreeMap::new(),
                keys: BTreeMap::new(),
                pos,
                data: None,
            },
        )?;
        for e in self.edges() {
            let (fi, ti) = (chosen.contains(&e.from_node), chosen.contains(&e.to_node));
            let from = if fi {
                match outputs
                    .iter()
                    .find(|o| o.targets[0] == (e.from_node.clone(), e.from_port.clone()))
                {
                    Some(o) => format!("{instance}.{}", o.name),
                    None => continue,
                }
            } else {
                format!("{}.{}", e.from_node, e.from_port)
            };
            let to = if ti {
                if fi {
                    continue; // inside the group
                }
                let src = (e.from_node.clone(), e.from_port.clone());
                let Some(i) = sources.iter().position(|s| *s == src) else {
                    continue;
                };
                if outer
                    .edges()
                    .iter()
                    .any(|x| x.to_node == instance && x.to_port == inputs[i].name)
                {
                    continue; // one edge per group input
                }
                format!("{instance}.{}", inputs[i].name)
            } else {
                format!("{}.{}", e.to_node, e.to_port)
            };
            outer.connect_deferred(catalog, &from, &to)?;
        }
        let used: std::collections::BTreeSet<String> =
            outer.nodes().map(|n| n.kind.clone()).collect();
        outer.groups.retain(|k, _| used.contains(k));
        Ok((def, outer))
    }
}

impl Graph {
    /// Replace group instance `id` by its inner nodes (the editor's Ungroup): knob values and
    /// key-frames written into the parameters they drive, edges rewired to the inner ports. An
    /// inner node keeps its id when this graph has no node (present or removed) of that id, else
    /// gets `{id}_{inner}`. Returns the new ids, inner id → id here.
    pub fn ungroup(
        &mut self,
        catalog: &Catalog,
        id: &str,
    ) -> Result<BTreeMap<String, String>, GraphError> {
        let node = self
            .node(id)
            .cloned()
            .ok_or_else(|| GraphError::UnknownNode {
                node: id.to_string(),
            })?;
        let def = self
            .groups
            .get(&node.kind)
            .cloned()
            .ok_or_else(|| GraphError::Group {
                group: node.kind.clone(),
                message: format!("node '{id}' is not a group instance"),
            })?;
        let inner = with_knobs(&def, &node, catalog)?;
        let before = self.edges();
        let mut out = self.clone();
        out.remove_node(id)?;
        for (name, d) in inner.groups() {
            out.groups.insert(name.clone(), d.clone());
        }
        let mut ids = BTreeMap::new();
        for n in inner.nodes() {
            let mut new_id = n.id.clone();
            if out.index.contains_key(&new_id) || out.retired.contains(&new_id) {
                new_id = format!("{id}_{}", n.id);
                let mut k = 2;
                while out.index.contains_key(&new_id) || out.retired.contains(&new_id) {
                    new_id = format!("{id}_{}{k}", n.id);
                    k += 1;
                }
            }
            let mut copy = n.clone();
            copy.id = new_id.clone();
            if let (Some([x, y]), Some([ox, oy])) = (copy.pos, node.pos) {
                copy.pos = Some([x + ox, y + oy]);
            }
            out.insert_node(catalog, copy)?;
            ids.insert(n.id.clone(), new_id);
        }
        let map = |n: &str| ids.get(n).cloned().unwrap_or_else(|| n.to_string());
        for e in inner.edges() {
            out.connect_deferred(
                catalog,
                &format!("{}.{}", map(&e.from_node), e.from_port),
                &format!("{}.{}", map(&e.to_node), e.to_port),
            )?;
        }
        for e in before {
            if e.to_node == id {
                if let Some(port) = def.inputs.iter().find(|p| p.name == e.to_port) {
                    for (n, p) in &port.targets {
                        out.connect_deferred(
                            catalog,
                            &format!("{}.{}", e.from_node, e.from_port),
                            &format!("{}.{p}", map(n)),
                        )?;
                    }
                }
            } else if e.from_node == id {
                if let Some((n, p)) = def
                    .outputs
                    .iter()
                    .find(|o| o.name == e.from_port)
                    .and_then(|o| o.targets.first())
                {
                    out.connect_deferred(
                        catalog,
                        &format!("{}.{p}", map(n)),
                        &format!("{}.{}", e.to_node, e.to_port),
                    )?;
                }
            }
        }
        let used: std::collections::BTreeSet<String> =
            out.nodes().map(|n| n.kind.clone()).collect();
        out.groups.retain(|k, _| used.contains(k));
        out.check_known_types(catalog)?;
        *self = out;
        Ok(ids)
    }

    /// The definition of group `group` this graph uses, or an error naming it.
    pub(in crate::graph) fn used_group(&self, group: &str) -> Result<Arc<GroupDef>, GraphError> {
        self.groups
            .get(group)
            .cloned()
            .ok_or_else(|| GraphError::Group {
                group: group.to_string(),
                message: "is not used by this graph".into(),
            })
    }

    /// The graph inside the group instance at `scope` (instance ids from this graph down:
    /// `["look", "fill"]`; empty: this graph); `None` when a step is not a group instance.
    pub fn inside(&self, scope: &[String]) -> Option<&Graph> {
        let mut g = self;
        for id in scope {
            let kind = &g.node(id)?.kind;
            g = &g.groups.get(kind)?.graph;
        }
        Some(g)
    }

    /// Apply `change` to the graph inside the group instance at `scope` (the editor's edits
    /// while inside a group), then check each definition up the path again and write it back:
    /// every instance of that group changes, a library group becomes an embedded copy (as
    /// Expose does), and a change that breaks a port, a knob or an outer edge is refused with
    /// the group named. An empty scope changes this graph itself.
    pub fn edit_inside<T>(
        &mut self,
        catalog: &Catalog,
        scope: &[String],
        change: impl FnOnce(&mut Graph, &Catalog) -> Result<T, GraphError>,
    ) -> Result<T, GraphError> {
        let Some((id, rest)) = scope.split_first() else {
            return change(self, catalog);
        };
        let kind = self.g[self.ix(id)?].kind.clone();
        let def = self
            .groups
            .get(&kind)
            .cloned()
            .ok_or_else(|| GraphError::Group {
                group: kind.clone(),
                message: format!("node '{id}' is not a group instance"),
            })?;
        let mut inner = def.graph.clone();
        let value = inner.edit_inside(catalog, rest, change)?;
        if inner != def.graph {
            let new = def.rebuilt(catalog, inner, def.knobs.clone())?;
            self.groups.insert(kind, Arc::new(new));
            self.check_known_types(catalog)?;
        }
        Ok(value)
    }

    /// Add a knob `knob` to group `group` driving inner `node.param` (the editor's Expose), or
    /// add that target to the knob when it exists. The group becomes an embedded copy (a
    /// library group is changed by publishing it again).
    pub fn expose_knob(
        &mut self,
        catalog: &Catalog,
        group: &str,
        node: &str,
        param: &str,
        knob: &str,
    ) -> Result<(), GraphError> {
        let def = self.used_group(group)?;
        let mut knobs = def.knobs.clone();
        let target = (node.to_string(), param.to_string());
        match knobs.iter_mut().find(|k| k.name == knob) {
            Some(k) if k.targets.contains(&target) => return Ok(()),
            Some(k) => k.targets.push(target),
            None => knobs.push(Knob {
                name: knob.to_string(),
                doc: String::new(),
                targets: vec![target],
                default: None,
                min: None,
                max: None,
            }),
        }
        let new = def.rebuilt(catalog, def.graph.clone(), knobs)?;
        self.groups.insert(group.to_string(), Arc::new(new));
        Ok(())
    }

    /// Make group `group` the library group `reference` (its file written by the caller with
    /// [`crate::graph::library_text`]): the graph references it from now on.
    pub fn publish_group(
        &mut self,
        group: &str,
        reference: &str,
        path: PathBuf,
    ) -> Result<Arc<GroupDef>, GraphError> {
        let def = self.used_group(group)?;
        let mut copy = (*def).clone();
        copy.library = Some(LibraryRef {
            name: reference.to_string(),
            path,
        });
        let copy = Arc::new(copy);
        self.groups.insert(group.to_string(), copy.clone());
        Ok(copy)
    }
}
