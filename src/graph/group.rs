//! Node groups: a subgraph with declared input and output ports and exposed parameters
//! ("knobs"), instantiated by a node whose kind is the group's name.
//!
//! A group's input port fans out to one or more inner `node.port`s (its types: those all of
//! them accept), an output port is one inner `node.port`, and a knob drives one or more inner
//! `node.param`s of one kind with its own default (the inner graph's value unless given), range
//! (inside every target's) and doc; knobs are key-frameable like any parameter. Groups nest.
//! A group's schema is built once per definition and kept for the life of the process (it is a
//! catalog entry like a built-in kind's, `&'static`), so reloading an unchanged group costs
//! nothing and a changed one a few hundred bytes.
//!
//! Evaluation sees the **flattened** graph ([`Graph::flatten`]): an instance `look` of a group
//! becomes its inner nodes `look/inner`, with the knob values written into their parameters and
//! the instance's edges rewired to the inner ports. So a group evaluates exactly as its
//! flattened graph does, caching works per inner node (a knob re-runs only what it reaches and
//! what is below), and statistics and `--output` name inner nodes `group/inner`.

use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;
use std::sync::{Arc, Mutex, OnceLock};

use super::document::{Graph, Node};
use super::error::GraphError;
use super::schema::{Catalog, NodeSchema};
use super::types::{DefaultValue, ParamKind, ParamSpec, PortSpec, PortType};
use super::value::ParamValue;

/// A group port: its name, doc (empty: the first inner port's), and the inner endpoints (`node`, `port`) it stands for — every
/// inner input it feeds (inputs), or the one inner output it gives (outputs).
#[derive(Debug, Clone, PartialEq)]
pub struct GroupPort {
    /// Port name on the group node.
    pub name: String,
    /// One-line description.
    pub doc: String,
    /// Inner endpoints.
    pub targets: Vec<(String, String)>,
}

/// An exposed parameter: its name, the inner parameters it drives, its own default and range.
#[derive(Debug, Clone, PartialEq)]
pub struct Knob {
    /// Parameter name on the group node.
    pub name: String,
    /// One-line description.
    pub doc: String,
    /// Inner (`node`, `param`) it sets, all of one kind.
    pub targets: Vec<(String, String)>,
    /// Default; `None`: the first target's value in the inner graph.
    pub default: Option<ParamValue>,
    /// Range; `None`: the first target's (numeric kinds). Must lie inside every target's.
    pub min: Option<f64>,
    /// See `min`.
    pub max: Option<f64>,
}

/// A group definition.
#[derive(Debug, Clone)]
pub struct GroupDef {
    /// The kind name instances use (`HoleFilling`).
    pub name: String,
    /// Version a reference must match.
    pub version: u32,
    /// What the group does.
    pub doc: String,
    /// Input ports.
    pub inputs: Vec<GroupPort>,
    /// Output ports.
    pub outputs: Vec<GroupPort>,
    /// Exposed parameters.
    pub knobs: Vec<Knob>,
    /// The inner graph (it carries the definitions of the groups it uses).
    pub graph: Graph,
    /// Where it came from: a library file (referenced by name), `None` when embedded in the
    /// graph.
    pub library: Option<LibraryRef>,
    schema: &'static NodeSchema,
}

/// A library group's reference: the name graphs use (`stylize/hole_filling`, the file's path
/// under a `lib/` folder without `.ron`) and the file it was read from.
#[derive(Debug, Clone, PartialEq)]
pub struct LibraryRef {
    /// The reference, as written in graphs.
    pub name: String,
    /// The file.
    pub path: PathBuf,
}

impl PartialEq for GroupDef {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.version == other.version
            && self.doc == other.doc
            && self.inputs == other.inputs
            && self.outputs == other.outputs
            && self.knobs == other.knobs
            && self.graph == other.graph
            && self.library == other.library
    }
}

fn group_err(group: &str, message: impl Into<String>) -> GraphError {
    GraphError::Group {
        group: group.to_string(),
        message: message.into(),
    }
}

fn leak(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}

/// Schemas already built, by a fingerprint of everything they hold: an unchanged group reloaded
/// (the editor re-reading its library) reuses its schema instead of leaking a new one.
fn intern(fingerprint: String, make: impl FnOnce() -> NodeSchema) -> &'static NodeSchema {
    static SCHEMAS: OnceLock<Mutex<HashMap<String, &'static NodeSchema>>> = OnceLock::new();
    let map = SCHEMAS.get_or_init(Default::default);
    let mut guard = match map.lock() {
        Ok(g) => g,
        Err(poisoned) => poisoned.into_inner(),
    };
    if let Some(s) = guard.get(&fingerprint) {
        return s;
    }
    let s: &'static NodeSchema = Box::leak(Box::new(make()));
    guard.insert(fingerprint, s);
    s
}

impl GroupDef {
    /// Check a definition against its inner graph and build its schema: every port and knob
    /// names inner endpoints that exist, input targets share a type, knob targets share a
    /// kind, a knob's default and range fit every target.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        catalog: &Catalog,
        name: &str,
        version: u32,
        doc: &str,
        inputs: Vec<GroupPort>,
        outputs: Vec<GroupPort>,
        knobs: Vec<Knob>,
        graph: Graph,
        library: Option<LibraryRef>,
    ) -> Result<Self, GraphError> {
        if catalog.get(name).is_some() {
            return Err(group_err(
                name,
                "has the name of a built-in node kind: choose another",
            ));
        }
        let ins = input_descs(catalog, name, &graph, &inputs)?;
        let outs = output_descs(catalog, name, &graph, &outputs)?;
        let mut params = Vec::new();
        for k in &knobs {
            params.push(knob_spec(catalog, name, &graph, k)?);
        }
        unique(name, "inputs", ins.iter().map(|d| d.name.as_str()))?;
        unique(name, "outputs", outs.iter().map(|d| d.name.as_str()))?;
        unique(name, "knobs", params.iter().map(|d| d.1.as_str()))?;
        let fingerprint = format!("{name}@{version}\n{doc}\n{ins:?}\n{outs:?}\n{params:?}");
        let (doc_s, name_s) = (doc.to_string(), name.to_string());
        // Strings are leaked only when the schema is new (an unchanged group reloaded reuses it).
        let schema = intern(fingerprint, move || {
            let ports = |ds: Vec<PortDesc>| -> &'static [PortSpec] {
                Vec::leak(ds.into_iter().map(PortDesc::leak).collect())
            };
            NodeSchema {
                kind: leak(&name_s),
                category: "Groups",
                doc: leak(&doc_s),
                inputs: ports(ins),
                outputs: ports(outs),
                params: Vec::leak(
                    params
                        .into_iter()
                        .map(|(spec, name, doc)| ParamSpec {
                            name: leak(&name),
                            doc: doc.as_deref().map_or(spec.doc, leak),
                            ..spec
                        })
                        .collect(),
                ),
            }
        });
        Ok(Self {
            name: name.to_string(),
            version,
            doc: doc.to_string(),
            inputs,
            outputs,
            knobs,
            graph,
            library,
            schema,
        })
    }

    /// The group's schema (ports typed as the inner ports, knobs as parameters).
    pub fn schema(&self) -> &'static NodeSchema {
        self.schema
    }
}

/// A knob's range `[min, max]` lies inside every target's.
fn check_range(
    catalog: &Catalog,
    group: &str,
    graph: &Graph,
    k: &Knob,
    min: f64,
    max: f64,
) -> Result<(), GraphError> {
    for (n, p) in &k.targets {
        if let Ok(schema) = graph.schema_of(catalog, n) {
            if let Some(spec) = schema.param(p) {
                if spec.kind.is_numeric() && (min < spec.min || max > spec.max) {
                    return Err(group_err(
                        group,
                        format!(
                            "knob '{}': range [{min}, {max}] is wider than {n}.{p}'s [{}, {}]",
                            k.name, spec.min, spec.max
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// A group port before its schema is built (owned strings; leaked once, by [`intern`]).
#[derive(Debug)]
struct PortDesc {
    name: String,
    types: Vec<PortType>,
    required: bool,
    /// The port's own doc, else the inner port's.
    doc: Result<String, &'static str>,
}

impl PortDesc {
    fn leak(self) -> PortSpec {
        PortSpec {
            name: leak(&self.name),
            types: Vec::leak(self.types),
            required: self.required,
            doc: match self.doc {
                Ok(d) => leak(&d),
                Err(inner) => inner,
            },
        }
    }
}

fn unique<'a>(
    group: &str,
    what: &str,
    names: impl Iterator<Item = &'a str>,
) -> Result<(), GraphError> {
    let mut seen = std::collections::BTreeSet::new();
    for n in names {
        if !seen.insert(n) {
            return Err(group_err(group, format!("two {what} are named '{n}'")));
        }
    }
    Ok(())
}

/// The group's input ports: each feeds inner inputs that exist and are not wired inside; its
/// types are those all of them accept, required when one of them is.
fn input_descs(
    catalog: &Catalog,
    name: &str,
    graph: &Graph,
    inputs: &[GroupPort],
) -> Result<Vec<PortDesc>, GraphError> {
    let mut out = Vec::new();
    for p in inputs {
        if p.targets.is_empty() {
            return Err(group_err(
                name,
                format!("input '{}' feeds no inner port", p.name),
            ));
        }
        let mut types: Option<Vec<PortType>> = None;
        let (mut required, mut first_doc) = (false, "");
        for (n, port) in &p.targets {
            let schema = graph
                .schema_of(catalog, n)
                .map_err(|_| group_err(name, format!("input '{}': no inner node '{n}'", p.name)))?;
            let spec = schema.input(port).ok_or_else(|| {
                group_err(
                    name,
                    format!(
                        "input '{}': inner node '{n}' has no input '{port}' (its inputs: {})",
                        p.name,
                        schema.input_names()
                    ),
                )
            })?;
            if graph
                .edges()
                .iter()
                .any(|e| e.to_node == *n && e.to_port == *port)
            {
                return Err(group_err(
                    name,
                    format!(
                        "input '{}': inner {n}.{port} is already connected inside",
                        p.name
                    ),
                ));
            }
            required |= spec.required;
            if first_doc.is_empty() {
                first_doc = spec.doc;
            }
            types = Some(match types {
                None => spec.types.to_vec(),
                Some(t) => t.into_iter().filter(|x| spec.types.contains(x)).collect(),
            });
        }
        let types = types.unwrap_or_default();
        if types.is_empty() {
            return Err(group_err(
                name,
                format!("input '{}': its inner ports accept no common type", p.name),
            ));
        }
        out.push(PortDesc {
            name: p.name.clone(),
            types,
            required,
            doc: if p.doc.is_empty() {
                Err(first_doc)
            } else {
                Ok(p.doc.clone())
            },
        });
    }
    Ok(out)
}

/// The group's output ports: each one inner output that exists. A polymorphic inner output
/// stays polymorphic: its type follows what reaches the group's inputs (the flattened graph's
/// types are checked on load).
fn output_descs(
    catalog: &Catalog,
    name: &str,
    graph: &Graph,
    outputs: &[GroupPort],
) -> Result<Vec<PortDesc>, GraphError> {
    let mut out = Vec::new();
    for p in outputs {
        let [(n, port)] = p.targets.as_slice() else {
            return Err(group_err(
                name,
                format!("output '{}' must come from exactly one inner port", p.name),
            ));
        };
        let schema = graph
            .schema_of(catalog, n)
            .map_err(|_| group_err(name, format!("output '{}': no inner node '{n}'", p.name)))?;
        let spec = schema.output(port).ok_or_else(|| {
            group_err(
                name,
                format!(
                    "output '{}': inner node '{n}' has no output '{port}' (its outputs: {})",
                    p.name,
                    schema.output_names()
                ),
            )
        })?;
        out.push(PortDesc {
            name: p.name.clone(),
            types: spec.types.to_vec(),
            required: false,
            doc: if p.doc.is_empty() {
                Err(spec.doc)
            } else {
                Ok(p.doc.clone())
            },
        });
    }
    Ok(out)
}

/// The parameter spec of knob `k`: the first target's, renamed, with the knob's default, range
/// and doc; every target must be of the same kind and contain the range.
fn knob_spec(
    catalog: &Catalog,
    group: &str,
    graph: &Graph,
    k: &Knob,
) -> Result<(ParamSpec, String, Option<String>), GraphError> {
    let mut first: Option<(ParamSpec, ParamValue)> = None;
    if k.targets.is_empty() {
        return Err(group_err(
            group,
            format!("knob '{}' drives no inner parameter", k.name),
        ));
    }
    for (n, p) in &k.targets {
        let schema = graph
            .schema_of(catalog, n)
            .map_err(|_| group_err(group, format!("knob '{}': no inner node '{n}'", k.name)))?;
        let spec = schema.param(p).ok_or_else(|| {
            group_err(
                group,
                format!(
                    "knob '{}': inner node '{n}' has no parameter '{p}' (its parameters: {})",
                    k.name,
                    schema.param_names()
                ),
            )
        })?;
        let current = graph
            .node(n)
            .and_then(|node| node.params.get(p).cloned())
            .unwrap_or_else(|| spec.default.value());
        match &first {
            None => first = Some((*spec, current)),
            Some((f, _))
                if std::mem::discriminant(&f.kind) != std::mem::discriminant(&spec.kind) =>
            {
                return Err(group_err(
                    group,
                    format!(
                        "knob '{}': {n}.{p} is {}, but the first target is {}",
                        k.name,
                        spec.kind.name(),
                        f.kind.name()
                    ),
                ));
            }
            _ => {}
        }
    }
    let Some((base, current)) = first else {
        return Err(group_err(
            group,
            format!("knob '{}' drives no inner parameter", k.name),
        ));
    };
    let min = k.min.unwrap_or(base.min);
    let max = k.max.unwrap_or(base.max);
    check_range(catalog, group, graph, k, min, max)?;
    let default_value = k.default.clone().unwrap_or(current);
    let mut spec = ParamSpec {
        name: "",
        min,
        max,
        when: None,
        ..base
    };
    spec.default = to_default(&spec.kind, &default_value).ok_or_else(|| {
        group_err(
            group,
            format!(
                "knob '{}': default {default_value} is not a {}",
                k.name,
                base.kind.name()
            ),
        )
    })?;
    spec.coerce(default_value.clone()).map_err(|e| {
        group_err(
            group,
            format!(
                "knob '{}': default {default_value} does not fit: {e:?}",
                k.name
            ),
        )
    })?;
    let doc = (!k.doc.is_empty()).then(|| k.doc.clone());
    Ok((spec, k.name.clone(), doc))
}

fn to_default(kind: &ParamKind, v: &ParamValue) -> Option<DefaultValue> {
    Some(match (kind, v) {
        (ParamKind::Float, ParamValue::Float(x)) => DefaultValue::Float(*x),
        (ParamKind::Float, ParamValue::Int(x)) => DefaultValue::Float(*x as f64),
        (ParamKind::Int, ParamValue::Int(x)) => DefaultValue::Int(*x),
        (ParamKind::Bool, ParamValue::Bool(x)) => DefaultValue::Bool(*x),
        (ParamKind::Enum(names), ParamValue::Enum(s) | ParamValue::Text(s)) => {
            DefaultValue::Enum(names.iter().find(|n| **n == s.as_str())?)
        }
        (ParamKind::Text, ParamValue::Text(s)) => DefaultValue::Text(leak(s)),
        (ParamKind::Colour, ParamValue::Colour(c)) => DefaultValue::Colour(*c),
        (ParamKind::Colour, ParamValue::Vec3(c)) => DefaultValue::Colour([c[0], c[1], c[2], 1.0]),
        (ParamKind::Vec3, ParamValue::Vec3(c)) => DefaultValue::Vec3(*c),
        _ => return None,
    })
}

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
        let def = self
            .groups
            .get(group)
            .cloned()
            .ok_or_else(|| GraphError::Group {
                group: group.to_string(),
                message: "is not used by this graph".into(),
            })?;
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
        let new = GroupDef::new(
            catalog,
            &def.name,
            def.version,
            &def.doc,
            def.inputs.clone(),
            def.outputs.clone(),
            knobs,
            def.graph.clone(),
            None,
        )?;
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
        let def = self
            .groups
            .get(group)
            .cloned()
            .ok_or_else(|| GraphError::Group {
                group: group.to_string(),
                message: "is not used by this graph".into(),
            })?;
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
        let def = self.groups.get(name).ok_or_else(|| GraphError::Group {
            group: name.to_string(),
            message: "is not used by this graph".into(),
        })?;
        let mut copy = (**def).clone();
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

    /// [`Graph::flatten`], and where each output port of a top-level group instance went:
    /// (`instance`, `port`) → (flattened node, port).
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
        let map = expand(self, catalog, "", &mut out)?;
        Ok((out, map.outputs))
    }
}

/// Add `graph`'s nodes under `prefix` to `out`, expanding group instances; the port map of
/// `graph`'s own group instances (by local id).
fn expand(
    graph: &Graph,
    catalog: &Catalog,
    prefix: &str,
    out: &mut Graph,
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
        let sub = expand(&inner, catalog, &sub_prefix, out)?;
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
fn with_knobs(def: &GroupDef, node: &Node, catalog: &Catalog) -> Result<Graph, GraphError> {
    let mut inner = def.graph.clone();
    for (knob, spec) in def.knobs.iter().zip(def.schema.params) {
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
