//! Every shader validates with naga; every node's shader has its node's stem; every uniform
//! struct's Rust layout matches its WGSL declaration.

use std::path::Path;

use tyndall::gpu::{check_uniform_layout, UniformLayout};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn every_shader_file_validates_with_naga() {
    let mut count = 0;
    for entry in std::fs::read_dir(root().join("shaders")).expect("shaders/") {
        let path = entry.expect("entry").path();
        if path.extension().and_then(|e| e.to_str()) != Some("wgsl") {
            continue;
        }
        let src = std::fs::read_to_string(&path).expect("read");
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{}: {}", path.display(), e.emit_to_string(&src)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
        count += 1;
    }
    assert!(count >= 5, "only {count} shaders found");
}

/// Node kinds that run no shader pass: `Scene` only uploads vertex and index buffers, `LightMap`
/// only uploads (or passes on) a texture and its light matrices.
const NO_GPU_PASS: &[&str] = &["LightMap", "Scene"];

#[test]
fn every_node_has_a_shader_and_source_file_with_one_stem() {
    let registry = tyndall::nodes::registry();
    for kind in registry.iter() {
        let name = kind.schema().kind;
        let Some(shader) = kind.shader() else {
            // Nodes that only upload data (no GPU pass) have no shader; keep that list explicit.
            assert!(NO_GPU_PASS.contains(&name), "{name} has no shader");
            continue;
        };
        let wgsl = root().join("shaders").join(format!("{}.wgsl", shader.stem));
        let rs = root().join("nodes").join(format!("{}.rs", shader.stem));
        assert!(rs.exists(), "{name}: nodes/{}.rs missing", shader.stem);
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

#[test]
fn every_uniform_struct_matches_its_wgsl() {
    let registry = tyndall::nodes::registry();
    let mut checked = 0;
    for kind in registry.iter() {
        let Some(shader) = kind.shader() else {
            continue;
        };
        for layout in kind.uniform_layouts() {
            check_uniform_layout(shader.source, layout)
                .unwrap_or_else(|e| panic!("{} ({}.wgsl): {e}", kind.schema().kind, shader.stem));
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
    for entry in std::fs::read_dir(root().join("nodes")).expect("nodes/") {
        let path = entry.expect("entry").path();
        let src = std::fs::read_to_string(&path).expect("read");
        assert!(
            !src.contains("#[repr(C)]"),
            "{}: declare uniform structs with tyndall::uniforms! so their layout is checked",
            path.display()
        );
        let stem = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default();
        for block in src.split("crate::uniforms! {").skip(1) {
            let name = block
                .split(" as \"")
                .nth(1)
                .and_then(|s| s.split('"').next())
                .expect("uniforms! block names its WGSL struct");
            let listed = registry.iter().any(|k| {
                k.shader().is_some_and(|s| s.stem == stem)
                    && k.uniform_layouts().iter().any(|l| l.wgsl_struct == name)
            });
            assert!(
                listed,
                "nodes/{stem}.rs: struct {name} is in no kind's `uniforms`"
            );
            declared += 1;
        }
    }
    assert!(declared >= 16, "only {declared} uniform structs found");
}
