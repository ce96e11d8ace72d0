//! Output types: the type each output port produces, polymorphic outputs resolved from what
//! reaches their node — for one port (an upstream walk) or for every port at once (one pass in
//! source order). Both are linear in what they visit and use no recursion.

use std::collections::BTreeMap;

use petgraph::stable_graph::NodeIndex;
use petgraph::visit::EdgeRef;
use petgraph::Direction as PgDir;

use super::document::Graph;
use super::schema::Catalog;
use super::types::PortType;

impl Graph {
    /// The type produced by output `port` of node `id`, resolving polymorphic outputs from the
    /// types of the connected inputs (over the nodes upstream of it, without recursion).
    pub fn output_type(&self, catalog: &Catalog, id: &str, port: &str) -> Option<PortType> {
        let start = *self.index.get(id)?;
        // The upstream cone in an order where every node follows its sources: a depth-first
        // post-order over incoming edges, with an explicit stack.
        let mut order = Vec::new();
        let mut seen = std::collections::HashSet::new();
        let mut stack = vec![(start, false)];
        while let Some((ix, expanded)) = stack.pop() {
            if expanded {
                order.push(ix);
                continue;
            }
            if !seen.insert(ix) {
                continue;
            }
            stack.push((ix, true));
            for e in self.g.edges_directed(ix, PgDir::Incoming) {
                if !seen.contains(&e.source()) {
                    stack.push((e.source(), false));
                }
            }
        }
        let types = self.resolve_types(catalog, &order);
        types.get(&(start, port)).copied()
    }

    /// The type of every node's every output (`(node, port)` → type), polymorphic ones resolved
    /// as [`Graph::output_type`] does, in one pass over the whole graph (linear in its size):
    /// for callers that ask for many ports, such as the editor drawing every pin.
    pub fn output_types(&self, catalog: &Catalog) -> BTreeMap<(String, String), PortType> {
        self.resolve_types(catalog, &self.source_order())
            .into_iter()
            .map(|((ix, port), t)| ((self.g[ix].id.clone(), port.to_string()), t))
            .collect()
    }

    /// The type of every output of the nodes `order` (each after its sources), polymorphic
    /// ones resolved from what reaches their node: the widest of the output's types that one
    /// of the input types can feed. Linear in the nodes and edges visited.
    pub(super) fn resolve_types<'a>(
        &'a self,
        catalog: &Catalog,
        order: &[NodeIndex],
    ) -> std::collections::HashMap<(NodeIndex, &'a str), PortType> {
        let mut types = std::collections::HashMap::new();
        for &ix in order {
            let Ok(schema) = self.schema_of(catalog, &self.g[ix].id) else {
                continue;
            };
            let inputs: Vec<PortType> = self
                .g
                .edges_directed(ix, PgDir::Incoming)
                .filter_map(|e| types.get(&(e.source(), e.weight().from_port.as_str())))
                .copied()
                .collect();
            for out in schema.outputs {
                let t = if out.types.len() <= 1 {
                    out.types.first().copied()
                } else {
                    let best = inputs
                        .iter()
                        .filter_map(|t| out.types.iter().rposition(|c| t.can_feed(*c)))
                        .max()
                        .unwrap_or(0);
                    out.types.get(best).copied()
                };
                if let Some(t) = t {
                    types.insert((ix, out.name), t);
                }
            }
        }
        types
    }
}

/// The port type a file with `channels` channels should become on a port accepting `accepts`.
pub fn type_for_file(accepts: &[PortType], channels: u32) -> Option<PortType> {
    if channels == 4 {
        return [PortType::Image, PortType::Lut2D]
            .into_iter()
            .find(|t| accepts.contains(t));
    }
    accepts
        .iter()
        .copied()
        .find(|t| t.is_single_channel())
        .or_else(|| {
            accepts
                .contains(&PortType::Image)
                .then_some(PortType::Image)
        })
}
