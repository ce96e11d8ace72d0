//! Groups as text: the `groups` table entries and library files (their serde shapes), a
//! definition from its entry and back, and the table and library file writers.

use std::collections::BTreeMap;
use std::sync::Arc;

use ron::value::Value;
use serde::{Deserialize, Serialize};

use crate::graph::document::{split_endpoint, Graph};
use crate::graph::error::GraphError;
use crate::graph::format::{
    build, file_graph, pairs, param_to_value, pretty, ser_inner, value_to_param, FileGraph,
    FileNode, Locator, FORMAT_VERSION,
};
use crate::graph::group::{GroupDef, GroupPort, Knob, LibraryRef};
use crate::graph::schema::Catalog;
use crate::graph::types::Interp;

type FileTrack = Vec<(f64, f64, Interp)>;

/// An input port as written: the inner ports it feeds.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(in crate::graph) struct FileInput {
    pub(in crate::graph) to: Vec<String>,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub(in crate::graph) doc: String,
}

/// An output port as written: the inner port it gives.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(in crate::graph) struct FileOutput {
    pub(in crate::graph) from: String,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub(in crate::graph) doc: String,
}

/// A knob as written.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(in crate::graph) struct FileKnob {
    pub(in crate::graph) to: Vec<String>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    pub(in crate::graph) default: Option<Value>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    pub(in crate::graph) min: Option<f64>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    pub(in crate::graph) max: Option<f64>,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub(in crate::graph) doc: String,
}

/// One entry of a `groups` table (or a library file's `group`): a library reference
/// (`library` set, nothing else but `version`) or an embedded definition.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(in crate::graph) struct FileGroup {
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    pub(in crate::graph) name: Option<String>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    pub(in crate::graph) library: Option<String>,
    pub(in crate::graph) version: u32,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub(in crate::graph) doc: String,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    pub(in crate::graph) inputs: Vec<(String, FileInput)>,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    pub(in crate::graph) outputs: Vec<(String, FileOutput)>,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    pub(in crate::graph) knobs: Vec<(String, FileKnob)>,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    pub(in crate::graph) nodes: Vec<(String, FileNode)>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub(in crate::graph) edges: Vec<(String, String)>,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    pub(in crate::graph) keys: Vec<(String, FileTrack)>,
    /// A library file's own table of the groups its definition uses.
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    pub(in crate::graph) groups: Vec<(String, FileGroup)>,
}

/// A library group file.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(in crate::graph) struct FileLibrary {
    pub(in crate::graph) version: u32,
    pub(in crate::graph) group: FileGroup,
}

pub(super) fn endpoints(
    group: &str,
    what: &str,
    list: &[String],
) -> Result<Vec<(String, String)>, GraphError> {
    list.iter()
        .map(|t| {
            split_endpoint(t)
                .map(|(n, p)| (n.to_string(), p.to_string()))
                .map_err(|_| GraphError::Group {
                    group: group.to_string(),
                    message: format!("{what}: '{t}' is not of the form node.port"),
                })
        })
        .collect()
}

/// A definition from its file entry, its inner graph built with `deps` available.
pub(super) fn definition(
    name: &str,
    fg: &FileGroup,
    catalog: &Catalog,
    deps: &BTreeMap<String, Arc<GroupDef>>,
    library: Option<LibraryRef>,
) -> Result<GroupDef, GraphError> {
    let inner = FileGraph {
        colour: None,
        version: FORMAT_VERSION,
        nodes: fg.nodes.clone(),
        edges: fg.edges.clone(),
        keys: fg.keys.clone(),
        groups: Vec::new(),
    };
    let loc = Locator { text: "" };
    let graph = build(inner, &loc, catalog, deps, true).map_err(|(_, e)| GraphError::Group {
        group: name.to_string(),
        message: e.to_string(),
    })?;
    let mut inputs = Vec::new();
    for (n, p) in &fg.inputs {
        inputs.push(GroupPort {
            name: n.clone(),
            doc: p.doc.clone(),
            targets: endpoints(name, &format!("input '{n}'"), &p.to)?,
        });
    }
    let mut outputs = Vec::new();
    for (n, p) in &fg.outputs {
        outputs.push(GroupPort {
            name: n.clone(),
            doc: p.doc.clone(),
            targets: endpoints(
                name,
                &format!("output '{n}'"),
                std::slice::from_ref(&p.from),
            )?,
        });
    }
    let mut knobs = Vec::new();
    for (n, k) in &fg.knobs {
        let default = match &k.default {
            Some(v) => Some(value_to_param(v).map_err(|found| GraphError::Group {
                group: name.to_string(),
                message: format!("knob '{n}': default is {found}"),
            })?),
            None => None,
        };
        knobs.push(Knob {
            name: n.clone(),
            doc: k.doc.clone(),
            targets: endpoints(name, &format!("knob '{n}'"), &k.to)?,
            default,
            min: k.min,
            max: k.max,
        });
    }
    GroupDef::new(
        catalog, name, fg.version, &fg.doc, inputs, outputs, knobs, graph, library,
    )
}

/// A definition as its file entry (embedded: the whole definition; `reference`: only the
/// library reference).
pub(super) fn file_group(def: &GroupDef, reference: bool) -> FileGroup {
    if let (true, Some(lib)) = (reference, &def.library) {
        return FileGroup {
            library: Some(lib.name.clone()),
            version: def.version,
            ..Default::default()
        };
    }
    let inner = file_graph(&def.graph);
    FileGroup {
        name: None,
        library: None,
        version: def.version,
        doc: def.doc.clone(),
        inputs: def
            .inputs
            .iter()
            .map(|p| {
                (
                    p.name.clone(),
                    FileInput {
                        to: p.targets.iter().map(|(n, q)| format!("{n}.{q}")).collect(),
                        doc: p.doc.clone(),
                    },
                )
            })
            .collect(),
        outputs: def
            .outputs
            .iter()
            .map(|p| {
                (
                    p.name.clone(),
                    FileOutput {
                        from: p
                            .targets
                            .first()
                            .map(|(n, q)| format!("{n}.{q}"))
                            .unwrap_or_default(),
                        doc: p.doc.clone(),
                    },
                )
            })
            .collect(),
        knobs: def
            .knobs
            .iter()
            .map(|k| {
                (
                    k.name.clone(),
                    FileKnob {
                        to: k.targets.iter().map(|(n, q)| format!("{n}.{q}")).collect(),
                        default: k.default.as_ref().map(param_to_value),
                        min: k.min,
                        max: k.max,
                        doc: k.doc.clone(),
                    },
                )
            })
            .collect(),
        nodes: inner.nodes,
        edges: inner.edges,
        keys: inner.keys,
        groups: Vec::new(),
    }
}

/// Every definition `g` uses, directly or through the embedded definitions it uses (a library
/// group brings its own), by name.
pub(super) fn used_groups(g: &Graph, out: &mut BTreeMap<String, Arc<GroupDef>>) {
    for (name, def) in g.groups() {
        if out.insert(name.clone(), def.clone()).is_none() && def.library.is_none() {
            used_groups(&def.graph, out);
        }
    }
}

/// Indent every line after the first by `n` spaces.
pub(super) fn indent(text: &str, n: usize) -> String {
    let pad = " ".repeat(n);
    text.lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 0 || l.is_empty() {
                l.to_string()
            } else {
                format!("{pad}{l}")
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The `groups` table of a graph file: `    groups: {\n        "Name": (…),\n    },\n`, each
/// embedded definition laid out as a graph file is; empty when the graph uses no group.
pub(in crate::graph) fn groups_text(g: &Graph) -> String {
    let mut all = BTreeMap::new();
    used_groups(g, &mut all);
    if all.is_empty() {
        return String::new();
    }
    let mut s = String::from("    groups: {\n");
    for (name, def) in &all {
        let text = match reference_entry(def) {
            Some(r) => r,
            None => {
                let entry = file_group(def, false);
                indent(
                    &ron::ser::to_string_pretty(&entry, pretty(2)).unwrap_or_default(),
                    8,
                )
            }
        };
        s.push_str(&format!("        {}: {text},\n", quote(name)));
    }
    s.push_str("    },\n");
    s
}

pub(super) fn quote(s: &str) -> String {
    ron::ser::to_string(s).unwrap_or_else(|_| format!("\"{s}\""))
}

/// A library file for `def`: `(version: 3, group: (name: …, version: …, …))`, with the
/// library groups it uses referenced and embedded ones copied in its own `groups` table.
pub fn library_text(def: &GroupDef) -> String {
    let mut group = file_group(def, false);
    group.name = Some(def.name.clone());
    let mut used = BTreeMap::new();
    used_groups(&def.graph, &mut used);
    group.groups = used
        .values()
        .map(|d| (d.name.clone(), file_group(d, true)))
        .collect();
    let file = FileLibrary {
        version: FORMAT_VERSION,
        group,
    };
    let mut s = ron::ser::to_string_pretty(&file, pretty(3)).unwrap_or_default();
    s.push('\n');
    s
}

/// A graph's group table entry referencing library group `def` (for a graph about to use it).
pub fn reference_entry(def: &GroupDef) -> Option<String> {
    def.library
        .as_ref()
        .map(|l| format!("(library: {}, version: {})", quote(&l.name), def.version))
}
