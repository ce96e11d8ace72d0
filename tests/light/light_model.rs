//! One model of the scene's lights (issue #60, item 3): a scene's lights are all it has. A
//! built-in scene has its sun as a directional light named `sun`; a glTF file with only a spot
//! has no sun, and the nodes that need one (`Sky`) or a light's screen position (`RadialBlur`)
//! name the light they use and refuse, naming the scene's lights, one the scene lacks.

use std::path::Path;
use std::sync::Arc;

use tyndall::eval::{EvalOptions, Evaluator, Target};

fn fixture(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(path)
        .display()
        .to_string()
}

#[test]
fn a_file_with_only_a_spot_has_no_sun_and_a_builtin_has_one() {
    let spot =
        tyndall::scene::load_gltf(Path::new(&fixture("tests/fixtures/cycles_spot/scene.gltf")))
            .expect("spot scene");
    assert_eq!(spot.lights.len(), 1, "{:?}", spot.lights);
    assert_eq!(spot.lights[0].type_name(), "spot");
    let err = spot.find_sun("").expect_err("no directional light");
    assert!(
        err.contains("no directional light") && err.contains("0 'spot' (spot)"),
        "{err}"
    );
    let err = spot.find_sun("spot").expect_err("a spot is not a sun");
    assert!(err.contains("not directional"), "{err}");
    let err = spot.find_light("key").expect_err("no such light");
    assert!(
        err.contains("no light 'key'") && err.contains("'spot'"),
        "{err}"
    );

    for name in tyndall::scene::BUILTIN_SCENES {
        let scene = tyndall::scene::builtin(name, 1).expect("built-in");
        let names: Vec<&str> = scene.lights.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["sun"], "{name}");
        assert!(scene.find_sun("").is_ok() && scene.find_sun("sun").is_ok());
    }
}

#[test]
fn a_file_without_lights_gets_the_default_sun() {
    // tests/fixtures/scene.gltf without its sun (KHR_lights_punctual, in the file's and the sun
    // node's extensions): a file with no lights.
    let text = std::fs::read_to_string(fixture("tests/fixtures/scene.gltf")).expect("fixture");
    let mut json: serde_json::Value = serde_json::from_str(&text).expect("json");
    json.as_object_mut().expect("object").remove("extensions");
    for node in json["nodes"].as_array_mut().expect("nodes") {
        node.as_object_mut().expect("node").remove("extensions");
    }
    json.as_object_mut()
        .expect("object")
        .remove("extensionsUsed");
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("unlit.gltf");
    std::fs::write(&path, json.to_string()).expect("write");
    let scene = tyndall::scene::load_gltf(&path).expect("unlit scene");
    let names: Vec<&str> = scene.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, [tyndall::scene::DEFAULT_SUN]);
    let sun = scene.find_sun("").expect("the default sun");
    assert_eq!(
        (sun.azimuth, sun.elevation, sun.intensity),
        (30.0, 60.0, 3.0)
    );
}

/// Sky and RadialBlur on a scene lit by a spot alone: Sky refuses (no sun), naming the spot;
/// RadialBlur converges on the spot's screen position, and refuses a light the scene lacks.
#[test]
fn sky_and_radial_blur_name_the_light_they_use() {
    let gpu = require_gpu!();
    let graph = |sky_light: &str, blur_light: &str| {
        format!(
            r#"(
    version: 2,
    nodes: {{
        "scene": (kind: "Scene", params: {{"path": "{path}"}}),
        "gbuffer": (kind: "GBuffer"),
        "sky": (kind: "Sky", params: {{"light": "{sky_light}"}}),
        "blur": (kind: "RadialBlur", params: {{"light": "{blur_light}"}}),
    }},
    edges: [
        ("scene.scene", "gbuffer.scene"),
        ("scene.scene", "sky.scene"),
        ("gbuffer.depth", "sky.depth"),
        ("gbuffer.albedo", "blur.occlusion"),
        ("scene.scene", "blur.scene"),
    ],
)"#,
            path = fixture("tests/fixtures/cycles_spot/scene.gltf"),
        )
    };
    let registry = Arc::new(tyndall::nodes::registry());
    let run = |text: &str, node: &str, port: &str| {
        let g =
            tyndall::graph::load_str(text, Path::new("g.ron"), registry.catalog()).expect("graph");
        Evaluator::new(registry.clone(), gpu.clone())
            .evaluate(
                &g,
                &[Target::Port(node.into(), port.into())],
                &EvalOptions {
                    size: (32, 18),
                    ..Default::default()
                },
            )
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    let err = run(&graph("", ""), "sky", "sky").expect_err("no sun to light the sky");
    assert!(
        err.contains("sky") && err.contains("light") && err.contains("'spot' (spot)"),
        "{err}"
    );
    run(&graph("", ""), "blur", "image").expect("the blur converges on the spot");
    run(&graph("", "spot"), "blur", "image").expect("the spot by name");
    let err = run(&graph("", "sun"), "blur", "image").expect_err("no light named sun");
    assert!(
        err.contains("no light 'sun'") && err.contains("'spot'"),
        "{err}"
    );
}
