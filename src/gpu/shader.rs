//! WGSL sources and the one mechanism that composes them: `#import path` lines.
//!
//! A shader file may start with lines `#import lib/medium` (any path under `shaders/` without
//! `.wgsl`): [`Shader::wgsl`] replaces each with that file's text, itself composed, every file
//! at most once per shader (a second import of the same file is dropped, so two parts may both
//! import `lib/medium`). `shaders/lib/` holds what several techniques share (camera rays,
//! shadow-map tests, medium integrals, hashing, sampling); a technique's folder
//! (`shaders/<stem>/`) may hold parts its passes share. The composed text is what naga
//! validates (`tests/shaders.rs`), what the layout and capability checks read, and what the
//! driver compiles.

use std::collections::{BTreeSet, HashMap};
use std::sync::{Mutex, OnceLock};

include!(concat!(env!("OUT_DIR"), "/shader_files.rs"));

/// A WGSL source and its path under `shaders/`.
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    /// Path under `shaders/` without `.wgsl`: `blur` for `shaders/blur.wgsl`,
    /// `single_scattering/min_max` for `shaders/single_scattering/min_max.wgsl`. Its first
    /// component is the node's stem (`nodes/<stem>.rs` or `nodes/<stem>/mod.rs`).
    pub stem: &'static str,
    /// The file's text as written (with its `#import` lines; see [`Shader::wgsl`]).
    pub source: &'static str,
}

impl Shader {
    /// `Shader::new("math", include_str!("../shaders/math.wgsl"))`: the path and the embedded
    /// source (a test checks that the source equals `shaders/<stem>.wgsl`).
    pub const fn new(stem: &'static str, source: &'static str) -> Self {
        Self { stem, source }
    }

    /// The node stem this shader belongs to: the first component of [`Shader::stem`].
    pub fn node_stem(&self) -> &'static str {
        self.stem.split('/').next().unwrap_or(self.stem)
    }

    /// The composed WGSL: every `#import` resolved (see the module doc), computed once per
    /// path and kept for the life of the process.
    pub fn wgsl(&self) -> Result<&'static str, String> {
        static DONE: OnceLock<Mutex<HashMap<&'static str, &'static str>>> = OnceLock::new();
        let done = DONE.get_or_init(Default::default);
        let mut done = done.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(text) = done.get(self.stem) {
            return Ok(text);
        }
        let text: &'static str = Box::leak(compose(self.stem, self.source)?.into_boxed_str());
        done.insert(self.stem, text);
        Ok(text)
    }
}

/// The text of `shaders/<path>.wgsl`, as embedded at build time.
pub fn shader_file(path: &str) -> Option<&'static str> {
    SHADER_FILES
        .iter()
        .find(|(name, _)| *name == path)
        .map(|(_, text)| *text)
}

/// Every `shaders/**/*.wgsl` path (without `.wgsl`), as embedded at build time.
pub fn shader_files() -> impl Iterator<Item = &'static str> {
    SHADER_FILES.iter().map(|(name, _)| *name)
}

/// Compose `source` (the text of `shaders/<name>.wgsl`): see the module doc.
pub fn compose(name: &str, source: &str) -> Result<String, String> {
    let mut seen = BTreeSet::new();
    seen.insert(name.to_string());
    let mut out = String::with_capacity(source.len() * 2);
    expand(name, source, &mut seen, &mut Vec::new(), &mut out)?;
    Ok(out)
}

fn expand(
    name: &str,
    source: &str,
    seen: &mut BTreeSet<String>,
    stack: &mut Vec<String>,
    out: &mut String,
) -> Result<(), String> {
    stack.push(name.to_string());
    for line in source.lines() {
        let Some(path) = line.trim().strip_prefix("#import") else {
            out.push_str(line);
            out.push('\n');
            continue;
        };
        let path = path.trim();
        if stack.iter().any(|s| s == path) {
            return Err(format!(
                "shaders/{name}.wgsl: `#import {path}` makes a cycle ({} → {path})",
                stack.join(" → ")
            ));
        }
        if !seen.insert(path.to_string()) {
            out.push_str(&format!("// (#import {path}: already included)\n"));
            continue;
        }
        let text = shader_file(path).ok_or_else(|| {
            format!("shaders/{name}.wgsl: `#import {path}`: there is no shaders/{path}.wgsl")
        })?;
        out.push_str(&format!(
            "// ---- #import {path} (shaders/{path}.wgsl) ----\n"
        ));
        expand(path, text, seen, stack, out)?;
        out.push_str(&format!("// ---- end of {path} ----\n"));
    }
    stack.pop();
    Ok(())
}
