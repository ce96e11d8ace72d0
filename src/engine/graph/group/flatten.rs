//! Flattening: a group instance becomes its inner nodes (`instance/inner`), knob values written
//! into the parameters they drive and edges rewired to inner ports — what evaluation sees.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::GroupDef;
use crate::graph::document::{Graph, Node};
use crate::graph::error::GraphError;
use crate::graph::schema::Catalog;

/// Where the inner endpoints of one flattened group instance are: its inputs' and outputs'
/// flattened `node.port`s.
#[derive(Default)]
struct PortMap {
    inputs: BTreeMap<(String, String), Vec<(String, String)>>,
    outputs: BTreeMap<(String, String), (String, String)>,
}

impl Graph {
    /// The group definitions this document uses, by name.
    pub fn groups(&self) -> &BTreeMap<String, Arc<GroupDef>> {
        &self.groups
    }

    /// Add (or replace) a group definition, so nodes may instantiate it.
    pub fn add_group(&mut self, def: Arc<GroupDef>) {
        self.groups.insert(def.name.clone(), def);
    }

    /// Replace the library group `name` by an embedded copy of it (Nuke's "copy to group"):
    /// the graph no longer follows the library file; saving writes the whole definition.
    pub fn embed_group(&mut self, name: &str) -> Result<(), GraphError> {
        let mut copy = (*self.used_group(name)?).clone();
        copy.library = None;
        self.groups.insert(name.to_string(), Arc::new(copy));
        Ok(())
    }

    /// Whether any node instantiates a group.
    pub fn has_group_nodes(&self) -> bool {
        self.nodes().any(|n| self.groups.contains_key(&n.kind))
    }

    /// The graph with every group instance replaced by its inner nodes (`instance/inner`, nested
    /// groups `a/b/inner`), knob values and key-frames written into the inner parameters they
    /// drive and edges rewired to inner ports. A graph without groups comes back as it is.
    pub fn flatten(&self, catalog: &Catalog) -> Result<Graph, GraphError> {
        self.flatten_ports(catalog).map(|(g, _)| g)
    }

    /// [`Graph::flatten`], and where each output port of every group instance went, nested
    /// ones included: (`instance` as a flattened path, `a` or `a/b`, `port`) → (flattened node,
    /// port).
    #[allow(clippy::type_complexity)]
    pub fn flatten_ports(
        &self,
        catalog: &Catalog,
    ) -> Result<(Graph, BTreeMap<(String, String), (String, String)>), GraphError> {
        if !self.has_group_nodes() {
            let mut g = self.clone();
            g.groups.clear();
            return Ok((g, BTreeMap::new()));
        }
        let mut out = Graph::new();
        out.working_space = self.working_space.clone();
        let mut all = BTreeMap::new();
        expand(self, catalog, "", &mut out, &mut all)?;
        Ok((out, all))
    }
}

/// Add `graph`'s nodes under `prefix` to `out`, expanding group instances; the port map of
/// `graph`'s own group instances (by local id). `all` gathers every instance's output ports by
/// flattened path.
fn expand(
    graph: &Graph,
    catalog: &Catalog,
    prefix: &str,
    out: &mut Graph,
    all: &mut BTreeMap<(String, String), (String, String)>,
) -> Result<PortMap, GraphError> {
    let mut map = PortMap::default();
    for node in graph.nodes() {
        let id = format!("{prefix}{}", node.id);
        let Some(def) = graph.groups.get(&node.kind) else {
            let mut n = node.clone();
            n.id = id;
            out.insert_node(catalog, n)?;
            continue;
        };
        let inner = with_knobs(def, node, catalog)?;
        let sub_prefix = format!("{id}/");
        let sub = expand(&inner, catalog, &sub_prefix, out, all)?;
        let resolve_in = |n: &str, p: &str| -> Vec<(String, String)> {
            sub.inputs
                .get(&(n.to_string(), p.to_string()))
                .cloned()
                .unwrap_or_else(|| vec![(format!("{sub_prefix}{n}"), p.to_string())])
        };
        for port in &def.inputs {
            let ends = port
                .targets
                .iter()
                .flat_map(|(n, p)| resolve_in(n, p))
                .collect();
            map.inputs
                .insert((node.id.clone(), port.name.clone()), ends);
        }
        for port in &def.outputs {
            if let Some((n, p)) = port.targets.first() {
                let end = sub
                    .outputs
                    .get(&(n.clone(), p.clone()))
                    .cloned()
                    .unwrap_or_else(|| (format!("{sub_prefix}{n}"), p.clone()));
                all.insert((id.clone(), port.name.clone()), end.clone());
                map.outputs
                    .insert((node.id.clone(), port.name.clone()), end);
            }
        }
    }
    for e in graph.edges() {
        let from = map
            .outputs
            .get(&(e.from_node.clone(), e.from_port.clone()))
            .cloned()
            .unwrap_or_else(|| (format!("{prefix}{}", e.from_node), e.from_port.clone()));
        let to = map
            .inputs
            .get(&(e.to_node.clone(), e.to_port.clone()))
            .cloned()
            .unwrap_or_else(|| vec![(format!("{prefix}{}", e.to_node), e.to_port.clone())]);
        for (tn, tp) in to {
            out.connect_deferred(
                catalog,
                &format!("{}.{}", from.0, from.1),
                &format!("{tn}.{tp}"),
            )?;
        }
    }
    Ok(map)
}

/// The inner graph of `def` with instance `node`'s knob values (explicit or default) and
/// key-frames written into the parameters they drive.
pub(super) fn with_knobs(
    def: &GroupDef,
    node: &Node,
    catalog: &Catalog,
) -> Result<Graph, GraphError> {
    let mut inner = def.graph.clone();
    for (knob, spec) in def.knobs.iter().zip(def.schema().params) {
        let value = node
            .params
            .get(&knob.name)
            .cloned()
            .unwrap_or_else(|| spec.default.value());
        let keys = node.keys.get(&knob.name);
        for (n, p) in &knob.targets {
            inner.set_param(catalog, n, p, value.clone())?;
            if let Some(keys) = keys {
                inner.set_keys(catalog, n, p, keys.clone())?;
            }
        }
    }
    Ok(inner)
}
