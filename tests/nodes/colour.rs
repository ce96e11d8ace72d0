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
                &colour_space::Params::with_overrides(&overrides).expect("params"),
            )
        } else {
            display_view::processor(
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
