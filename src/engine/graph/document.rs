//! The graph document: nodes with stable ids, typed edges, parameters and key-frames, held in a
//! petgraph `StableDiGraph`.

use std::collections::{BTreeMap, BTreeSet};

use petgraph::stable_graph::{NodeIndex, StableDiGraph};
use petgraph::visit::{EdgeRef, IntoEdgeReferences};
use petgraph::Direction as PgDir;

use super::error::GraphError;
use super::schema::{Catalog, NodeSchema};
use super::types::{sample_keys, Key, ParamProblem, ParamSpec, ParamValue};

/// One node of the document.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    /// Stable id, unique in the document and never reused by [`Graph::add_node`].
    pub id: String,
    /// Node kind (a catalog name).
    pub kind: String,
    /// Parameters set explicitly; the others take the schema's default.
    pub params: BTreeMap<String, ParamValue>,
    /// Key-frame tracks by parameter name (numeric parameters only, sorted by time).
    pub keys: BTreeMap<String, Vec<Key>>,
    /// Position on the editor canvas.
    pub pos: Option<[f32; 2]>,
    /// Free-form per-node data block (TF layers, strokes, splats), kept verbatim.
    pub data: Option<super::NodeData>,
}

/// An edge payload: which output port feeds which input port.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Wire {
    /// Output port on the source node.
    pub from_port: String,
    /// Input port on the destination node.
    pub to_port: String,
}

/// An edge as endpoints, for listing.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct EdgeRefs {
    /// Source node id.
    pub from_node: String,
    /// Source output port.
    pub from_port: String,
    /// Destination node id.
    pub to_node: String,
    /// Destination input port.
    pub to_port: String,
}

/// Split `node.port` at its last dot.
pub fn split_endpoint(text: &str) -> Result<(&str, &str), GraphError> {
    match text.rsplit_once('.') {
        Some((n, p)) if !n.is_empty() && !p.is_empty() => Ok((n, p)),
        _ => Err(GraphError::BadEndpoint {
            text: text.to_string(),
        }),
    }
}

/// The node-graph document.
#[derive(Debug, Clone, Default)]
pub struct Graph {
    pub(super) g: StableDiGraph<Node, Wire>,
    pub(super) index: BTreeMap<String, NodeIndex>,
    pub(super) retired: BTreeSet<String>,
    /// Group definitions nodes may instantiate (their kind is the group's name).
    pub(super) groups: BTreeMap<String, std::sync::Arc<super::group::GroupDef>>,
    /// The working space its colours are in (`colour: (working_space: …)`); empty: the
    /// default, [`crate::colour::WORKING_SPACE`].
    pub(super) working_space: String,
}

impl PartialEq for Graph {
    fn eq(&self, other: &Self) -> bool {
        self.index.len() == other.index.len()
            && self.nodes().zip(other.nodes()).all(|(a, b)| a == b)
            && self.edges() == other.edges()
            && self.groups == other.groups
            && self.working_space == other.working_space
    }
}

fn param_error(node: &str, spec: &ParamSpec, value: &ParamValue, p: ParamProblem) -> GraphError {
    match p {
        ParamProblem::WrongType | ParamProblem::UnknownEnum(_) => GraphError::WrongParamType {
            node: node.to_string(),
            param: spec.name.to_string(),
            expected: spec.expected(),
            found: match value {
                ParamValue::Enum(s) | ParamValue::Text(s) => format!("\"{s}\""),
                v => format!("{} {v}", v.kind_name()),
            },
        },
        ParamProblem::OutOfRange(v) => GraphError::OutOfRange {
            node: node.to_string(),
            param: spec.name.to_string(),
            value: v,
            expected: spec.expected(),
        },
    }
}

impl Graph {
    /// An empty document.
    pub fn new() -> Self {
        Self::default()
    }

    /// The colour space its colours (sun, lights, constants, transfer functions) are in: the
    /// file's `colour: (working_space: …)`, else [`crate::colour::WORKING_SPACE`]
    /// (`Linear Rec.709 (sRGB)`).
    pub fn working_space(&self) -> &str {
        if self.working_space.is_empty() {
            crate::colour::WORKING_SPACE
        } else {
            &self.working_space
        }
    }

    /// Whether the graph names a working space of its own.
    pub fn has_working_space(&self) -> bool {
        !self.working_space.is_empty()
    }

    /// Set the working space (a colour space of the config; empty or the default's name: the
    /// default). The name is checked when the graph is evaluated, against its config.
    pub fn set_working_space(&mut self, name: &str) {
        self.working_space = if name == crate::colour::WORKING_SPACE {
            String::new()
        } else {
            name.trim().to_string()
        };
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// Whether the document has no nodes.
    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Nodes ordered by id.
    pub fn nodes(&self) -> impl Iterator<Item = &Node> + '_ {
        self.index.values().map(move |ix| &self.g[*ix])
    }

    /// The node with id `id`.
    pub fn node(&self, id: &str) -> Option<&Node> {
        self.index.get(id).map(|ix| &self.g[*ix])
    }

    pub(super) fn ix(&self, id: &str) -> Result<NodeIndex, GraphError> {
        self.index
            .get(id)
            .copied()
            .ok_or_else(|| GraphError::UnknownNode {
                node: id.to_string(),
            })
    }

    pub(super) fn schema_of(
        &self,
        catalog: &Catalog,
        id: &str,
    ) -> Result<&'static NodeSchema, GraphError> {
        let node = self.node(id).ok_or_else(|| GraphError::UnknownNode {
            node: id.to_string(),
        })?;
        self.kind_schema(catalog, &node.kind)
            .ok_or_else(|| GraphError::UnknownKind {
                node: id.to_string(),
                kind: node.kind.clone(),
                known: self.kind_names(catalog),
            })
    }

    /// The schema of `kind`: one of this document's groups, else the catalog's.
    pub fn kind_schema(&self, catalog: &Catalog, kind: &str) -> Option<&'static NodeSchema> {
        match self.groups.get(kind) {
            Some(def) => Some(def.schema()),
            None => catalog.get(kind),
        }
    }

    /// The catalog's kind names and this document's groups, for messages.
    pub fn kind_names(&self, catalog: &Catalog) -> String {
        if self.groups.is_empty() {
            return catalog.kind_names();
        }
        let groups: Vec<&str> = self.groups.keys().map(String::as_str).collect();
        format!("{}; groups: {}", catalog.kind_names(), groups.join(", "))
    }

    /// Add a node of `kind` with a fresh id derived from the kind (`math1`, `math2`, ...); ids of
    /// removed nodes are never handed out again by this document.
    pub fn add_node(&mut self, catalog: &Catalog, kind: &str) -> Result<String, GraphError> {
        let id = self.fresh_id(kind);
        self.insert_node(
            catalog,
            Node {
                id: id.clone(),
                kind: kind.to_string(),
                params: BTreeMap::new(),
                keys: BTreeMap::new(),
                pos: None,
                data: None,
            },
        )?;
        Ok(id)
    }

    /// The id [`Graph::add_node`] would give the next node of `kind`: the kind in lower case
    /// and the smallest number not used by a present or removed node.
    pub fn fresh_id(&self, kind: &str) -> String {
        let stem: String = kind.to_lowercase();
        let mut n = 1;
        loop {
            let id = format!("{stem}{n}");
            if !self.index.contains_key(&id) && !self.retired.contains(&id) {
                return id;
            }
            n += 1;
        }
    }

    /// Insert a fully described node, checking its kind, parameters and key-frames.
    pub fn insert_node(&mut self, catalog: &Catalog, node: Node) -> Result<(), GraphError> {
        if self.index.contains_key(&node.id) {
            return Err(GraphError::DuplicateNode { node: node.id });
        }
        let schema =
            self.kind_schema(catalog, &node.kind)
                .ok_or_else(|| GraphError::UnknownKind {
                    node: node.id.clone(),
                    kind: node.kind.clone(),
                    known: self.kind_names(catalog),
                })?;
        let mut checked = node.clone();
        checked.params.clear();
        checked.keys.clear();
        for (name, value) in &node.params {
            let v = check_param(schema, &node.id, name, value.clone())?;
            checked.params.insert(name.clone(), v);
        }
        for (name, keys) in &node.keys {
            check_keys(schema, &node.id, name, keys)?;
            checked.keys.insert(name.clone(), keys.clone());
        }
        let ix = self.g.add_node(checked);
        self.index.insert(node.id, ix);
        Ok(())
    }

    /// Remove a node and its edges. Its id is retired.
    pub fn remove_node(&mut self, id: &str) -> Result<Node, GraphError> {
        let ix = self.ix(id)?;
        self.index.remove(id);
        self.retired.insert(id.to_string());
        self.g
            .remove_node(ix)
            .ok_or_else(|| GraphError::UnknownNode {
                node: id.to_string(),
            })
    }

    /// Set a parameter, checking its type and range.
    pub fn set_param(
        &mut self,
        catalog: &Catalog,
        id: &str,
        name: &str,
        value: ParamValue,
    ) -> Result<(), GraphError> {
        let schema = self.schema_of(catalog, id)?;
        let v = check_param(schema, id, name, value)?;
        let ix = self.ix(id)?;
        self.g[ix].params.insert(name.to_string(), v);
        Ok(())
    }

    /// Set a parameter from text as the command line (`--set`), bench suites and
    /// `bench/results.csv` write it (`0.5`, `7`, `true`, an enum name, `r,g,b[,a]`, `x,y,z`: see
    /// [`ParamSpec::parse_str`]), with the errors [`Graph::set_param`] gives.
    pub fn set_param_text(
        &mut self,
        catalog: &Catalog,
        id: &str,
        name: &str,
        text: &str,
    ) -> Result<(), GraphError> {
        let schema = self.schema_of(catalog, id)?;
        let spec = schema
            .param(name)
            .ok_or_else(|| unknown_param(schema, id, name))?;
        let v = spec
            .parse_str(text)
            .map_err(|p| param_error(id, spec, &ParamValue::Text(text.to_string()), p))?;
        self.set_param(catalog, id, name, v)
    }

    /// Set (or with an empty list, clear) a parameter's key-frames.
    pub fn set_keys(
        &mut self,
        catalog: &Catalog,
        id: &str,
        name: &str,
        mut keys: Vec<Key>,
    ) -> Result<(), GraphError> {
        let schema = self.schema_of(catalog, id)?;
        keys.sort_by(|a, b| a.t.total_cmp(&b.t));
        let ix = self.ix(id)?;
        if keys.is_empty() {
            self.g[ix].keys.remove(name);
            return Ok(());
        }
        check_keys(schema, id, name, &keys)?;
        self.g[ix].keys.insert(name.to_string(), keys);
        Ok(())
    }

    /// Set the canvas position of a node.
    pub fn set_pos(&mut self, id: &str, pos: Option<[f32; 2]>) -> Result<(), GraphError> {
        let ix = self.ix(id)?;
        self.g[ix].pos = pos;
        Ok(())
    }

    /// Set (or clear) a node's data block.
    pub fn set_data(&mut self, id: &str, data: Option<super::NodeData>) -> Result<(), GraphError> {
        let ix = self.ix(id)?;
        self.g[ix].data = data;
        Ok(())
    }

    /// Whether parameter `name` of node `id` is in effect at time `t` (see
    /// [`ParamSpec::when`](crate::graph::ParamSpec::when)): `Err` says what would make it count.
    pub fn param_in_effect(
        &self,
        catalog: &Catalog,
        id: &str,
        name: &str,
        t: f64,
    ) -> Result<(), String> {
        let Ok(schema) = self.schema_of(catalog, id) else {
            return Ok(());
        };
        let Some(spec) = schema.param(name) else {
            return Ok(());
        };
        spec.in_effect(|other| {
            self.param_at(catalog, id, other, t)
                .ok()
                .map(|v| v.to_string())
        })
    }

    /// A parameter's value at time `t`: key-frames if any, else the explicit value, else the
    /// default. Int parameters round interpolated values to nearest; results are clamped to the
    /// hard range.
    pub fn param_at(
        &self,
        catalog: &Catalog,
        id: &str,
        name: &str,
        t: f64,
    ) -> Result<ParamValue, GraphError> {
        let schema = self.schema_of(catalog, id)?;
        let node = &self.g[self.ix(id)?];
        let spec = schema.param(name).ok_or_else(|| GraphError::UnknownParam {
            node: id.to_string(),
            kind: node.kind.clone(),
            param: name.to_string(),
            known: schema.param_names(),
        })?;
        if let Some(v) = node.keys.get(name).and_then(|k| sample_keys(k, t)) {
            let v = v.clamp(spec.min, spec.max);
            return Ok(match spec.kind {
                super::types::ParamKind::Int => ParamValue::Int(v.round() as i64),
                _ => ParamValue::Float(v),
            });
        }
        Ok(node
            .params
            .get(name)
            .cloned()
            .unwrap_or_else(|| spec.default.value()))
    }

    /// Edges ordered by destination then source.
    pub fn edges(&self) -> Vec<EdgeRefs> {
        let mut v: Vec<EdgeRefs> = (&self.g)
            .edge_references()
            .map(|e| EdgeRefs {
                from_node: self.g[e.source()].id.clone(),
                from_port: e.weight().from_port.clone(),
                to_node: self.g[e.target()].id.clone(),
                to_port: e.weight().to_port.clone(),
            })
            .collect();
        v.sort();
        v
    }

    /// The `(node, port)` feeding input `port` of node `id`, if connected.
    pub fn source_of(&self, id: &str, port: &str) -> Option<(&str, &str)> {
        let ix = self.index.get(id)?;
        self.g
            .edges_directed(*ix, PgDir::Incoming)
            .find(|e| e.weight().to_port == port)
            .map(|e| {
                (
                    self.g[e.source()].id.as_str(),
                    e.weight().from_port.as_str(),
                )
            })
    }

    /// Ids of the nodes directly downstream of `id`.
    pub fn consumers(&self, id: &str) -> Vec<&str> {
        let Some(ix) = self.index.get(id) else {
            return Vec::new();
        };
        let mut v: Vec<&str> = self
            .g
            .edges_directed(*ix, PgDir::Outgoing)
            .map(|e| self.g[e.target()].id.as_str())
            .collect();
        v.sort();
        v.dedup();
        v
    }

    /// Every node in an order where each follows its sources (the graph is acyclic by
    /// construction; should a cycle be there, document order).
    pub(super) fn source_order(&self) -> Vec<NodeIndex> {
        petgraph::algo::toposort(&self.g, None).unwrap_or_else(|_| self.g.node_indices().collect())
    }

    /// Node ids in a topological order (sources first; ties by id).
    pub fn topo_order(&self) -> Vec<String> {
        let mut indeg: BTreeMap<&str, usize> = BTreeMap::new();
        for n in self.nodes() {
            indeg.insert(&n.id, 0);
        }
        for e in (&self.g).edge_references() {
            *indeg.entry(self.g[e.target()].id.as_str()).or_default() += 1;
        }
        let mut ready: BTreeSet<&str> = indeg
            .iter()
            .filter(|(_, d)| **d == 0)
            .map(|(k, _)| *k)
            .collect();
        let mut out = Vec::new();
        while let Some(id) = ready.pop_first() {
            out.push(id.to_string());
            if let Some(ix) = self.index.get(id) {
                for e in self.g.edges_directed(*ix, PgDir::Outgoing) {
                    let t = self.g[e.target()].id.as_str();
                    if let Some(d) = indeg.get_mut(t) {
                        *d -= 1;
                        if *d == 0 {
                            ready.insert(t);
                        }
                    }
                }
            }
        }
        out
    }
}

fn unknown_param(schema: &NodeSchema, node: &str, name: &str) -> GraphError {
    GraphError::UnknownParam {
        node: node.to_string(),
        kind: schema.kind.to_string(),
        param: name.to_string(),
        known: schema.param_names(),
    }
}

fn check_param(
    schema: &NodeSchema,
    node: &str,
    name: &str,
    value: ParamValue,
) -> Result<ParamValue, GraphError> {
    let spec = schema
        .param(name)
        .ok_or_else(|| unknown_param(schema, node, name))?;
    spec.coerce(value.clone())
        .map_err(|p| param_error(node, spec, &value, p))
}

/// Check a parameter's value with the error the document would give (used by the CLI too).
pub fn check_param_value(
    schema: &NodeSchema,
    node: &str,
    name: &str,
    value: ParamValue,
) -> Result<ParamValue, GraphError> {
    check_param(schema, node, name, value)
}

fn check_keys(schema: &NodeSchema, node: &str, name: &str, keys: &[Key]) -> Result<(), GraphError> {
    let target = format!("{node}.{name}");
    let spec = schema
        .param(name)
        .ok_or_else(|| unknown_param(schema, node, name))?;
    if !spec.kind.is_numeric() {
        return Err(GraphError::BadKeys {
            target,
            reason: format!(
                "parameter is {}, only Float and Int can be key-framed",
                spec.kind.name()
            ),
        });
    }
    if keys.is_empty() {
        return Err(GraphError::BadKeys {
            target,
            reason: "no keys".into(),
        });
    }
    for k in keys {
        if !k.t.is_finite() {
            return Err(GraphError::BadKeys {
                target,
                reason: format!("time {} is not finite", k.t),
            });
        }
        let v = if spec.kind == super::types::ParamKind::Int {
            ParamValue::Int(k.v.round() as i64)
        } else {
            ParamValue::Float(k.v)
        };
        if spec.check(&v).is_err() {
            return Err(GraphError::OutOfRange {
                node: node.to_string(),
                param: name.to_string(),
                value: k.v,
                expected: spec.expected(),
            });
        }
    }
    if keys.windows(2).any(|w| w[0].t >= w[1].t) {
        return Err(GraphError::BadKeys {
            target,
            reason: "key times must be strictly increasing".into(),
        });
    }
    Ok(())
}
