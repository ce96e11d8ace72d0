//! Groups in files: the `groups` table of a graph file (format 3) and library group files.
//!
//! ```ron
//! (
//!     version: 3,
//!     nodes: {"look": (kind: "HoleFilling", params: {"radius": 7})},
//!     groups: {
//!         // a library group, by its path under a `lib/` folder and its version:
//!         "HoleFilling": (library: "stylize/hole_filling", version: 1),
//!         // or embedded (a copy):
//!         "Grade": (
//!             version: 1,
//!             doc: "Exposure and tone curve.",
//!             inputs: {"image": (to: ["tonemap.image"])},
//!             outputs: {"out": (from: "tonemap.out")},
//!             knobs: {"exposure": (to: ["tonemap.exposure"], min: -4.0, max: 4.0)},
//!             nodes: {"tonemap": (kind: "Tonemap")},
//!         ),
//!     },
//! )
//! ```
//!
//! A library file is `(version: 3, group: (name: "HoleFilling", version: 1, …))` at
//! `<folder>/lib/<reference>.ron`. Folders searched, in order: `lib/` beside the graph, `lib/`
//! in the folder above (so `graphs/stylize/x.ron` finds `graphs/lib/`), then
//! `$TYNDALL_PRESETS/lib` (else `~/.config/tyndall/presets/lib`). A library file is read at
//! every load of a graph that uses it, so editing it changes every such graph at its next
//! load. The table's key is the kind nodes use and must be the library group's `name`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ron::value::Value;
use serde::{Deserialize, Serialize};

use super::document::{split_endpoint, Graph};
use super::error::GraphError;
use super::format::{
    build, file_graph, pairs, param_to_value, pretty, ron_options, ser_inner, value_to_param,
    FileGraph, FileNode, Locator, FORMAT_VERSION,
};
use super::group::{GroupDef, GroupPort, Knob, LibraryRef};
use super::schema::Catalog;
use super::types::Interp;

type FileTrack = Vec<(f64, f64, Interp)>;

/// An input port as written: the inner ports it feeds.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileInput {
    to: Vec<String>,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    doc: String,
}

/// An output port as written: the inner port it gives.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileOutput {
    from: String,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    doc: String,
}

/// A knob as written.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileKnob {
    to: Vec<String>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    default: Option<Value>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    min: Option<f64>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    max: Option<f64>,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    doc: String,
}

/// One entry of a `groups` table (or a library file's `group`): a library reference
/// (`library` set, nothing else but `version`) or an embedded definition.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileGroup {
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    name: Option<String>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    library: Option<String>,
    version: u32,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    doc: String,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    inputs: Vec<(String, FileInput)>,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    outputs: Vec<(String, FileOutput)>,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    knobs: Vec<(String, FileKnob)>,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    nodes: Vec<(String, FileNode)>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    edges: Vec<(String, String)>,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    keys: Vec<(String, FileTrack)>,
    /// A library file's own table of the groups its definition uses.
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    groups: Vec<(String, FileGroup)>,
}

/// A library group file.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileLibrary {
    version: u32,
    group: FileGroup,
}

/// The folders library groups are looked up in for a graph file at `graph` (see the module
/// doc), in order.
pub fn library_folders(graph: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    out.extend(project_folders(graph));
    if let Some(u) = user_library() {
        if !out.contains(&u) {
            out.push(u);
        }
    }
    out
}

/// `$TYNDALL_PRESETS/lib`, else `~/.config/tyndall/presets/lib`, when it exists.
pub fn user_library() -> Option<PathBuf> {
    std::env::var_os("TYNDALL_PRESETS")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config/tyndall/presets"))
        })
        .map(|u| u.join("lib"))
        .filter(|l| l.is_dir())
}

fn project_folders(graph: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let dir = graph
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let start = std::fs::canonicalize(dir).unwrap_or_else(|_| dir.to_path_buf());
    // The graph's folder and the one above; never the file system root's `lib`.
    for a in start.ancestors().take(2).filter(|a| a.parent().is_some()) {
        let lib = a.join("lib");
        if lib.is_dir() {
            out.push(lib);
        }
    }
    out
}

/// Resolves the groups of one graph load: embedded definitions in dependency order, library
/// references from the folders, each library file read once per load, cycles refused with the
/// chain named.
pub(super) struct Resolver {
    folders: Vec<PathBuf>,
    loaded: BTreeMap<String, Arc<GroupDef>>,
    stack: Vec<String>,
}

impl Resolver {
    /// A resolver for the graph file `file`.
    pub(super) fn for_graph(file: &Path) -> Self {
        Self {
            folders: library_folders(file),
            loaded: BTreeMap::new(),
            stack: Vec::new(),
        }
    }

    /// Resolve a `groups` table into definitions by name.
    pub(super) fn resolve_table(
        &mut self,
        table: &[(String, FileGroup)],
        catalog: &Catalog,
    ) -> Result<BTreeMap<String, Arc<GroupDef>>, GraphError> {
        let mut done: BTreeMap<String, Arc<GroupDef>> = BTreeMap::new();
        for (name, _) in table {
            self.resolve_one(name, table, catalog, &mut done)?;
        }
        Ok(done)
    }

    fn resolve_one(
        &mut self,
        name: &str,
        table: &[(String, FileGroup)],
        catalog: &Catalog,
        done: &mut BTreeMap<String, Arc<GroupDef>>,
    ) -> Result<(), GraphError> {
        if done.contains_key(name) {
            return Ok(());
        }
        if let Some(i) = self.stack.iter().position(|s| s == name) {
            let mut chain: Vec<&str> = self.stack[i..].iter().map(String::as_str).collect();
            chain.push(name);
            return Err(GraphError::GroupCycle {
                group: name.to_string(),
                chain: chain.join(" → "),
            });
        }
        let Some((_, fg)) = table.iter().find(|(n, _)| n == name) else {
            return Ok(()); // not a group: a built-in kind (or unknown, reported by the node)
        };
        self.stack.push(name.to_string());
        let result = match &fg.library {
            Some(lib) => self.library(name, lib, fg.version, catalog),
            None => {
                let mut deps = BTreeMap::new();
                for (_, n) in &fg.nodes {
                    if table.iter().any(|(t, _)| *t == n.kind) {
                        self.resolve_one(&n.kind, table, catalog, done)?;
                    }
                    if let Some(d) = done.get(&n.kind) {
                        deps.insert(n.kind.clone(), d.clone());
                    }
                }
                definition(name, fg, catalog, &deps, None)
            }
        };
        self.stack.pop();
        done.insert(name.to_string(), Arc::new(result?));
        Ok(())
    }

    /// The library group `reference` at `version`, for the table entry `name`.
    fn library(
        &mut self,
        name: &str,
        reference: &str,
        version: u32,
        catalog: &Catalog,
    ) -> Result<GroupDef, GraphError> {
        let missing = |reason: String| GraphError::LibraryGroup {
            node: name.to_string(),
            group: format!("{reference}@{version}"),
            reason,
        };
        if let Some(def) = self.loaded.get(reference) {
            if def.version != version {
                return Err(missing(format!(
                    "is version {}, not {version}",
                    def.version
                )));
            }
            return Ok((**def).clone());
        }
        let rel = format!("{reference}.ron");
        let Some(path) = self
            .folders
            .iter()
            .map(|f| f.join(&rel))
            .find(|p| p.is_file())
        else {
            let searched: Vec<String> = self
                .folders
                .iter()
                .map(|f| f.display().to_string())
                .collect();
            return Err(missing(format!(
                "not found: no {rel} in the library folders ({})",
                if searched.is_empty() {
                    "none: no lib/ folder above the graph, no $TYNDALL_PRESETS/lib".to_string()
                } else {
                    searched.join(", ")
                }
            )));
        };
        let text = std::fs::read_to_string(&path)
            .map_err(|e| missing(format!("cannot read {}: {e}", path.display())))?;
        let file: FileLibrary = ron_options()
            .from_str(&text)
            .map_err(|e| missing(format!("{}: {}: {}", path.display(), e.span.start, e.code)))?;
        if file.version > FORMAT_VERSION {
            return Err(missing(format!(
                "{} is format version {}, newer than this build's {FORMAT_VERSION}",
                path.display(),
                file.version
            )));
        }
        let g = &file.group;
        let found = g.name.clone().unwrap_or_default();
        if found != name {
            return Err(missing(format!(
                "{} defines '{found}', but the graph uses it as '{name}'",
                path.display()
            )));
        }
        if g.version != version {
            return Err(missing(format!(
                "{} is version {}, the graph wants version {version}",
                path.display(),
                g.version
            )));
        }
        let deps = self.resolve_table(&g.groups, catalog)?;
        let def = definition(
            name,
            g,
            catalog,
            &deps,
            Some(LibraryRef {
                name: reference.to_string(),
                path: path.clone(),
            }),
        )
        .map_err(|e| missing(format!("{}: {e}", path.display())))?;
        self.loaded
            .insert(reference.to_string(), Arc::new(def.clone()));
        Ok(def)
    }
}

fn endpoints(
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
fn definition(
    name: &str,
    fg: &FileGroup,
    catalog: &Catalog,
    deps: &BTreeMap<String, Arc<GroupDef>>,
    library: Option<LibraryRef>,
) -> Result<GroupDef, GraphError> {
    let inner = FileGraph {
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
fn file_group(def: &GroupDef, reference: bool) -> FileGroup {
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
fn used_groups(g: &Graph, out: &mut BTreeMap<String, Arc<GroupDef>>) {
    for (name, def) in g.groups() {
        if out.insert(name.clone(), def.clone()).is_none() && def.library.is_none() {
            used_groups(&def.graph, out);
        }
    }
}

/// Indent every line after the first by `n` spaces.
fn indent(text: &str, n: usize) -> String {
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
pub(super) fn groups_text(g: &Graph) -> String {
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

fn quote(s: &str) -> String {
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

/// A library group from its file, as a graph referencing it would get it (`reference`: its
/// path under the library folder, without `.ron`).
pub fn load_library_group(
    folder: &Path,
    reference: &str,
    catalog: &Catalog,
) -> Result<Arc<GroupDef>, GraphError> {
    let path = folder.join(format!("{reference}.ron"));
    let text = std::fs::read_to_string(&path)
        .map_err(|e| GraphError::Io(format!("cannot read {}: {e}", path.display())))?;
    let file: FileLibrary = ron_options()
        .from_str(&text)
        .map_err(|e| GraphError::Syntax {
            message: format!("{}: {}: {}", path.display(), e.span.start, e.code),
        })?;
    let name = file.group.name.clone().unwrap_or_default();
    let mut r = Resolver {
        folders: vec![folder.to_path_buf()],
        loaded: BTreeMap::new(),
        stack: Vec::new(),
    };
    let table = vec![(
        name.clone(),
        FileGroup {
            library: Some(reference.to_string()),
            version: file.group.version,
            ..Default::default()
        },
    )];
    let mut defs = r.resolve_table(&table, catalog)?;
    defs.remove(&name).ok_or_else(|| GraphError::Group {
        group: name,
        message: format!("{} defines no group", path.display()),
    })
}

/// Every library group under `folders` (their references: paths under a folder without
/// `.ron`), first folder first; a reference found twice is listed once, from the first.
pub fn list_library(folders: &[PathBuf]) -> Vec<(PathBuf, String)> {
    let mut out: Vec<(PathBuf, String)> = Vec::new();
    for folder in folders {
        let mut stack = vec![folder.clone()];
        while let Some(d) = stack.pop() {
            let Ok(entries) = std::fs::read_dir(&d) else {
                continue;
            };
            let mut entries: Vec<PathBuf> = entries.flatten().map(|e| e.path()).collect();
            entries.sort();
            for p in entries {
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|e| e == "ron") {
                    let rel = p.strip_prefix(folder).unwrap_or(&p).with_extension("");
                    let reference = rel.to_string_lossy().replace('\\', "/");
                    if !out.iter().any(|(_, r)| *r == reference) {
                        out.push((folder.clone(), reference));
                    }
                }
            }
        }
    }
    out
}

/// A graph's group table entry referencing library group `def` (for a graph about to use it).
pub fn reference_entry(def: &GroupDef) -> Option<String> {
    def.library
        .as_ref()
        .map(|l| format!("(library: {}, version: {})", quote(&l.name), def.version))
}

/// Whether `text` is a library group file (`(version: …, group: (…))`) rather than a graph.
pub fn is_library_text(text: &str) -> bool {
    ron_options().from_str::<FileLibrary>(text).is_ok()
}

/// A library group file read on its own (`tyndall validate` on a file under a `lib/` folder):
/// its groups are resolved from the `lib/` folder it lies in.
pub fn load_library_file(path: &Path, catalog: &Catalog) -> Result<Arc<GroupDef>, GraphError> {
    let comps: Vec<String> = path
        .with_extension("")
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let Some(i) = comps.iter().rposition(|c| c == "lib") else {
        return Err(GraphError::Io(format!(
            "{}: a library group file lies under a lib/ folder",
            path.display()
        )));
    };
    let folder: PathBuf = comps[..=i].iter().collect();
    load_library_group(&folder, &comps[i + 1..].join("/"), catalog)
}
