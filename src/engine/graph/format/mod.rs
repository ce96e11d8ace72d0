//! The RON file format: load (with migrations and located errors) and deterministic save.
//!
//! ```ron
//! (
//!     version: 2,
//!     nodes: {
//!         "a": (kind: "Constant", params: {"value": 2.0}),
//!         "m": (kind: "Math", params: {"op": "mul"}, pos: (120.0, 40.0)),
//!     },
//!     edges: [("a.value", "m.a")],
//!     keys: {"a.value": [(0.0, 1.0, Linear), (24.0, 3.0, Hold)]},
//! )
//! ```
//!
//! Saving orders nodes by id, parameters by name, edges by destination, so save → load → save is
//! byte-identical. Older versions are read and migrated by [`MIGRATIONS`].

use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

use ron::value::{Number, Value};
use serde::de::{MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::document::Graph;
use super::error::{GraphError, LoadError, Location};
use super::schema::Catalog;
use super::types::{Interp, ParamValue};

/// The format version this build writes and the newest it reads. Version 3 added `groups`
/// (node groups, embedded or referenced from a library file: [`crate::graph::GroupDef`]).
pub const FORMAT_VERSION: u32 = 3;

/// A key-frame track as written: `(time, value, interpolation)` triples.
pub(super) type FileTrack = Vec<(f64, f64, Interp)>;

/// A reader for one older format version: parses text of that version (with located errors)
/// and applies every migration step up to the current version.
pub type Migration = fn(&str) -> Result<FileGraph, ron::error::SpannedError>;

/// Readers of older versions; entry `i` reads version `i + 1`. Each chains the per-version
/// steps (`migrate_v1_to_v2`, `migrate_v2_to_v3`).
pub const MIGRATIONS: &[Migration] = &[migrate::read_v1, migrate::read_v2];

mod build;
mod migrate;

pub(super) use build::build;

/// The current file shape (version [`FORMAT_VERSION`]).
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileGraph {
    pub(super) version: u32,
    /// Colour settings: `colour: (working_space: "ACEScg")`; absent: the default working space.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    pub(super) colour: Option<FileColour>,
    #[serde(default, with = "pairs")]
    pub(super) nodes: Vec<(String, FileNode)>,
    #[serde(default)]
    pub(super) edges: Vec<(String, String)>,
    #[serde(default, with = "pairs")]
    pub(super) keys: Vec<(String, FileTrack)>,
    /// Group definitions (embedded or library references), written by hand after the rest
    /// (see [`save_string`]).
    #[serde(default, with = "pairs", skip_serializing)]
    pub(super) groups: Vec<(String, super::library::FileGroup)>,
}

/// A graph's colour settings as written.
#[derive(Serialize, Deserialize, Clone, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct FileColour {
    /// The working space (a colour space of the config).
    #[serde(default)]
    pub(super) working_space: String,
}

#[derive(Serialize, Deserialize, Clone)]
#[serde(deny_unknown_fields)]
pub(super) struct FileNode {
    pub(super) kind: String,
    #[serde(default, with = "pairs", skip_serializing_if = "Vec::is_empty")]
    params: Vec<(String, Value)>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    pos: Option<(f32, f32)>,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        serialize_with = "ser_inner"
    )]
    data: Option<super::NodeData>,
}

pub(super) fn ser_inner<S: Serializer, T: Serialize>(
    v: &Option<T>,
    s: S,
) -> Result<S::Ok, S::Error> {
    match v {
        Some(x) => x.serialize(s),
        None => s.serialize_none(),
    }
}

/// A map read as a list of pairs, so that repeated keys are seen instead of silently merged.
pub(super) mod pairs {
    use super::*;

    pub fn serialize<S: Serializer, K: Serialize, V: Serialize>(
        v: &[(K, V)],
        s: S,
    ) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(v.len()))?;
        for (k, val) in v {
            m.serialize_entry(k, val)?;
        }
        m.end()
    }

    struct PairsVisitor<K, V>(std::marker::PhantomData<(K, V)>);

    impl<'de, K: Deserialize<'de>, V: Deserialize<'de>> Visitor<'de> for PairsVisitor<K, V> {
        type Value = Vec<(K, V)>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a map { \"key\": value, ... }")
        }
        fn visit_map<A: MapAccess<'de>>(self, mut a: A) -> Result<Self::Value, A::Error> {
            let mut out = Vec::new();
            while let Some(kv) = a.next_entry()? {
                out.push(kv);
            }
            Ok(out)
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>, K: Deserialize<'de>, V: Deserialize<'de>>(
        d: D,
    ) -> Result<Vec<(K, V)>, D::Error> {
        d.deserialize_map(PairsVisitor(std::marker::PhantomData))
    }
}

pub(super) fn ron_options() -> ron::Options {
    ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
}

/// Finds where things are named in the file's text, for error locations.
pub(super) struct Locator<'a> {
    pub(super) text: &'a str,
}

impl Locator<'_> {
    pub(super) fn at(&self, byte: usize) -> Location {
        let before = &self.text[..byte.min(self.text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before
            .rsplit('\n')
            .next()
            .map(|l| l.chars().count())
            .unwrap_or(0)
            + 1;
        Location { line, col }
    }

    /// Byte offset of the `nth` (0-based) occurrence of `"s"` at or after `from`, optionally
    /// only where followed by a colon (a map key).
    fn find_quoted(&self, s: &str, from: usize, nth: usize, as_key: bool) -> Option<usize> {
        let needle = format!("\"{s}\"");
        let mut pos = from;
        let mut seen = 0;
        while let Some(i) = self.text.get(pos..)?.find(&needle) {
            let abs = pos + i;
            let after = self.text[abs + needle.len()..].trim_start();
            if !as_key || after.starts_with(':') {
                if seen == nth {
                    return Some(abs);
                }
                seen += 1;
            }
            pos = abs + needle.len();
        }
        None
    }

    fn node(&self, id: &str, nth: usize) -> Option<usize> {
        let nodes = self.text.find("nodes").unwrap_or(0);
        self.find_quoted(id, nodes, nth, true)
    }

    fn param(&self, id: &str, param: &str) -> Option<usize> {
        let n = self.node(id, 0)?;
        self.find_quoted(param, n, 0, true)
    }

    fn edge(&self, endpoint: &str) -> Option<usize> {
        let edges = self.text.find("edges").unwrap_or(0);
        self.find_quoted(endpoint, edges, 0, false)
    }

    fn key(&self, target: &str) -> Option<usize> {
        let keys = self.text.find("keys").unwrap_or(0);
        self.find_quoted(target, keys, 0, true)
    }

    fn version(&self) -> Option<usize> {
        self.text.find("version")
    }
}

pub(super) fn value_to_param(v: &Value) -> Result<ParamValue, String> {
    match v {
        Value::Number(n) => match n {
            Number::F32(_) | Number::F64(_) => Ok(ParamValue::Float(n.into_f64())),
            _ => Ok(ParamValue::Int(n.into_f64() as i64)),
        },
        Value::Bool(b) => Ok(ParamValue::Bool(*b)),
        Value::String(s) => Ok(ParamValue::Text(s.clone())),
        Value::Seq(items) if items.len() == 3 || items.len() == 4 => {
            let mut c = [1.0f64; 4];
            for (i, it) in items.iter().enumerate() {
                match it {
                    Value::Number(n) => c[i] = n.into_f64(),
                    _ => return Err("a list of numbers".into()),
                }
            }
            // Three numbers are a Vec3 (a Colour parameter coerces it with alpha 1).
            Ok(if items.len() == 3 {
                ParamValue::Vec3([c[0], c[1], c[2]])
            } else {
                ParamValue::Colour(c)
            })
        }
        Value::Seq(_) => Err("a list (colours have 3 or 4 numbers, vectors 3)".into()),
        Value::Map(_) => Err("a map or struct".into()),
        Value::Unit => Err("()".into()),
        Value::Option(_) => Err("an option".into()),
        Value::Char(c) => Err(format!("the character '{c}'")),
        Value::Bytes(_) => Err("bytes".into()),
    }
}

pub(super) fn param_to_value(p: &ParamValue) -> Value {
    match p {
        ParamValue::Float(v) => Value::Number(Number::F64((*v).into())),
        ParamValue::Int(v) => Value::Number(Number::I64(*v)),
        ParamValue::Bool(b) => Value::Bool(*b),
        ParamValue::Enum(s) | ParamValue::Text(s) => Value::String(s.clone()),
        ParamValue::Colour(c) => numbers(c),
        ParamValue::Vec3(c) => numbers(c),
    }
}

fn numbers(c: &[f64]) -> Value {
    Value::Seq(
        c.iter()
            .map(|x| Value::Number(Number::F64((*x).into())))
            .collect(),
    )
}

fn syntax_location(e: &ron::error::SpannedError) -> Location {
    Location {
        line: e.span.start.line,
        col: e.span.start.col,
    }
}

/// Parse a graph from text. `file` is used in error messages only.
pub fn load_str(text: &str, file: &Path, catalog: &Catalog) -> Result<Graph, LoadError> {
    let loc = Locator { text };
    let err = |location: Option<Location>, error: GraphError| LoadError {
        file: file.to_path_buf(),
        location,
        error,
    };
    let raw: Value = ron_options().from_str(text).map_err(|e| {
        err(
            Some(syntax_location(&e)),
            GraphError::Syntax {
                message: e.code.to_string(),
            },
        )
    })?;
    let version = match &raw {
        Value::Map(m) => match m.get(&Value::String("version".into())) {
            Some(Value::Number(n)) => n.into_f64(),
            Some(_) => {
                return Err(err(
                    loc.version().map(|b| loc.at(b)),
                    GraphError::Syntax {
                        message: "`version` must be a whole number".into(),
                    },
                ))
            }
            None => {
                return Err(err(
                    Some(Location { line: 1, col: 1 }),
                    GraphError::Syntax {
                        message: "expected a graph struct with a `version` field".into(),
                    },
                ))
            }
        },
        _ => {
            return Err(err(
                Some(Location { line: 1, col: 1 }),
                GraphError::Syntax {
                    message: "expected a graph struct `(version: .., nodes: {..}, ..)`".into(),
                },
            ))
        }
    };
    if !(version >= 1.0 && version.fract() == 0.0 && version <= u32::MAX as f64) {
        return Err(err(
            loc.version().map(|b| loc.at(b)),
            GraphError::Syntax {
                message: format!("`version` must be a whole number ≥ 1, found {version}"),
            },
        ));
    }
    let version = version as u32;
    if version > FORMAT_VERSION {
        return Err(err(
            loc.version().map(|b| loc.at(b)),
            GraphError::VersionTooNew {
                found: version,
                supported: FORMAT_VERSION,
            },
        ));
    }
    let reader: Migration = match MIGRATIONS.get(version as usize - 1) {
        Some(read_old) if version < FORMAT_VERSION => *read_old,
        _ => |text| ron_options().from_str::<FileGraph>(text),
    };
    let parsed = reader(text).map_err(|e| {
        let message = if version < FORMAT_VERSION {
            format!("{} (reading format version {version})", e.code)
        } else {
            e.code.to_string()
        };
        err(Some(syntax_location(&e)), GraphError::Syntax { message })
    })?;
    let mut resolver = super::library::Resolver::for_graph(file);
    let groups = resolver
        .resolve_table(&parsed.groups, catalog)
        .map_err(|e| err(None, e))?;
    build(parsed, &loc, catalog, &groups, false).map_err(|(b, e)| err(b.map(|b| loc.at(b)), e))
}

/// A graph as its file's parts (without groups): nodes by id, edges by destination, key tracks.
pub(super) fn file_graph(g: &Graph) -> FileGraph {
    let mut keys = Vec::new();
    let nodes = g
        .nodes()
        .map(|n| {
            for (param, track) in &n.keys {
                keys.push((
                    format!("{}.{param}", n.id),
                    track
                        .iter()
                        .map(|k| (k.t, k.v, k.interp))
                        .collect::<Vec<_>>(),
                ));
            }
            (
                n.id.clone(),
                FileNode {
                    kind: n.kind.clone(),
                    params: n
                        .params
                        .iter()
                        .map(|(k, v)| (k.clone(), param_to_value(v)))
                        .collect(),
                    pos: n.pos.map(|[x, y]| (x, y)),
                    data: n.data.clone(),
                },
            )
        })
        .collect();
    FileGraph {
        version: FORMAT_VERSION,
        groups: Vec::new(),
        colour: g.has_working_space().then(|| FileColour {
            working_space: g.working_space().to_string(),
        }),
        nodes,
        edges: g
            .edges()
            .into_iter()
            .map(|e| {
                (
                    format!("{}.{}", e.from_node, e.from_port),
                    format!("{}.{}", e.to_node, e.to_port),
                )
            })
            .collect(),
        keys,
    }
}

/// Serialise a graph deterministically (ids, parameters and edges ordered; then its groups).
pub fn save_string(g: &Graph) -> String {
    let file = file_graph(g);
    let cfg = ron::ser::PrettyConfig::new()
        .depth_limit(2)
        .indentor("    ")
        .new_line("\n")
        .struct_names(false)
        .separate_tuple_members(false);
    let mut s = ron::ser::to_string_pretty(&file, cfg).unwrap_or_else(|e| format!("// {e}"));
    let groups = super::library::groups_text(g);
    if !groups.is_empty() {
        // Before the closing `)`: the `groups` table, each definition in the file's own layout.
        if let Some(end) = s.rfind(')') {
            s.insert_str(end, &groups);
        }
    }
    s.push('\n');
    s
}

/// The pretty-printer settings of graph files: maps and lists one entry per line down to
/// `depth`, each entry on one line.
pub(super) fn pretty(depth: usize) -> ron::ser::PrettyConfig {
    ron::ser::PrettyConfig::new()
        .depth_limit(depth)
        .indentor("    ")
        .new_line("\n")
        .struct_names(false)
        .separate_tuple_members(false)
}

/// Read and parse a graph file.
pub fn load_file(path: &Path, catalog: &Catalog) -> Result<Graph, LoadError> {
    let text = std::fs::read_to_string(path).map_err(|e| LoadError {
        file: path.to_path_buf(),
        location: None,
        error: GraphError::Io(format!("cannot read: {e}")),
    })?;
    load_str(&text, path, catalog)
}

/// Write a graph file atomically: the text goes to a temporary file beside the target, is
/// flushed to disk, then renamed over the target, so a crash leaves the old or the new file,
/// never a truncated one.
pub fn save_file(path: &Path, g: &Graph) -> Result<(), GraphError> {
    write_atomic(path, save_string(g).as_bytes())
}

/// Atomically replace `path` with `bytes` (temporary file in the same folder, fsync, rename).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), GraphError> {
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp: PathBuf = dir.join(format!(".{name}.tmp{}", std::process::id()));
    let io = |e: std::io::Error| GraphError::Io(format!("cannot write {}: {e}", path.display()));
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(bytes).map_err(io)?;
    f.sync_all().map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
}
