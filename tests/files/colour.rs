//! Colour management in files and graphs (issue #45, items 2 and 4): a graph's working space,
//! `ImageInput.colourspace` and its file rules, glTF colours converted to the working space,
//! PNGs written from another working space, and the EXR `chromaticities` attribute — checked
//! against published matrices, not only against OpenColorIO.

use std::path::Path;

use crate::common;

use tyndall::io::Raster;

/// Published linear Rec.709 → ACEScg (AP1) matrix, Bradford D65 → D60 (ACES documentation;
/// rows), and its inverse direction ACEScg → Rec.709.
const REC709_TO_AP1: [[f32; 3]; 3] = [
    [0.61310, 0.33952, 0.04737],
    [0.07019, 0.91636, 0.01345],
    [0.02062, 0.10958, 0.86980],
];
const AP1_TO_REC709: [[f32; 3]; 3] = [
    [1.70505, -0.62179, -0.08326],
    [-0.13026, 1.14080, -0.01055],
    [-0.02400, -0.12897, 1.15297],
];

fn mul(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

/// A graph of `nodes` (RON entries) and `edges`, in working space `space` (none: default).
fn graph_text(space: Option<&str>, nodes: &str, edges: &str) -> String {
    let colour = space
        .map(|s| format!("colour: (working_space: \"{s}\"),"))
        .unwrap_or_default();
    format!("(version: 3, {colour} nodes: {{ {nodes} }}, edges: [{edges}])")
}

/// Evaluate `text`'s sinks, or `ports`, in `dir`.
fn evaluate(
    text: &str,
    dir: &Path,
    ports: &[(&str, &str)],
) -> Result<common::Outputs, tyndall::eval::EvalError> {
    let gpu = common::gpu().expect("gpu");
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let g = tyndall::graph::load_str(text, &dir.join("g.ron"), registry.catalog()).expect("graph");
    let mut ev = tyndall::eval::Evaluator::new(registry, gpu.clone());
    let mut targets = ev.sinks(&g);
    targets.extend(
        ports
            .iter()
            .map(|(n, p)| tyndall::eval::Target::Port(n.to_string(), p.to_string())),
    );
    let opts = tyndall::eval::EvalOptions {
        size: (4, 2),
        ..Default::default()
    };
    ev.evaluate(&g, &targets, &opts)
        .map(|r| common::Outputs::new(gpu, r.outputs))
}

/// Eight colours: black, grey, white, primaries, two mixed (8-bit codes, so a PNG holds them
/// exactly).
fn codes() -> Raster {
    let px: [[u8; 3]; 8] = [
        [0, 0, 0],
        [128, 128, 128],
        [255, 255, 255],
        [255, 0, 0],
        [0, 255, 0],
        [0, 0, 255],
        [230, 140, 40],
        [20, 90, 200],
    ];
    let mut r = Raster::new(4, 2, 4, 1.0);
    for (i, p) in px.iter().enumerate() {
        for (c, v) in p.iter().enumerate() {
            r.data[i * 4 + c] = f32::from(*v) / 255.0;
        }
    }
    r
}

/// A graph keeps `colour: (working_space: …)` through saving; one without it saves without it;
/// a working space the config does not have fails the evaluation naming it and listing the
/// config's spaces.
#[test]
fn a_graph_keeps_its_working_space() {
    let registry = tyndall::nodes::registry();
    let nodes = r#""c": (kind: "Constant")"#;
    let text = graph_text(Some("ACEScg"), nodes, "");
    let g = tyndall::graph::load_str(&text, Path::new("g.ron"), registry.catalog()).expect("load");
    assert_eq!(g.working_space(), "ACEScg");
    let saved = tyndall::graph::save_string(&g);
    assert!(saved.contains("working_space: \"ACEScg\""), "{saved}");
    let again =
        tyndall::graph::load_str(&saved, Path::new("g.ron"), registry.catalog()).expect("reload");
    assert_eq!(again, g);
    let plain = graph_text(None, nodes, "");
    let g = tyndall::graph::load_str(&plain, Path::new("g.ron"), registry.catalog()).expect("load");
    assert_eq!(g.working_space(), "Linear Rec.709 (sRGB)");
    assert!(!tyndall::graph::save_string(&g).contains("colour"));
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let bad = graph_text(Some("Nope"), nodes, "");
    let e = evaluate(&bad, dir.path(), &[("c", "image")])
        .err()
        .expect("a working space the config lacks")
        .to_string();
    assert!(e.contains("`Nope`") && e.contains("ACEScg"), "{e}");
}

/// `ImageInput` converts a file to the working space: a PNG by the file rule (sRGB-encoded
/// Rec.709) into ACEScg equals decoding the sRGB curve and the published Rec.709 → AP1 matrix;
/// an EXR named `colourspace = ACEScg` read into the default working space equals the published
/// AP1 → Rec.709 matrix. 2e-3: the published matrices are rounded to five digits (OpenColorIO's
/// own GPU pass agrees with its CPU within 1e-5 here). In the default working space with no
/// `colourspace` the PNG reads exactly as before (sRGB decoding), and `srgb = false` is data.
#[test]
fn image_input_converts_files_to_the_working_space() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("codes.png");
    let exr = dir.path().join("codes.exr");
    let src = codes();
    tyndall::io::write_image(&png, &src, tyndall::io::Precision::U8, false).expect("png");
    tyndall::io::write_image(&exr, &src, tyndall::io::Precision::F32, false).expect("exr");
    let read = |space: Option<&str>, path: &Path, params: &str| -> Raster {
        let nodes = format!(
            r#""in": (kind: "ImageInput", params: {{"path": "{}", {params}}})"#,
            path.display()
        );
        evaluate(
            &graph_text(space, &nodes, ""),
            dir.path(),
            &[("in", "image")],
        )
        .expect("evaluate")
        .read("in", "image")
    };
    let close = |got: &Raster, want: &dyn Fn([f32; 3]) -> [f32; 3], tol: f32, what: &str| {
        for i in 0..8 {
            let w = want([src.data[i * 4], src.data[i * 4 + 1], src.data[i * 4 + 2]]);
            for (c, w) in w.iter().enumerate() {
                let g = got.data[i * 4 + c];
                assert!(
                    (g - w).abs() <= tol * w.abs().max(1.0),
                    "{what}: pixel {i} channel {c}: {g} vs {w}"
                );
            }
            assert_eq!(got.data[i * 4 + 3], 1.0, "{what}: alpha");
        }
    };
    let decode = |v: [f32; 3]| v.map(tyndall::io::srgb_to_linear);
    close(&read(None, &png, ""), &decode, 0.0, "PNG, default space");
    close(
        &read(Some("ACEScg"), &png, ""),
        &|v| mul(&REC709_TO_AP1, decode(v)),
        2e-3,
        "PNG into ACEScg",
    );
    close(
        &read(None, &exr, r#""colourspace": "ACEScg""#),
        &|v| mul(&AP1_TO_REC709, v),
        2e-3,
        "ACEScg EXR into Rec.709",
    );
    close(
        &read(Some("ACEScg"), &png, r#""srgb": false"#),
        &|v| v,
        0.0,
        "data",
    );
    // A name the config lacks is an error on the parameter, listing the config's spaces.
    let nodes = format!(
        r#""in": (kind: "ImageInput", params: {{"path": "{}", "colourspace": "Nope"}})"#,
        png.display()
    );
    let e = evaluate(
        &graph_text(None, &nodes, ""),
        dir.path(),
        &[("in", "image")],
    )
    .err()
    .expect("unknown colour space")
    .to_string();
    assert!(e.contains("colourspace") && e.contains("ACEScg"), "{e}");
}

/// In ACEScg a PNG read and written again comes back as it was (the writer converts to linear
/// Rec.709 before the sRGB encoding; one 8-bit step: rounding), and the EXR carries ACEScg's
/// `chromaticities` — none in the default working space, as before.
#[test]
fn files_written_from_another_working_space() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("codes.png");
    let src = codes();
    tyndall::io::write_image(&png, &src, tyndall::io::Precision::U8, false).expect("png");
    for space in [Some("ACEScg"), None] {
        let nodes = format!(
            r#""in": (kind: "ImageInput", params: {{"path": "{}"}}),
               "png": (kind: "ImageOutput", params: {{"path": "{}"}}),
               "exr": (kind: "ImageOutput", params: {{"path": "{}"}}),
               "aov": (kind: "AovOutput", params: {{"path": "{}"}})"#,
            png.display(),
            dir.path().join("out.png").display(),
            dir.path().join("out.exr").display(),
            dir.path().join("aov.exr").display(),
        );
        let edges =
            r#"("in.image", "png.image"), ("in.image", "exr.image"), ("in.image", "aov.rgba")"#;
        evaluate(&graph_text(space, &nodes, edges), dir.path(), &[]).expect("render");
        let back = tyndall::io::read_image(&dir.path().join("out.png"), false).expect("png");
        let steps = back
            .data
            .iter()
            .zip(&src.data)
            .map(|(a, b)| ((a - b) * 255.0).abs().round() as i32)
            .max()
            .unwrap_or(0);
        assert!(steps <= 1, "{space:?}: {steps} 8-bit steps");
        let want = tyndall::colour::ColourCtx {
            config: String::new(),
            working_space: space.unwrap_or_default().to_string(),
        }
        .chromaticities()
        .expect("chromaticities");
        assert_eq!(space.is_some(), want.is_some());
        for file in ["out.exr", "aov.exr"] {
            let meta =
                exr::meta::MetaData::read_from_file(dir.path().join(file), false).expect("header");
            let got = meta.headers[0].shared_attributes.chromaticities.map(|c| {
                [
                    c.red.0, c.red.1, c.green.0, c.green.1, c.blue.0, c.blue.1, c.white.0,
                    c.white.1,
                ]
            });
            assert_eq!(got, want, "{file} in {space:?}");
        }
    }
}

/// glTF base and light colours (linear Rec.709) come into an ACEScg graph converted: the
/// published Rec.709 → AP1 matrix on the file's values (2e-3, its rounding); the built-in
/// scenes' colours are the graph's own and stay.
#[test]
fn gltf_colours_are_converted_to_the_working_space() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let file = format!("{}/tests/fixtures/scene.gltf", env!("CARGO_MANIFEST_DIR"));
    let scene = |space: Option<&str>, path: &str| {
        let nodes = format!(r#""s": (kind: "Scene", params: {{"path": "{path}"}})"#);
        let out = evaluate(
            &graph_text(space, &nodes, ""),
            dir.path(),
            &[("s", "scene")],
        )
        .expect("evaluate");
        out.get("s", "scene")
            .payload::<tyndall::scene::GpuScene>()
            .expect("scene")
            .scene
            .clone()
    };
    let plain = scene(None, &file);
    let aces = scene(Some("ACEScg"), &file);
    let near = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 2e-3);
    for (p, a) in plain.objects.iter().zip(&aces.objects) {
        let rgb = [p.colour[0], p.colour[1], p.colour[2]];
        let got = [a.colour[0], a.colour[1], a.colour[2]];
        assert!(near(got, mul(&REC709_TO_AP1, rgb)), "{rgb:?} → {got:?}");
        assert_eq!(a.colour[3], p.colour[3]);
    }
    assert_eq!(plain.find_sun("").expect("sun").colour, [1.0, 0.9, 0.8]);
    assert!(near(
        aces.find_sun("").expect("sun").colour,
        mul(&REC709_TO_AP1, plain.find_sun("").expect("sun").colour)
    ));
    assert!(plain.objects.iter().any(|o| o.colour[0] != o.colour[2]));
    // A built-in scene: no conversion.
    let a = scene(Some("ACEScg"), "");
    let b = scene(None, "");
    assert_eq!(
        a.find_sun("").expect("sun").colour,
        b.find_sun("").expect("sun").colour
    );
    assert_eq!(a.objects[0].colour, b.objects[0].colour);
}
