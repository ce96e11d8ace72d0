//! Where the files a graph names are: relative input paths resolve against the graph file's
//! folder, output paths under the output directory, and an output path that is absolute or
//! climbs out with `..` is refused unless the user allows any path — so a preset from someone
//! else cannot overwrite your files. Which parameters name files, and whether they are read or
//! written, each node declares ([`NodeDecl::files`](super::NodeDecl::files)). Also how a
//! frame number and a wedge suffix enter a file name.

use std::path::{Component, Path, PathBuf};

use thiserror::Error;

use super::{FileRole, Registry};
use crate::graph::{Graph, ParamValue};

/// How file paths in a graph are resolved.
#[derive(Clone, Debug)]
pub struct PathPolicy {
    /// The graph file's folder: relative input paths are taken from it.
    pub graph_dir: PathBuf,
    /// Relative output paths are written under it (`.`: the working directory).
    pub output_dir: PathBuf,
    /// Allow absolute output paths and `..` escapes.
    pub allow_any: bool,
}

impl PathPolicy {
    /// Where a path the graph reads is: relative to the graph's folder; absolute (or empty:
    /// no file) as written.
    pub fn input(&self, path: &str) -> String {
        let p = Path::new(path);
        if path.is_empty() || p.is_absolute() {
            path.to_string()
        } else {
            self.graph_dir.join(p).to_string_lossy().into_owned()
        }
    }
}

/// An output path the policy refuses.
#[derive(Debug, Error)]
#[error("node '{node}': {param} = \"{path}\" {why}; outputs stay under the output directory (--output-dir), or pass --allow-any-path")]
pub struct PathRefused {
    /// The node.
    pub node: String,
    /// Its parameter.
    pub param: String,
    /// The path as written in the graph.
    pub path: String,
    /// Why it is refused.
    pub why: &'static str,
}

/// `graph` with every declared file parameter resolved by `policy` (parameters left at their
/// default are resolved too). Empty paths stay empty.
pub fn resolve_files(
    registry: &Registry,
    graph: &Graph,
    policy: &PathPolicy,
) -> Result<Graph, PathRefused> {
    let mut out = graph.clone();
    for node in graph.nodes() {
        let Some(kind) = registry.get(&node.kind) else {
            continue;
        };
        let decl = kind.decl();
        for (param, role) in decl.files {
            let default = decl
                .schema
                .params
                .iter()
                .find(|p| p.name == *param)
                .map(|p| p.default.value());
            let Some(ParamValue::Text(text)) = node.params.get(*param).cloned().or(default) else {
                continue;
            };
            if text.is_empty() {
                continue;
            }
            let path = Path::new(&text);
            let resolved = match role {
                FileRole::Read => PathBuf::from(policy.input(&text)),
                FileRole::Write => {
                    let refuse = |why| PathRefused {
                        node: node.id.clone(),
                        param: param.to_string(),
                        path: text.clone(),
                        why,
                    };
                    if !policy.allow_any && path.is_absolute() {
                        return Err(refuse("is absolute"));
                    }
                    if !policy.allow_any && path.components().any(|c| c == Component::ParentDir) {
                        return Err(refuse("climbs out with .."));
                    }
                    if path.is_relative() && policy.output_dir != Path::new(".") {
                        policy.output_dir.join(path)
                    } else {
                        path.to_path_buf()
                    }
                }
            };
            let value = ParamValue::Text(resolved.to_string_lossy().into_owned());
            // A text parameter takes any text: this cannot fail for a declared file parameter.
            let _ = out.set_param(registry.catalog(), &node.id, param, value);
        }
        // Files named inside the data block are inputs too.
        if let Some(data) = &node.data {
            // A block the node cannot parse is left as it is: evaluating it reports the error.
            if let Ok(Some(resolved)) = kind.data_files(data, &|p| policy.input(p)) {
                let _ = out.set_data(&node.id, Some(resolved));
            }
        }
    }
    Ok(out)
}

/// Cache-key material for a file: its size and modification time (0 when it cannot be read).
/// The evaluator adds it for every file parameter a node declares it reads
/// ([`NodeDecl::files`](super::NodeDecl::files)); a node whose data block names files adds
/// theirs in [`NodeKind::volatile_key`](super::NodeKind::volatile_key).
pub fn file_stamp(path: &std::path::Path) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::hash::DefaultHasher::new();
    if let Ok(m) = std::fs::metadata(path) {
        m.len().hash(&mut h);
        m.modified().ok().hash(&mut h);
    }
    h.finish()
}

/// The file a sink writes for `path` with a wedge `suffix` at `frame`: the frame replaces a
/// `####` run (zero-padded to its length) or a printf `%d` / `%0Nd` in the path, else `_NNNN` is
/// appended to the suffix; the suffix goes before the extension.
pub fn output_path(path: &str, suffix: &str, frame: Option<i64>) -> PathBuf {
    match frame {
        None => with_suffix(path, suffix),
        Some(f) => match with_frame(path, f) {
            Some(p) => with_suffix(&p, suffix),
            None => with_suffix(path, &format!("{suffix}_{f:04}")),
        },
    }
}

/// `path` with its first `####` run or `%d` / `%0Nd` replaced by `frame` (`None`: no pattern).
pub fn with_frame(path: &str, frame: i64) -> Option<String> {
    if let Some(start) = path.find('#') {
        let run = path[start..].chars().take_while(|c| *c == '#').count();
        let digits = format!("{frame:0run$}");
        return Some(format!(
            "{}{digits}{}",
            &path[..start],
            &path[start + run..]
        ));
    }
    let start = path.find('%')?;
    let rest = &path[start + 1..];
    let spec: String = rest.chars().take_while(|c| c.is_ascii_digit()).collect();
    if !rest[spec.len()..].starts_with('d') {
        return None;
    }
    let width: usize = spec.trim_start_matches('0').parse().unwrap_or(0);
    let digits = format!("{frame:0width$}");
    Some(format!(
        "{}{digits}{}",
        &path[..start],
        &rest[spec.len() + 1..]
    ))
}

/// Insert `suffix` before a path's extension (`out.exr` + `_w1` → `out_w1.exr`).
pub fn with_suffix(path: &str, suffix: &str) -> PathBuf {
    let p = PathBuf::from(path);
    if suffix.is_empty() {
        return p;
    }
    let stem = p
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match p.extension() {
        Some(ext) => format!("{stem}{suffix}.{}", ext.to_string_lossy()),
        None => format!("{stem}{suffix}"),
    };
    p.with_file_name(name)
}

/// A list of frames (`--frames`).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameList(pub Vec<i64>);

/// Parse a frame spec: `A`, `A-B`, `A-BxS`, comma-separated; frames ≥ 0, in the order given,
/// repeats dropped.
pub fn parse_frame_spec(s: &str) -> Result<FrameList, String> {
    let mut out: Vec<i64> = Vec::new();
    for part in s.split(',').map(str::trim) {
        let num = |t: &str| -> Result<i64, String> {
            t.trim()
                .parse::<i64>()
                .ok()
                .filter(|v| *v >= 0)
                .ok_or_else(|| format!("bad frame '{t}' in '{s}' (frames are whole numbers ≥ 0)"))
        };
        let (range, step) = match part.split_once(['x', 'X']) {
            Some((r, st)) => (r, num(st)?),
            None => (part, 1),
        };
        if step == 0 {
            return Err(format!("'{part}': the step must be at least 1"));
        }
        let (a, b) = match range.split_once('-') {
            Some((a, b)) => (num(a)?, num(b)?),
            None => (num(range)?, num(range)?),
        };
        if b < a {
            return Err(format!("frame range '{part}' is empty"));
        }
        if (b - a) / step > 1_000_000 {
            return Err(format!("'{part}' is more than a million frames"));
        }
        for f in (a..=b).step_by(step as usize) {
            if !out.contains(&f) {
                out.push(f);
            }
        }
    }
    Ok(FrameList(out))
}
