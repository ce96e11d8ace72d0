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

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Mutex, OnceLock};

mod edit;
mod flatten;

use super::document::Graph;
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

pub(super) fn group_err(group: &str, message: impl Into<String>) -> GraphError {
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

    /// This definition under another name (an embedded copy): what a paste makes of a group
    /// whose name the document already uses for a different definition.
    pub fn renamed(&self, catalog: &Catalog, name: &str) -> Result<Self, GraphError> {
        Self::new(
            catalog,
            name,
            self.version,
            &self.doc,
            self.inputs.clone(),
            self.outputs.clone(),
            self.knobs.clone(),
            self.graph.clone(),
            None,
        )
    }

    /// This definition with inner graph `graph` (an edit made inside the group) and knobs
    /// `knobs`, checked again as [`GroupDef::new`] checks; the result is an embedded copy (it
    /// no longer follows a library file).
    pub fn rebuilt(
        &self,
        catalog: &Catalog,
        graph: Graph,
        knobs: Vec<Knob>,
    ) -> Result<Self, GraphError> {
        Self::new(
            catalog,
            &self.name,
            self.version,
            &self.doc,
            self.inputs.clone(),
            self.outputs.clone(),
            knobs,
            graph,
            None,
        )
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

/// Inner port `n.port` (an input, or an output), with an error naming `label` (`input 'x'`)
/// when the node or the port does not exist.
fn inner_port(
    catalog: &Catalog,
    group: &str,
    graph: &Graph,
    label: &str,
    n: &str,
    port: &str,
    input: bool,
) -> Result<&'static PortSpec, GraphError> {
    let schema = graph
        .schema_of(catalog, n)
        .map_err(|_| group_err(group, format!("{label}: no inner node '{n}'")))?;
    let (spec, dir, names) = if input {
        (schema.input(port), "input", schema.input_names())
    } else {
        (schema.output(port), "output", schema.output_names())
    };
    spec.ok_or_else(|| {
        group_err(
            group,
            format!("{label}: inner node '{n}' has no {dir} '{port}' (its {dir}s: {names})"),
        )
    })
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
            let spec = inner_port(
                catalog,
                name,
                graph,
                &format!("input '{}'", p.name),
                n,
                port,
                true,
            )?;
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
        let spec = inner_port(
            catalog,
            name,
            graph,
            &format!("output '{}'", p.name),
            n,
            port,
            false,
        )?;
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
