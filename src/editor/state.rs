//! Editor state: the document, its undo/redo history, the clipboard format, presets, saving.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use thiserror::Error;

mod groups;

use tyndall_engine::graph::{
    load_file, load_str, save_string, write_atomic, Catalog, Graph, GraphError, Key, LoadError,
    Node, ParamValue,
};

/// Undo steps kept (older ones are dropped).
pub const UNDO_LIMIT: usize = 200;

/// Editor failures, each naming the file or node at fault.
#[derive(Debug, Error)]
pub enum EditorError {
    /// A document operation was refused (type mismatch, cycle, bad value...).
    #[error(transparent)]
    Graph(#[from] GraphError),
    /// A file could not be loaded.
    #[error(transparent)]
    Load(#[from] LoadError),
    /// The document has no file yet.
    #[error("the graph has no file yet: use save as")]
    NoPath,
}

/// One preset of a library folder.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PresetEntry {
    /// Name shown (file stem, with the folder for subfolders: `stylize/tree_hole_filling`).
    pub name: String,
    /// The file.
    pub path: PathBuf,
}

/// The side file autosave writes next to `path` (`.name.ron.autosave`).
pub fn autosave_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "untitled.ron".into());
    path.with_file_name(format!(".{name}.autosave"))
}

/// The editor's document state: the graph (the single source of truth), its history and file.
pub struct EditorState {
    catalog: Catalog,
    graph: Graph,
    undo: Vec<Graph>,
    redo: Vec<Graph>,
    path: Option<PathBuf>,
    saved: Graph,
    last_autosave: Instant,
    autosave_every: Duration,
    /// The tag of the last `set_data` call that may merge with the next (a drag or a stroke in
    /// progress): `node:tag`.
    merge: Option<String>,
    /// The group instances entered (Tab), from the document down: the canvas shows and edits
    /// the graph inside the last one.
    scope: Vec<String>,
}

impl EditorState {
    /// A new, empty, untitled document.
    pub fn new(catalog: Catalog) -> Self {
        Self {
            catalog,
            graph: Graph::new(),
            undo: Vec::new(),
            redo: Vec::new(),
            path: None,
            saved: Graph::new(),
            last_autosave: Instant::now(),
            autosave_every: Duration::from_secs(60),
            merge: None,
            scope: Vec::new(),
        }
    }

    /// Open a graph file.
    pub fn open(catalog: Catalog, path: &Path) -> Result<Self, EditorError> {
        let graph = load_file(path, &catalog)?;
        let mut s = Self::new(catalog);
        s.saved = graph.clone();
        s.graph = graph;
        s.path = Some(path.to_path_buf());
        Ok(s)
    }

    /// The graph shown and edited: the document, or the inside of the group entered.
    pub fn graph(&self) -> &Graph {
        self.graph.inside(&self.scope).unwrap_or(&self.graph)
    }

    /// The whole document (what is saved and evaluated), whatever group is entered.
    pub fn root(&self) -> &Graph {
        &self.graph
    }

    /// The catalog of node kinds.
    pub fn catalog(&self) -> &Catalog {
        &self.catalog
    }

    /// The document's file, if it has one.
    pub fn path(&self) -> Option<&Path> {
        self.path.as_deref()
    }

    /// Whether the document differs from its file (asked before quitting).
    pub fn is_dirty(&self) -> bool {
        self.graph != self.saved
    }

    /// Number of steps undo can take.
    pub fn undo_depth(&self) -> usize {
        self.undo.len()
    }

    /// Connect `from` to `to` (`"node.port"`) in one undo step, first removing the edge `to`
    /// already has (connecting to a taken input replaces its edge, as in other compositors).
    pub fn connect_replacing(&mut self, from: &str, to: &str) -> Result<(), EditorError> {
        let (to_node, to_port) = to.split_once('.').unwrap_or((to, ""));
        let (to_node, to_port) = (to_node.to_string(), to_port.to_string());
        self.apply(|g, c| {
            g.disconnect(&to_node, &to_port);
            g.connect(c, from, to)
        })
    }

    /// Apply a change as one undoable step; a refused change leaves document and history as
    /// they were.
    pub fn apply<T>(
        &mut self,
        change: impl FnOnce(&mut Graph, &Catalog) -> Result<T, GraphError>,
    ) -> Result<T, EditorError> {
        self.merge = None;
        let before = self.graph.clone();
        let scope = self.scope.clone();
        match self.graph.edit_inside(&self.catalog, &scope, change) {
            Ok(v) => {
                if self.graph != before {
                    self.undo.push(before);
                    if self.undo.len() > UNDO_LIMIT {
                        self.undo.remove(0);
                    }
                    self.redo.clear();
                }
                Ok(v)
            }
            Err(e) => {
                self.graph = before;
                Err(e.into())
            }
        }
    }

    /// Set (or clear) a node's data block as one undoable step. With `merge`, consecutive calls
    /// with the same tag on the same node — the frames of one drag or one painted stroke — make
    /// a single step: undo returns to before the first of them.
    pub fn set_data(
        &mut self,
        node: &str,
        data: Option<tyndall_engine::graph::NodeData>,
        merge: Option<&str>,
    ) -> Result<(), EditorError> {
        let tag = merge.map(|m| format!("{node}:{m}"));
        if tag.is_some() && tag == self.merge && !self.undo.is_empty() {
            let scope = self.scope.clone();
            self.graph
                .edit_inside(&self.catalog, &scope, |g, _| g.set_data(node, data))?;
            self.redo.clear();
            return Ok(());
        }
        self.apply(|g, _| g.set_data(node, data))?;
        self.merge = tag;
        Ok(())
    }

    /// A node's data block parsed into the node's own structure (`T::default()` when it has
    /// none); the error is the parse error.
    pub fn node_data<T: serde::de::DeserializeOwned + Default>(
        &self,
        node: &str,
    ) -> Result<T, String> {
        match self.graph().node(node).and_then(|n| n.data.as_ref()) {
            Some(d) => d.parse(),
            None => Ok(T::default()),
        }
    }

    /// Write a node's data block from its structure: [`EditorState::set_data`] (one undoable
    /// step, merged by `merge` tag).
    pub fn store_node_data<T: serde::Serialize>(
        &mut self,
        node: &str,
        data: &T,
        merge: Option<&str>,
    ) -> Result<(), String> {
        let d = tyndall_engine::graph::NodeData::from_value(data)?;
        self.set_data(node, Some(d), merge)
            .map_err(|e| e.to_string())
    }

    /// End a merged edit (the drag or stroke is over): the next `set_data` starts a new step.
    pub fn end_merge(&mut self) {
        self.merge = None;
    }

    /// Undo the last change; returns whether there was one.
    pub fn undo(&mut self) -> bool {
        self.merge = None;
        match self.undo.pop() {
            Some(g) => {
                self.redo.push(std::mem::replace(&mut self.graph, g));
                self.fix_scope();
                true
            }
            None => false,
        }
    }

    /// Redo the last undone change; returns whether there was one.
    pub fn redo(&mut self) -> bool {
        self.merge = None;
        match self.redo.pop() {
            Some(g) => {
                self.undo.push(std::mem::replace(&mut self.graph, g));
                self.fix_scope();
                true
            }
            None => false,
        }
    }

    /// Add a node of `kind` at a canvas position; returns its id.
    pub fn add_node(&mut self, kind: &str, pos: [f32; 2]) -> Result<String, EditorError> {
        self.apply(|g, c| {
            let id = g.add_node(c, kind)?;
            g.set_pos(&id, Some(pos))?;
            Ok(id)
        })
    }

    /// Connect `from` (`node.port`) to `to`; the error says why a connection is refused.
    pub fn connect(&mut self, from: &str, to: &str) -> Result<(), EditorError> {
        self.apply(|g, c| g.connect(c, from, to))
    }

    /// Set a parameter.
    pub fn set_param(
        &mut self,
        node: &str,
        param: &str,
        value: ParamValue,
    ) -> Result<(), EditorError> {
        self.apply(|g, c| g.set_param(c, node, param, value))
    }

    /// Set (or clear with an empty list) a parameter's key-frames.
    pub fn set_keys(&mut self, node: &str, param: &str, keys: Vec<Key>) -> Result<(), EditorError> {
        self.apply(|g, c| g.set_keys(c, node, param, keys))
    }

    /// Delete nodes (and their edges).
    pub fn delete(&mut self, ids: &[String]) -> Result<(), EditorError> {
        self.apply(|g, _| {
            for id in ids {
                g.remove_node(id)?;
            }
            Ok(())
        })
    }

    /// The clipboard text of a selection: a graph file holding the selected nodes and the edges
    /// among them (so it can be pasted into any graph, or saved as a preset).
    pub fn copy(&self, ids: &[String]) -> String {
        let keep: BTreeSet<&str> = ids.iter().map(String::as_str).collect();
        let mut sub = Graph::new();
        let here = self.graph();
        for n in here.nodes().filter(|n| keep.contains(n.id.as_str())) {
            if let Some(def) = here.groups().get(&n.kind) {
                sub.add_group(def.clone());
            }
            // The node came from this document, so it passes the same checks again.
            let _ = sub.insert_node(&self.catalog, n.clone());
        }
        for e in here.edges() {
            if keep.contains(e.from_node.as_str()) && keep.contains(e.to_node.as_str()) {
                let _ = sub.connect_deferred(
                    &self.catalog,
                    &format!("{}.{}", e.from_node, e.from_port),
                    &format!("{}.{}", e.to_node, e.to_port),
                );
            }
        }
        save_string(&sub)
    }

    /// Paste clipboard text (or merge a preset): every node gets a fresh id, positions move by
    /// `offset`; returns the new ids. One undo step.
    pub fn paste(&mut self, text: &str, offset: [f32; 2]) -> Result<Vec<String>, EditorError> {
        // Library groups in the text are looked up from the document's folder.
        let here = self
            .path
            .clone()
            .unwrap_or_else(|| PathBuf::from("<clipboard>"));
        let clip = load_str(text, &here, &self.catalog)?;
        self.paste_graph(&clip, offset)
    }

    /// Add the nodes and edges of `clip` (with the groups they use) with fresh ids, offset by
    /// `offset`; one undo step. Returns the new ids.
    pub fn paste_graph(
        &mut self,
        clip: &Graph,
        offset: [f32; 2],
    ) -> Result<Vec<String>, EditorError> {
        self.apply(|g, c| {
            // A group whose name the document uses for another definition comes in renamed
            // (`Look2`), so the document's own instances keep theirs.
            let mut kinds: BTreeMap<String, String> = BTreeMap::new();
            for (name, def) in clip.groups() {
                match g.groups().get(name) {
                    Some(have) if **have != **def => {
                        let mut n = 2;
                        while g.groups().contains_key(&format!("{name}{n}"))
                            || c.get(&format!("{name}{n}")).is_some()
                        {
                            n += 1;
                        }
                        let new = format!("{name}{n}");
                        g.add_group(std::sync::Arc::new(def.renamed(c, &new)?));
                        kinds.insert(name.clone(), new);
                    }
                    Some(_) => {}
                    None => g.add_group(def.clone()),
                }
            }
            let mut ids: BTreeMap<String, String> = BTreeMap::new();
            for n in clip.nodes() {
                let id = g.fresh_id(&n.kind);
                let node = Node {
                    id: id.clone(),
                    kind: kinds
                        .get(&n.kind)
                        .cloned()
                        .unwrap_or_else(|| n.kind.clone()),
                    pos: n.pos.map(|[x, y]| [x + offset[0], y + offset[1]]),
                    ..n.clone()
                };
                g.insert_node(c, node)?;
                ids.insert(n.id.clone(), id);
            }
            for e in clip.edges() {
                if let (Some(a), Some(b)) = (ids.get(&e.from_node), ids.get(&e.to_node)) {
                    g.connect(
                        c,
                        &format!("{a}.{}", e.from_port),
                        &format!("{b}.{}", e.to_port),
                    )?;
                }
            }
            Ok(ids.into_values().collect())
        })
    }

    /// Duplicate nodes (with the edges among them), offset on the canvas.
    pub fn duplicate(&mut self, ids: &[String]) -> Result<Vec<String>, EditorError> {
        let text = self.copy(ids);
        self.paste(&text, [40.0, 40.0])
    }

    /// Save to the document's file (atomically: temporary file, then rename).
    pub fn save(&mut self) -> Result<(), EditorError> {
        let path = self.path.clone().ok_or(EditorError::NoPath)?;
        self.save_as(&path)
    }

    /// Save to `path` atomically and make it the document's file; removes the autosave.
    pub fn save_as(&mut self, path: &Path) -> Result<(), EditorError> {
        tyndall_engine::graph::save_file(path, &self.graph)?;
        self.path = Some(path.to_path_buf());
        self.saved = self.graph.clone();
        let _ = std::fs::remove_file(autosave_path(path));
        Ok(())
    }

    /// Save a selection as a preset file.
    pub fn save_preset(&self, ids: &[String], path: &Path) -> Result<(), EditorError> {
        Ok(write_atomic(path, self.copy(ids).as_bytes())?)
    }

    /// Write the autosave side file if the autosave period has passed since the last one and
    /// the document has unsaved changes; returns whether it wrote. Call every frame.
    pub fn tick_autosave(&mut self, now: Instant) -> Result<bool, EditorError> {
        if now.duration_since(self.last_autosave) < self.autosave_every || !self.is_dirty() {
            return Ok(false);
        }
        self.last_autosave = now;
        let path = self
            .path
            .clone()
            .unwrap_or_else(|| PathBuf::from("untitled.ron"));
        write_atomic(&autosave_path(&path), save_string(&self.graph).as_bytes())?;
        Ok(true)
    }

    /// Set the autosave period (default one minute).
    pub fn set_autosave_period(&mut self, every: Duration) {
        self.autosave_every = every;
    }

    /// An autosave newer than `path` left by a session that did not save: what to offer to
    /// recover at start.
    pub fn recoverable(path: &Path) -> Option<PathBuf> {
        let side = autosave_path(path);
        let side_time = std::fs::metadata(&side).and_then(|m| m.modified()).ok()?;
        match std::fs::metadata(path).and_then(|m| m.modified()) {
            Ok(t) if t > side_time => None,
            _ => Some(side),
        }
    }

    /// Recover from an autosave: the document becomes its content (unsaved), the file stays
    /// the original.
    pub fn recover(&mut self, side: &Path) -> Result<(), EditorError> {
        let g = load_file(side, &self.catalog)?;
        self.scope.clear();
        self.apply(|doc, _| {
            *doc = g;
            Ok(())
        })
    }
}

/// The picture shown for a preset in the browser: `<name>.png` beside the preset, else the one
/// under `docs/` for presets under `graphs/` (`graphs/stylize/x.ron` → `docs/stylize/x.png`, what
/// `scripts/render_docs.sh` writes). For an animated preset rendered as a sequence, the first
/// frame stands in (`x_0000.png`, `x.0001.png`: the name, `_` or `.`, digits).
pub fn preset_thumbnail(path: &Path) -> Option<PathBuf> {
    let stem = path.file_stem()?.to_str()?;
    let beside = path.parent().map(Path::to_path_buf);
    let docs = path
        .strip_prefix("graphs")
        .ok()
        .and_then(Path::parent)
        .map(|rel| Path::new("docs").join(rel));
    let first_frame = |dir: &Path| -> Option<PathBuf> {
        let mut frames: Vec<PathBuf> = std::fs::read_dir(dir)
            .ok()?
            .flatten()
            .map(|e| e.path())
            .filter(|p| {
                let Some(name) = p.file_name().and_then(|n| n.to_str()) else {
                    return false;
                };
                let Some(digits) = name
                    .strip_prefix(stem)
                    .and_then(|r| r.strip_prefix('_').or_else(|| r.strip_prefix('.')))
                    .and_then(|r| r.strip_suffix(".png"))
                else {
                    return false;
                };
                !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
            })
            .collect();
        frames.sort();
        frames.into_iter().next()
    };
    [beside, docs].into_iter().flatten().find_map(|dir| {
        let single = dir.join(format!("{stem}.png"));
        if single.is_file() {
            Some(single)
        } else {
            first_frame(&dir)
        }
    })
}

/// The presets under `folders` (recursively), ordered by name; a folder's `lib/` holds library
/// groups and its `bench/` the benchmark suites' inputs (`benches/*.ron` name them), not looks,
/// so both are left out.
pub fn list_presets(folders: &[PathBuf]) -> Vec<PresetEntry> {
    let mut out = Vec::new();
    for root in folders {
        let mut stack = vec![root.clone()];
        while let Some(dir) = stack.pop() {
            let Ok(entries) = std::fs::read_dir(&dir) else {
                continue;
            };
            for e in entries.flatten() {
                let p = e.path();
                if p.is_dir() {
                    let skipped = |n: &std::ffi::OsStr| n == "lib" || n == "bench";
                    if !(dir == *root && p.file_name().is_some_and(skipped)) {
                        stack.push(p);
                    }
                } else if p.extension().and_then(|x| x.to_str()) == Some("ron") {
                    let rel = p.strip_prefix(root).unwrap_or(&p).with_extension("");
                    out.push(PresetEntry {
                        name: rel.to_string_lossy().replace('\\', "/"),
                        path: p,
                    });
                }
            }
        }
    }
    out.sort_by(|a, b| a.name.cmp(&b.name));
    out
}
