//! Embeds every `shaders/**/*.wgsl` file in a table (`$OUT_DIR/shader_files.rs`), so that a
//! shader's `#import name` lines can be resolved at run time by the engine's `Shader::wgsl`
//! without the engine holding any shader (`crate::shader` hands each shader this table).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn walk(dir: &Path, root: &Path, out: &mut Vec<(String, PathBuf)>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
    paths.sort();
    for path in paths {
        if path.is_dir() {
            walk(&path, root, out);
        } else if path.extension().and_then(|e| e.to_str()) == Some("wgsl") {
            let name = path
                .strip_prefix(root)
                .unwrap_or(&path)
                .with_extension("")
                .to_string_lossy()
                .replace('\\', "/");
            out.push((name, path));
        }
    }
}

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default());
    // shaders/ sits beside nodes/ at the top of the repository.
    let root = manifest.join("..").join("shaders");
    println!("cargo:rerun-if-changed=../shaders");
    let mut files = Vec::new();
    walk(&root, &root, &mut files);
    let mut text = String::from(
        "/// Every `shaders/**/*.wgsl` file: (path under `shaders/` without `.wgsl`, text).\n\
         pub const SHADER_FILES: tyndall_engine::gpu::ShaderFiles = &[\n",
    );
    for (name, path) in &files {
        println!("cargo:rerun-if-changed={}", path.display());
        let _ = writeln!(
            text,
            "    ({name:?}, include_str!({:?})),",
            path.display().to_string()
        );
    }
    text.push_str("];\n");
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap_or_default()).join("shader_files.rs");
    if let Err(e) = std::fs::write(&out, text) {
        panic!("cannot write {}: {e}", out.display());
    }
}
