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

use super::error::GraphError;
use super::format::{ron_options, FORMAT_VERSION};
use super::group::{GroupDef, LibraryRef};
use super::schema::Catalog;

mod file;

use file::{definition, FileLibrary};
pub(super) use file::{groups_text, FileGroup};
pub use file::{library_text, reference_entry};

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
