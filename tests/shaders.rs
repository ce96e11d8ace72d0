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

/// Node kinds that run no shader pass: `Scene` only uploads vertex and index buffers.
const NO_GPU_PASS: &[&str] = &["Scene"];

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
            check_uniform_layout(shader.source, &layout)
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
        fields: vec![("a", 0), ("b", 4)],
    };
    assert!(check_uniform_layout(wgsl, &wrong).is_err());
    let renamed = UniformLayout {
        wgsl_struct: "Params",
        size: 32,
        fields: vec![("a", 0), ("c", 16)],
    };
    assert!(check_uniform_layout(wgsl, &renamed).is_err());
    let right = UniformLayout {
        wgsl_struct: "Params",
        size: 32,
        fields: vec![("a", 0), ("b", 16)],
    };
    assert!(check_uniform_layout(wgsl, &right).is_ok());
}
