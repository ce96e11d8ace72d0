//! Every shader file validates with naga once its `#import`s are composed; every node's shaders
//! lie under its stem (`shaders/<stem>.wgsl` or `shaders/<stem>/…`, beside `nodes/<stem>.rs` or
//! `nodes/<stem>/mod.rs`); no shader file is unused; every uniform struct's Rust layout matches
//! its WGSL declaration.

use std::path::{Path, PathBuf};

use tyndall::gpu::{check_uniform_layout, Shader, UniformLayout};
use tyndall::nodes::{shader_files, SHADER_FILES};

/// `#import` composition against the techniques' shader table.
fn compose(name: &str, source: &str) -> Result<String, String> {
    tyndall::gpu::compose(name, source, SHADER_FILES)
}

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Every `*.wgsl` below `dir`, as (path under `shaders/` without `.wgsl`, file).
fn wgsl_files(dir: &Path, out: &mut Vec<(String, PathBuf)>) {
    for entry in std::fs::read_dir(dir).expect("shaders/") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            wgsl_files(&path, out);
        } else if path.extension().and_then(|e| e.to_str()) == Some("wgsl") {
            let name = path
                .strip_prefix(root().join("shaders"))
                .expect("under shaders/")
                .with_extension("")
                .to_string_lossy()
                .replace('\\', "/");
            out.push((name, path));
        }
    }
}

fn all_wgsl() -> Vec<(String, PathBuf)> {
    let mut files = Vec::new();
    wgsl_files(&root().join("shaders"), &mut files);
    files.sort();
    files
}

fn validate(name: &str, src: &str) {
    let module = naga::front::wgsl::parse_str(src)
        .unwrap_or_else(|e| panic!("shaders/{name}.wgsl (composed): {}", e.emit_to_string(src)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("shaders/{name}.wgsl (composed): {e:?}"));
}

#[test]
fn every_shader_file_validates_with_naga() {
    let files = all_wgsl();
    for (name, path) in &files {
        let src = std::fs::read_to_string(path).expect("read");
        let composed = compose(name, &src).unwrap_or_else(|e| panic!("{e}"));
        validate(name, &composed);
    }
    assert!(files.len() >= 5, "only {} shaders found", files.len());
    // The build-time table `#import` resolves against holds exactly the files on disk.
    let embedded: Vec<&str> = shader_files().collect();
    let on_disk: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(embedded, on_disk, "shader table out of date: rebuild");
}

#[test]
fn every_shader_validates_with_its_volume_levels_written_through_row_buffers() {
    // On wgpu's GL backend 3D storage levels are storage buffers (src/engine/gpu/volume.rs rewrites
    // the shader): every shader that writes one must validate in that form too, on any machine.
    let mut rewritten = 0;
    for (name, path) in &all_wgsl() {
        let src = std::fs::read_to_string(path).expect("read");
        let composed = compose(name, &src).unwrap_or_else(|e| panic!("{e}"));
        let rows = tyndall::gpu::rows_source(&composed);
        if rows != composed {
            assert!(!rows.contains("texture_storage_3d"), "{name}: {rows}");
            validate(name, &rows);
            rewritten += 1;
        }
    }
    assert!(rewritten >= 3, "only {rewritten} shaders write volumes");
    // A use the rewrite does not know is left for naga to reject, not silently dropped.
    let odd = "@group(0) @binding(1) var v: texture_storage_3d<r32float, write>;\n\
               @compute @workgroup_size(1) fn main() { textureStore(v, vec3<i32>(0), vec4<f32>(1.0)); }";
    let out = tyndall::gpu::rows_source(odd);
    assert!(naga::front::wgsl::parse_str(&out)
        .ok()
        .and_then(|m| naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all()
        )
        .validate(&m)
        .ok())
        .is_none());
}

#[test]
fn imports_resolve_once_and_fail_clearly() {
    // Imported twice (directly and through another file): included once.
    let twice = compose("t", "#import lib/medium\n#import lib/medium\nfn f() {}").expect("ok");
    assert_eq!(
        twice.matches("---- #import lib/medium ").count(),
        1,
        "{twice}"
    );
    let e = compose("t", "#import lib/no_such_file\n").expect_err("unknown import");
    assert!(e.contains("no shaders/lib/no_such_file.wgsl"), "{e}");
}

/// Node kinds that run no shader pass: `Scene` only uploads vertex and index buffers, `LightMap`
/// only uploads (or passes on) a texture and its light matrices.
const NO_GPU_PASS: &[&str] = &["LightMap", "Scene"];

/// Node kinds whose pass is a runtime shader (`Shader::runtime`): OpenColorIO writes its WGSL
/// for the transform the parameters name (`nodes/algorithms/ocio.rs`), so there is no file to
/// list; `tests/nodes/colour.rs` runs them on both backends.
const RUNTIME_SHADER: &[&str] = &["ColourSpace", "DisplayView"];

/// The stem of the file under `nodes/` that declares `kind` (`kind: "Blur"` in its
/// `NodeSchema`, or for a family of kinds sharing one implementation the name as a literal):
/// `blur` for `nodes/blur.rs`, `phase` for `nodes/phase/mod.rs`.
fn declaring_stem(kind: &str) -> Option<String> {
    let mut files = Vec::new();
    rust_files(&root().join("nodes"), &mut files);
    let texts: Vec<(PathBuf, String)> = files
        .into_iter()
        .filter_map(|p| std::fs::read_to_string(&p).ok().map(|s| (p, s)))
        .collect();
    let schema = format!("kind: \"{kind}\"");
    let literal = format!("\"{kind}\"");
    texts
        .iter()
        .find(|(_, s)| s.contains(&schema))
        .or_else(|| texts.iter().find(|(_, s)| s.contains(&literal)))
        .map(|(p, _)| p)
        .and_then(|p| p.strip_prefix(root().join("nodes")).ok())
        .and_then(|rel| rel.components().next())
        .and_then(|c| c.as_os_str().to_str())
        .map(|s| s.trim_end_matches(".rs").to_string())
}

/// Passes several kinds dispatch (`nodes/algorithms/`, `shaders/algorithms/`): any kind may
/// list them; every other shader of a kind is under the kind's own stem.
const SHARED: &str = "algorithms";

#[test]
fn every_node_has_shaders_and_source_under_one_stem() {
    let registry = tyndall::nodes::registry();
    for kind in registry.iter() {
        let name = kind.schema().kind;
        let stem = declaring_stem(name)
            .unwrap_or_else(|| panic!("{name}: no file under nodes/ declares it"));
        assert_ne!(
            stem, SHARED,
            "{name} is declared in nodes/{SHARED}/, which holds no node"
        );
        let shaders = kind.shaders();
        for on_demand in kind.decl().on_demand {
            assert!(
                shaders.iter().any(|s| s.stem == on_demand.stem),
                "{name}: on-demand shader {} is not among its shaders",
                on_demand.stem
            );
        }
        if shaders.is_empty() {
            // Nodes that only upload data (no GPU pass) have no shader; keep that list explicit.
            assert!(
                NO_GPU_PASS.contains(&name) || RUNTIME_SHADER.contains(&name),
                "{name} has no shader"
            );
            continue;
        }
        for shader in shaders {
            assert!(
                shader.node_stem() == stem || shader.node_stem() == SHARED,
                "{name}: {} is neither under {stem} nor under {SHARED}",
                shader.stem
            );
            let wgsl = root().join("shaders").join(format!("{}.wgsl", shader.stem));
            let on_disk = std::fs::read_to_string(&wgsl)
                .unwrap_or_else(|_| panic!("{name}: {} missing", wgsl.display()));
            assert_eq!(
                on_disk,
                shader.source,
                "{name}: embedded shader differs from {}",
                wgsl.display()
            );
        }
    }
}

/// No technique uses another's module: a node reaches another only through the values on its
/// ports, and what several share lives in `nodes/algorithms/` (ARCHITECTURE.md). A file of stem
/// `x` may name `crate::x`, `crate::algorithms`, `crate::util` and the crate root's
/// `crate::shader`; `super::` from a stem's top file is the crate root.
#[test]
fn no_technique_uses_another_techniques_module() {
    let stems: Vec<String> = std::fs::read_dir(root().join("nodes"))
        .expect("nodes/")
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let p = e.path();
            let name = p.file_name()?.to_str()?.to_string();
            if p.is_dir() {
                Some(name)
            } else {
                name.strip_suffix(".rs").map(str::to_string)
            }
        })
        .filter(|s| !["lib", "build", "util", SHARED].contains(&s.as_str()))
        .collect();
    assert!(stems.len() > 25, "only {} stems", stems.len());
    let mut files = Vec::new();
    rust_files(&root().join("nodes"), &mut files);
    let mut found = Vec::new();
    for path in files {
        let rel = path
            .strip_prefix(root().join("nodes"))
            .expect("under nodes/");
        let own = rel
            .components()
            .next()
            .and_then(|c| c.as_os_str().to_str())
            .map(|s| s.trim_end_matches(".rs").to_string())
            .unwrap_or_default();
        let top = rel.components().count() == 1;
        let src = std::fs::read_to_string(&path).expect("read");
        for (n, line) in src.lines().enumerate() {
            for other in stems.iter().filter(|s| **s != own) {
                let mut doors = vec![format!("crate::{other}::"), format!("crate::{other};")];
                if top {
                    doors.push(format!("super::{other}::"));
                } else {
                    doors.push(format!("super::super::{other}::"));
                }
                if doors.iter().any(|d| line.contains(d.as_str())) {
                    found.push(format!("{}:{}: {}", rel.display(), n + 1, line.trim()));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "techniques using another's module:\n{}",
        found.join("\n")
    );
}

/// Every shader file is a node's shader, imported by one, part of the shared library, or the
/// engine's own display pass (`tyndall::display`, which the editor and the benchmarks run).
#[test]
fn no_shader_file_is_unused() {
    let registry = tyndall::nodes::registry();
    let shaders: Vec<Shader> = registry
        .iter()
        .flat_map(|k| k.shaders().iter().copied())
        .collect();
    let composed: Vec<&str> = shaders
        .iter()
        .map(|s| s.wgsl().expect("composes"))
        .collect();
    for (name, _) in all_wgsl() {
        if name.starts_with("lib/") {
            continue;
        }
        let used = name == tyndall::display::STEM
            || shaders.iter().any(|s| s.stem == name)
            || composed
                .iter()
                .any(|c| c.contains(&format!("---- #import {name} ")));
        assert!(
            used,
            "shaders/{name}.wgsl is no node's shader and imported by none"
        );
    }
}

/// A uniform layout is checked against every shader of its node that declares the struct (at
/// least one must).
#[test]
fn every_uniform_struct_matches_its_wgsl() {
    let registry = tyndall::nodes::registry();
    let mut checked = 0;
    for kind in registry.iter() {
        for layout in kind.uniform_layouts() {
            let mut found = false;
            for shader in kind.shaders() {
                let wgsl = shader.wgsl().expect("composes");
                if !wgsl.contains(&format!("struct {} {{", layout.wgsl_struct)) {
                    continue;
                }
                found = true;
                check_uniform_layout(wgsl, layout).unwrap_or_else(|e| {
                    panic!("{} ({}.wgsl): {e}", kind.schema().kind, shader.stem)
                });
            }
            assert!(
                found,
                "{}: no shader declares struct {}",
                kind.schema().kind,
                layout.wgsl_struct
            );
            checked += 1;
        }
    }
    assert!(checked >= 4, "only {checked} uniform structs checked");
}

#[test]
fn layout_check_catches_drift() {
    let wgsl = "struct Params { a: f32, b: vec4<f32> }\n@group(0) @binding(0) var<uniform> P: Params;\n@compute @workgroup_size(1) fn main() { _ = P.a; }";
    // Rust side packed as if b followed a directly: WGSL aligns vec4 to 16.
    let wrong = UniformLayout {
        wgsl_struct: "Params",
        size: 20,
        fields: &[("a", 0), ("b", 4)],
    };
    assert!(check_uniform_layout(wgsl, &wrong).is_err());
    let renamed = UniformLayout {
        wgsl_struct: "Params",
        size: 32,
        fields: &[("a", 0), ("c", 16)],
    };
    assert!(check_uniform_layout(wgsl, &renamed).is_err());
    let right = UniformLayout {
        wgsl_struct: "Params",
        size: 32,
        fields: &[("a", 0), ("b", 16)],
    };
    assert!(check_uniform_layout(wgsl, &right).is_ok());
}

// Structs declared with `uniforms!`, as nodes declare theirs: the checked field list is the
// struct's own, so a field added on the Rust side alone cannot be left out of the check.
tyndall::uniforms! {
    /// Matches `DRIFT_WGSL`'s `Params`.
    #[allow(dead_code)]
    struct Same as "Params" {
        a: f32,
        b: u32,
        _pad0: u32,
        _pad1: u32,
    }
}
tyndall::uniforms! {
    /// `Same` with a field added in Rust only, in what was padding (the size is unchanged, so
    /// only the field list can tell).
    #[allow(dead_code)]
    struct RustOnly as "Params" {
        a: f32,
        b: u32,
        c: f32,
        _pad1: u32,
    }
}
tyndall::uniforms! {
    /// `Same` with a field added in Rust only, at the end (within the same 16-byte padding).
    #[allow(dead_code)]
    struct RustTail as "Params" {
        a: f32,
        b: u32,
        _pad0: u32,
        _pad1: u32,
        c: f32,
    }
}

const DRIFT_WGSL: &str = "struct Params { a: f32, b: u32, _pad0: u32, _pad1: u32 }\n@group(0) @binding(0) var<uniform> P: Params;\n@compute @workgroup_size(1) fn main() { _ = P.a; }";

#[test]
fn layout_check_catches_a_field_added_on_one_side_only() {
    assert!(check_uniform_layout(DRIFT_WGSL, &Same::LAYOUT).is_ok());
    let e = check_uniform_layout(DRIFT_WGSL, &RustOnly::LAYOUT).expect_err("Rust-only field");
    assert!(e.contains('c'), "{e}");
    assert!(check_uniform_layout(DRIFT_WGSL, &RustTail::LAYOUT).is_err());
    // A field added to the WGSL struct only, in its padding (size unchanged).
    let wgsl_only = DRIFT_WGSL.replace("_pad0: u32", "c: f32");
    assert!(check_uniform_layout(&wgsl_only, &Same::LAYOUT).is_err());
    // … or at its end.
    let wgsl_tail = DRIFT_WGSL.replace("_pad1: u32 }", "_pad1: u32, c: f32 }");
    assert!(check_uniform_layout(&wgsl_tail, &Same::LAYOUT).is_err());
}

/// Every uniform struct a node file declares is in a kind's declaration, so the layout check
/// above sees it (two MinMax structs of SingleScattering once were not).
#[test]
fn every_declared_uniform_struct_is_checked() {
    let registry = tyndall::nodes::registry();
    let mut declared = 0;
    let mut files = Vec::new();
    rust_files(&root().join("nodes"), &mut files);
    for path in files {
        let src = std::fs::read_to_string(&path).expect("read");
        assert!(
            !src.contains("#[repr(C)]"),
            "{}: declare uniform structs with tyndall::uniforms! so their layout is checked",
            path.display()
        );
        // The node's stem: the file's (`nodes/blur.rs`) or its folder's (`nodes/x/params.rs`).
        let rel = path
            .strip_prefix(root().join("nodes"))
            .expect("under nodes/");
        let stem = rel
            .components()
            .next()
            .and_then(|c| c.as_os_str().to_str())
            .map(|s| s.trim_end_matches(".rs").to_string())
            .unwrap_or_default();
        for block in src.split("tyndall_engine::uniforms! {").skip(1) {
            let name = block
                .split(" as \"")
                .nth(1)
                .and_then(|s| s.split('"').next())
                .expect("uniforms! block names its WGSL struct");
            let listed = registry.iter().any(|k| {
                k.shaders().iter().any(|s| s.node_stem() == stem)
                    && k.uniform_layouts().iter().any(|l| l.wgsl_struct == name)
            });
            assert!(
                listed,
                "{}: struct {name} is in no kind's `uniforms`",
                path.display()
            );
            declared += 1;
        }
    }
    assert!(declared >= 16, "only {declared} uniform structs found");
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("nodes/") {
        let path = entry.expect("entry").path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().and_then(|e| e.to_str()) == Some("rs") {
            out.push(path);
        }
    }
}

/// A technique reads its parameters as its declared struct (`Params::from_ctx`,
/// `Params::from_params`), never one by name: the engine's by-name readers are private to it,
/// and this test keeps the other doors shut (the reader the `params!` macro makes, the trait
/// it reads through, the raw parameter map).
#[test]
fn no_technique_reads_a_parameter_by_name() {
    let doors = [
        "ParamReader",
        "for_declared(",
        "from_param(",
        "FromParam",
        "params.get(",
        "params[",
    ];
    let mut files = Vec::new();
    rust_files(&root().join("nodes"), &mut files);
    assert!(files.len() > 40, "only {} files under nodes/", files.len());
    let mut found = Vec::new();
    for path in files {
        let src = std::fs::read_to_string(&path).expect("read");
        for (n, line) in src.lines().enumerate() {
            if let Some(d) = doors.iter().find(|d| line.contains(**d)) {
                found.push(format!(
                    "{}:{}: {d}: {}",
                    path.display(),
                    n + 1,
                    line.trim()
                ));
            }
        }
    }
    assert!(
        found.is_empty(),
        "by-name parameter reads in nodes/:\n{}",
        found.join("\n")
    );
}

/// `src/` knows no technique: no string literal in it equals a node kind (ARCHITECTURE.md's
/// first invariant). A kind's name may appear in prose (a doc comment, a longer message), and
/// port type names that a kind shares (`ShadowMap`, `LightMap`, `Scene`) are port types.
#[test]
fn no_string_literal_in_src_is_a_node_kind() {
    let registry = tyndall::nodes::registry();
    let port_types: Vec<&str> = tyndall::graph::PortType::ALL
        .iter()
        .map(|t| t.name())
        .collect();
    let kinds: Vec<&str> = registry
        .iter()
        .map(|k| k.schema().kind)
        .filter(|k| !port_types.contains(k))
        .collect();
    assert!(kinds.len() > 30, "only {} kinds to look for", kinds.len());
    let mut files = Vec::new();
    rust_files(&root().join("src"), &mut files);
    let mut found = Vec::new();
    for path in files {
        let src = std::fs::read_to_string(&path).expect("read");
        for (n, line) in src.lines().enumerate() {
            let code = line.trim_start();
            if code.starts_with("//") {
                continue;
            }
            // Every "…" literal on the line (escapes skipped; raw strings are not used for
            // kinds).
            let mut rest = code;
            while let Some(start) = rest.find('"') {
                let body = &rest[start + 1..];
                let mut end = None;
                let mut escaped = false;
                for (i, c) in body.char_indices() {
                    match c {
                        '\\' if !escaped => escaped = true,
                        '"' if !escaped => {
                            end = Some(i);
                            break;
                        }
                        _ => escaped = false,
                    }
                }
                let Some(end) = end else { break };
                let literal = &body[..end];
                if kinds.contains(&literal) {
                    found.push(format!("{}:{}: \"{literal}\"", path.display(), n + 1));
                }
                rest = &body[end + 1..];
            }
        }
    }
    assert!(
        found.is_empty(),
        "node kinds named in src/:\n{}",
        found.join("\n")
    );
}
