//! Colour management (issue #45): `ColourSpace` and `DisplayView` on the GPU against the `ocio`
//! crate's CPU processor, and against published values that owe nothing to it.

use crate::common;

use tyndall::graph::{ParamValue, PortType};
use tyndall::io::Raster;

/// A 4-channel test image: black, mid grey, primaries, a saturated and an HDR colour, small
/// and negative values (what scene-linear renders hold; one outside AP1), alpha varied.
fn swatches() -> Raster {
    let px: &[[f32; 4]] = &[
        [0.0, 0.0, 0.0, 1.0],
        [0.18, 0.18, 0.18, 1.0],
        [1.0, 0.0, 0.0, 1.0],
        [0.0, 1.0, 0.0, 0.5],
        [0.0, 0.0, 1.0, 1.0],
        [0.9, 0.5, 0.1, 1.0],
        [16.0, 8.0, 2.0, 1.0],
        [0.002, 0.004, 0.001, 1.0],
        [-0.5, 0.1, 2.0, 1.0],
        [1.0, 1.0, 1.0, 0.25],
        [100.0, 100.0, 100.0, 1.0],
        [0.05, 0.3, 0.02, 1.0],
    ];
    let mut r = Raster::new(4, 3, 4, 0.0);
    for (i, p) in px.iter().enumerate() {
        r.data[i * 4..i * 4 + 4].copy_from_slice(p);
    }
    r
}

/// Run `kind` with `params` on the swatches.
fn run(kind: &str, params: &[(&str, &str)]) -> Raster {
    let gpu = common::gpu().expect("gpu");
    let params: Vec<(&str, ParamValue)> = params
        .iter()
        .map(|(k, v)| (*k, ParamValue::Text(v.to_string())))
        .collect();
    let input = common::upload(&gpu, &swatches(), PortType::Image);
    common::run_node(
        &gpu,
        kind,
        &params,
        vec![("image", input)],
        &["image"],
        (4, 3),
    )
    .expect("run")
    .remove("image")
    .expect("image")
}

/// The largest difference, relative to max(1, |expected|), over the colour channels.
fn worst(got: &Raster, want: &Raster) -> f32 {
    got.data
        .iter()
        .zip(&want.data)
        .enumerate()
        .filter(|(i, _)| i % 4 != 3)
        .map(|(_, (a, b))| (a - b).abs() / b.abs().max(1.0))
        .fold(0.0, f32::max)
}

/// GPU equals the CPU processor for colour-space conversions and display / view transforms
/// (ACES 2.0 SDR with its tables, un-tone-mapped sRGB, a look), within 1e-3 of max(1, |value|):
/// the crate's own bound between its WGSL and its CPU processor (its docs: 1e-3 relative, 1e-3
/// absolute below 1), well within an 8-bit step; the GPU's `pow`/`exp` add their own
/// differences (measured: printed).
#[test]
fn gpu_equals_the_cpu_processor() {
    if common::gpu().is_none() {
        return;
    }
    use tyndall::nodes::{colour_space, display_view};
    let text = |v: &str| ParamValue::Text(v.to_string());
    let cases: [(&str, &[(&str, &str)]); 6] = [
        ("ColourSpace", &[("to", "ACEScg")]),
        ("ColourSpace", &[("to", "ACES2065-1")]),
        (
            "ColourSpace",
            &[("from", "ACEScg"), ("to", "sRGB Encoded Rec.709 (sRGB)")],
        ),
        ("DisplayView", &[]),
        ("DisplayView", &[("view", "Un-tone-mapped")]),
        (
            "DisplayView",
            &[("look", "ACES 1.3 Reference Gamut Compression")],
        ),
    ];
    for (kind, params) in cases {
        let got = run(kind, params);
        let overrides: Vec<(&str, ParamValue)> =
            params.iter().map(|(k, v)| (*k, text(v))).collect();
        let processor = if kind == "ColourSpace" {
            colour_space::processor(
                &Default::default(),
                &colour_space::Params::with_overrides(&overrides).expect("params"),
            )
        } else {
            display_view::processor(
                &Default::default(),
                &display_view::Params::with_overrides(&overrides).expect("params"),
            )
        }
        .expect("processor");
        let want = tyndall::nodes::algorithms::ocio::reference(&processor, &swatches());
        let w = worst(&got, &want);
        eprintln!("{kind} {params:?}: GPU vs CPU {w:.2e}");
        assert!(
            w <= 1e-3,
            "{kind} {params:?}: GPU differs from the CPU by {w}"
        );
        for (i, (a, b)) in got.data.iter().zip(&want.data).enumerate() {
            assert!(
                a.is_finite() == b.is_finite(),
                "{kind}: value {i} {a} vs {b}"
            );
        }
    }
}

/// Against published values: Rec.709 primaries in ACEScg are the columns of the Rec.709-to-AP1
/// matrix (Bradford-adapted D65 → ACES white, as the ACES documentation gives it, to 4 places),
/// and the un-tone-mapped sRGB display encodes scene-linear 0.18 with the sRGB curve,
/// 1.055 · 0.18^(1/2.4) − 0.055 = 0.4614 (IEC 61966-2-1), 1 as 1.
#[test]
fn conversions_match_published_values() {
    if common::gpu().is_none() {
        return;
    }
    let got = run("ColourSpace", &[("to", "ACEScg")]);
    let matrix = [
        [0.6131, 0.3395, 0.0474],
        [0.0702, 0.9164, 0.0134],
        [0.0206, 0.1096, 0.8698],
    ];
    for (k, px) in [2usize, 3, 4].iter().enumerate() {
        for (row, m) in matrix.iter().enumerate() {
            let v = got.data[px * 4 + row];
            assert!(
                (v - m[k]).abs() <= 1e-3,
                "Rec.709 primary {k} in ACEScg, row {row}: {v} vs {}",
                m[k]
            );
        }
    }
    // The look compresses colours outside AP1 (the swatch with a strongly negative red) and leaves
    // grey alone.
    let (plain, looked) = (
        run("DisplayView", &[]),
        run(
            "DisplayView",
            &[("look", "ACES 1.3 Reference Gamut Compression")],
        ),
    );
    assert!(
        (0..3).any(|c| (plain.data[8 * 4 + c] - looked.data[8 * 4 + c]).abs() > 1e-3),
        "the look changes nothing out of gamut"
    );
    for c in 0..3 {
        assert!(
            (plain.data[4 + c] - looked.data[4 + c]).abs() <= 1e-4,
            "the look moves grey"
        );
    }
    let srgb = run("DisplayView", &[("view", "Un-tone-mapped")]);
    let grey = 1.055 * 0.18f32.powf(1.0 / 2.4) - 0.055;
    for c in 0..3 {
        assert!(
            (srgb.data[4 + c] - grey).abs() <= 1e-4,
            "0.18 → {}",
            srgb.data[4 + c]
        );
        assert!(
            (srgb.data[9 * 4 + c] - 1.0).abs() <= 1e-4,
            "1 → {}",
            srgb.data[9 * 4 + c]
        );
    }
}

/// Bad names are refused naming the node's parameter and listing what the config has.
#[test]
fn unknown_names_are_refused_with_what_the_config_has() {
    let Some(gpu) = common::gpu() else {
        return;
    };
    let input = common::upload(&gpu, &swatches(), PortType::Image);
    let e = common::run_node(
        &gpu,
        "DisplayView",
        &[("view", ParamValue::Text("Filmic".into()))],
        vec![("image", input)],
        &["image"],
        (4, 3),
    )
    .expect_err("no such view")
    .to_string();
    assert!(e.contains("view") && e.contains("Un-tone-mapped"), "{e}");
}

/// A small config of our own (`tests/fixtures/ocio/config.ocio`): its `Graded` view is a 5³
/// `.cube` 3D LUT (out = (r², (g + b) / 2, 1 − b) on the lattice) and its look `Warm` a CDL
/// slope (1.2, 1, 0.8). On the GPU (the LUT a 3D texture that OpenColorIO's shader
/// interpolates) equal to the CPU processor within 1e-3 of max(1, |value|), as above; inputs on
/// the lattice give the table's own values (1e-5: its six decimals), and the look scales before
/// the LUT: (0.5, 0.25, 0.5) becomes (0.6, 0.25, 0.4) then the LUT at an off-lattice point,
/// checked against the CPU only.
#[test]
fn a_custom_config_with_a_cube_lut_and_a_look() {
    let Some(gpu) = common::gpu() else {
        return;
    };
    let config = format!(
        "{}/tests/fixtures/ocio/config.ocio",
        env!("CARGO_MANIFEST_DIR")
    );
    let px: &[[f32; 4]] = &[
        [0.0, 0.0, 0.0, 1.0],
        [0.5, 0.25, 0.75, 1.0],
        [1.0, 0.5, 0.25, 1.0],
        [0.25, 1.0, 1.0, 1.0],
        [0.5, 0.25, 0.5, 1.0],
        [0.3, 0.6, 0.9, 1.0],
    ];
    let mut image = Raster::new(3, 2, 4, 0.0);
    for (i, p) in px.iter().enumerate() {
        image.data[i * 4..i * 4 + 4].copy_from_slice(p);
    }
    for look in ["", "Warm"] {
        let params = [
            ("config", ParamValue::Text(config.clone())),
            ("source", ParamValue::Text("linear".into())),
            ("view", ParamValue::Text("Graded".into())),
            ("look", ParamValue::Text(look.into())),
        ];
        let input = common::upload(&gpu, &image, PortType::Image);
        let got = common::run_node(
            &gpu,
            "DisplayView",
            &params,
            vec![("image", input)],
            &["image"],
            (3, 2),
        )
        .expect("run")
        .remove("image")
        .expect("image");
        let p = tyndall::nodes::display_view::Params::with_overrides(&params).expect("params");
        let processor =
            tyndall::nodes::display_view::processor(&Default::default(), &p).expect("processor");
        let want = tyndall::nodes::algorithms::ocio::reference(&processor, &image);
        let w = worst(&got, &want);
        eprintln!("custom config, look `{look}`: GPU vs CPU {w:.2e}");
        assert!(w <= 1e-3, "look `{look}`: GPU differs from the CPU by {w}");
        if look.is_empty() {
            for (i, p) in px[..4].iter().enumerate() {
                let table = [p[0] * p[0], (p[1] + p[2]) / 2.0, 1.0 - p[2]];
                for (c, t) in table.iter().enumerate() {
                    let v = got.data[i * 4 + c];
                    assert!(
                        (v - t).abs() <= 1e-5,
                        "lattice input {p:?}, channel {c}: {v} vs the table's {t}"
                    );
                }
            }
        } else {
            // The look moved the input: (0.5, 0.25, 0.5) → (0.6, 0.25, 0.4) before the LUT,
            // so blue's output is 1 − 0.4 (the LUT is linear in b there).
            assert!(
                (got.data[4 * 4 + 2] - 0.6).abs() <= 1e-4,
                "{}",
                got.data[4 * 4 + 2]
            );
        }
    }
}

/// `ImageOutput` writes a PNG through a display / view (issue #45, item 4): with `view` set the
/// file holds the view's 8-bit values (the CPU processor's, within one 8-bit step: rounding),
/// not sRGB-encoded again; with none set, the plain sRGB encoding, which is the built-in
/// config's `sRGB - Display` / `Un-tone-mapped` within one step (measured: 0 and 0 steps, on
/// A.exr's grey ramp from 0.5 to far past 1).
#[test]
fn image_output_writes_a_png_through_a_view() {
    let Some(gpu) = common::gpu() else {
        return;
    };
    let dir = tempfile::tempdir().expect("tempdir");
    let src = format!("{}/tests/fixtures/A.exr", env!("CARGO_MANIFEST_DIR"));
    let write = |name: &str, view: &str| -> Raster {
        let path = dir.path().join(name);
        let text = format!(
            r#"(version: 3, nodes: {{
                "in": (kind: "ImageInput", params: {{"path": "{src}"}}),
                "out": (kind: "ImageOutput", params: {{"path": "{}", "view": "{view}"}}),
            }}, edges: [("in.image", "out.image")])"#,
            path.display()
        );
        let registry = std::sync::Arc::new(tyndall::nodes::registry());
        let g = tyndall::graph::load_str(&text, &dir.path().join("g.ron"), registry.catalog())
            .expect("graph");
        let mut ev = tyndall::eval::Evaluator::new(registry, gpu.clone());
        let sinks = ev.sinks(&g);
        ev.evaluate(&g, &sinks, &Default::default())
            .expect("render");
        // Read back as stored (8-bit codes / 255), no decoding.
        tyndall::io::read_image(&path, false).expect("png")
    };
    // A.exr is one channel: ImageInput reads it as grey with alpha 1.
    let scalar = tyndall::io::read_image(std::path::Path::new(&src), false).expect("exr");
    assert_eq!(scalar.channels, 1);
    let mut input = Raster::new(scalar.width, scalar.height, 4, 1.0);
    for (i, v) in scalar.data.iter().enumerate() {
        input.data[i * 4..i * 4 + 3].copy_from_slice(&[*v; 3]);
    }
    let steps = |a: &Raster, b: &Raster| {
        a.data
            .iter()
            .zip(&b.data)
            .enumerate()
            .filter(|(i, _)| i % 4 != 3)
            .map(|(_, (x, y))| ((x - y) * 255.0).abs().round() as i32)
            .max()
            .unwrap_or(0)
    };
    let aces = write("aces.png", "ACES 2.0 - SDR 100 nits (Rec.709)");
    let p = tyndall::nodes::display_view::Params::with_overrides(&[(
        "view",
        ParamValue::Text("ACES 2.0 - SDR 100 nits (Rec.709)".into()),
    )])
    .expect("params");
    let mut want = tyndall::nodes::algorithms::ocio::reference(
        &tyndall::nodes::display_view::processor(&Default::default(), &p).expect("processor"),
        &input,
    );
    for v in &mut want.data {
        *v = v.clamp(0.0, 1.0);
    }
    let s = steps(&aces, &want);
    eprintln!("ImageOutput through ACES 2.0 SDR: {s} 8-bit steps from the CPU processor");
    assert!(s <= 1, "{s} steps");
    let plain = write("plain.png", "");
    let untonemapped = write("untonemapped.png", "Un-tone-mapped");
    let s = steps(&plain, &untonemapped);
    eprintln!("sRGB encoding vs Un-tone-mapped: {s} 8-bit steps");
    assert!(s <= 1, "{s} steps");
    assert!(
        steps(&plain, &aces) > 1,
        "the ACES view should change the picture"
    );
}
