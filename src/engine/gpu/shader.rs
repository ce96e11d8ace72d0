//! WGSL sources and the one mechanism that composes them: `#import path` lines.
//!
//! A shader file may start with lines `#import lib/medium` (any path under `shaders/` without
//! `.wgsl`): [`Shader::wgsl`] replaces each with that file's text, itself composed, every file
//! at most once per shader (a second import of the same file is dropped, so two parts may both
//! import `lib/medium`). `shaders/lib/` holds what several techniques share (camera rays,
//! shadow-map tests, medium integrals, hashing, sampling); a technique's folder
//! (`shaders/<stem>/`) may hold parts its passes share. The composed text is what naga
//! validates (`tests/platform/shaders.rs`), what the layout and capability checks read, and what the
//! driver compiles.

use std::collections::{BTreeSet, HashMap};
use std::sync::{Mutex, OnceLock};

/// The WGSL files `#import` lines resolve against: (path under `shaders/` without `.wgsl`,
/// text). The engine holds no shader; the techniques crate embeds every `shaders/**/*.wgsl`
/// file at build time and hands its table to each [`Shader`] it declares.
pub type ShaderFiles = &'static [(&'static str, &'static str)];

/// A WGSL source, its path under `shaders/`, and the files its `#import` lines resolve against.
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    /// Path under `shaders/` without `.wgsl`: `blur` for `shaders/blur.wgsl`,
    /// `single_scattering/min_max` for `shaders/single_scattering/min_max.wgsl`. Its first
    /// component is the node's stem (`nodes/<stem>.rs` or `nodes/<stem>/mod.rs`).
    pub stem: &'static str,
    /// The file's text as written (with its `#import` lines; see [`Shader::wgsl`]).
    pub source: &'static str,
    /// Where its `#import` lines are looked up (see [`ShaderFiles`]).
    pub files: ShaderFiles,
}

impl Shader {
    /// `Shader::new("math", include_str!("../shaders/math.wgsl"), FILES)`: the path, the
    /// embedded source (a test checks that the source equals `shaders/<stem>.wgsl`) and the
    /// files its imports resolve against (a technique writes `crate::shader("math", …)`,
    /// which passes the techniques crate's table).
    pub const fn new(stem: &'static str, source: &'static str, files: ShaderFiles) -> Self {
        Self {
            stem,
            source,
            files,
        }
    }

    /// A shader whose text is made at run time (OpenColorIO's WGSL for one colour transform,
    /// wrapped in a node's entry point): interned by its text, so each distinct text is one
    /// `Shader` for the life of the process, with the stem `<prefix>/<hash of the text>` under
    /// which its pipelines are cached like any other's. It has no `#import` lines. Pipelines
    /// made up front in a later process skip it (its text is not known before its node runs).
    pub fn runtime(prefix: &str, text: &str) -> Shader {
        use std::hash::{Hash, Hasher};
        static INTERNED: OnceLock<Mutex<HashMap<String, Shader>>> = OnceLock::new();
        let interned = INTERNED.get_or_init(Default::default);
        let mut interned = interned.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(s) = interned.get(text) {
            return *s;
        }
        let mut h = std::collections::hash_map::DefaultHasher::new();
        text.hash(&mut h);
        // Two texts whose hashes collide still get two stems (two pipelines).
        let mut name = format!("{prefix}/{:016x}", h.finish());
        while interned.values().any(|s| s.stem == name) {
            name.push('+');
        }
        let stem: &'static str = Box::leak(name.into_boxed_str());
        let source: &'static str = Box::leak(text.to_string().into_boxed_str());
        let shader = Shader::new(stem, source, &[]);
        interned.insert(text.to_string(), shader);
        shader
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
        let text: &'static str =
            Box::leak(compose(self.stem, self.source, self.files)?.into_boxed_str());
        done.insert(self.stem, text);
        Ok(text)
    }
}

/// Compose `source` (the text of `shaders/<name>.wgsl`), its imports looked up in `files`: see
/// the module doc.
pub fn compose(name: &str, source: &str, files: ShaderFiles) -> Result<String, String> {
    let mut seen = BTreeSet::new();
    seen.insert(name.to_string());
    let mut out = String::with_capacity(source.len() * 2);
    expand(name, source, files, &mut seen, &mut Vec::new(), &mut out)?;
    Ok(out)
}

fn expand(
    name: &str,
    source: &str,
    files: ShaderFiles,
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
        let text = files
            .iter()
            .find(|(file, _)| *file == path)
            .map(|(_, text)| *text)
            .ok_or_else(|| {
                format!("shaders/{name}.wgsl: `#import {path}`: there is no shaders/{path}.wgsl")
            })?;
        out.push_str(&format!(
            "// ---- #import {path} (shaders/{path}.wgsl) ----\n"
        ));
        expand(path, text, files, seen, stack, out)?;
        out.push_str(&format!("// ---- end of {path} ----\n"));
    }
    stack.pop();
    Ok(())
}
