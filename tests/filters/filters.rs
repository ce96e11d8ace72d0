//! BilateralFilter and RadialBlur: equal to the formulas on EXR files written by OpenEXR (expected
//! outputs computed in float64 by tests/fixtures/make_filter_exr.py), GPU equal to the CPU
//! references, and finite at the extremes.

use crate::common;
use std::path::{Path, PathBuf};
use std::process::Command;

use tyndall::graph::{ParamValue, PortType};
use tyndall::io::{read_image, Raster};
use tyndall::nodes::{bilateral_filter as bf, radial_blur as rb};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/filters")
        .join(name)
}

/// Largest |got − want| / max(1, |want|).
fn rel_err(got: &Raster, want: &Raster) -> f32 {
    assert_eq!(
        (got.width, got.height, got.channels),
        (want.width, want.height, want.channels)
    );
    got.data
        .iter()
        .zip(&want.data)
        .map(|(g, w)| (g - w).abs() / w.abs().max(1.0))
        .fold(0.0, f32::max)
}

fn node(args: &[&str], out: &Path) -> Raster {
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .arg("node")
        .args(args)
        .arg(format!("--output=image={}", out.display()))
        .output()
        .expect("run tyndall");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    read_image(out, false).expect("output")
}

/// The CLI on the OpenEXR fixtures equals the float64 formulas (1e-4 relative: the issue's
/// bound; f32 weights and sums differ from float64 by ~1e-6 here).
#[test]
fn filters_on_exr_inputs_equal_the_formulas() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let img = format!("--input=image={}", fixture("I.exr").display());
    let guided = node(
        &[
            "BilateralFilter",
            &img,
            &format!("--input=guide={}", fixture("G.exr").display()),
            "--param=radius=3",
            "--param=sigma_spatial=1.5",
            "--param=sigma_range=0.8",
        ],
        &dir.path().join("a.exr"),
    );
    let want = read_image(&fixture("bilateral_guided.exr"), false).expect("expected");
    assert!(
        rel_err(&guided, &want) <= 1e-4,
        "guided: {}",
        rel_err(&guided, &want)
    );
    let luma = node(
        &[
            "BilateralFilter",
            &img,
            "--param=radius=2",
            "--param=sigma_spatial=2",
            "--param=sigma_range=0.15",
        ],
        &dir.path().join("b.exr"),
    );
    let want = read_image(&fixture("bilateral_luma.exr"), false).expect("expected");
    assert!(
        rel_err(&luma, &want) <= 1e-4,
        "luminance: {}",
        rel_err(&luma, &want)
    );
    let radial = node(
        &[
            "RadialBlur",
            &format!("--input=occlusion={}", fixture("O.exr").display()),
            "--param=light_x=17.3",
            "--param=light_y=4.6",
            "--param=samples=24",
            "--param=density=0.8",
            "--param=decay=0.95",
            "--param=weight=0.3",
            "--param=exposure=0.5",
        ],
        &dir.path().join("c.exr"),
    );
    let want = read_image(&fixture("radial.exr"), false).expect("expected");
    assert!(
        rel_err(&radial, &want) <= 1e-4,
        "radial: {}",
        rel_err(&radial, &want)
    );
}

/// GPU equals the CPU references on random inputs (Image and Scalar), with and without guide.
#[test]
fn gpu_equals_cpu_references() {
    let gpu = require_gpu!();
    let (w, h) = (19, 13);
    let img = common::random_raster(w, h, 4, 0.0, 2.0, 11);
    let sca = common::random_raster(w, h, 1, 0.0, 2.0, 12);
    let guide = common::random_raster(w, h, 1, 1.0, 4.0, 13);
    let s = bf::Settings {
        radius: 3,
        sigma_spatial: 1.7,
        sigma_range: 0.6,
    };
    let params = [
        ("radius", ParamValue::Int(3)),
        ("sigma_spatial", ParamValue::Float(1.7)),
        ("sigma_range", ParamValue::Float(0.6)),
    ];
    for (src, ty) in [(&img, PortType::Image), (&sca, PortType::Scalar)] {
        for with_guide in [false, true] {
            let mut inputs = vec![("image", common::upload(&gpu, src, ty))];
            if with_guide {
                inputs.push(("guide", common::upload(&gpu, &guide, PortType::Scalar)));
            }
            let got =
                common::run_node(&gpu, "BilateralFilter", &params, inputs, &["image"], (8, 8))
                    .expect("bilateral")
                    .remove("image")
                    .expect("image");
            let want = bf::reference(src, with_guide.then_some(&guide.data[..]), s);
            // 1e-5: same f32 operations, exp() of the GPU vs Rust's.
            assert!(rel_err(&got, &want) <= 1e-5, "{ty:?} guide {with_guide}");
        }
        let p = rb::RadialParams {
            light: [4.5, 30.0],
            samples: 17,
            density: 1.3,
            decay: 0.9,
            weight: 0.7,
            exposure: 1.5,
            _pad0: 0,
        };
        let got = common::run_node(
            &gpu,
            "RadialBlur",
            &[
                ("light_x", ParamValue::Float(4.5)),
                ("light_y", ParamValue::Float(30.0)),
                ("samples", ParamValue::Int(17)),
                ("density", ParamValue::Float(1.3)),
                ("decay", ParamValue::Float(0.9)),
                ("weight", ParamValue::Float(0.7)),
                ("exposure", ParamValue::Float(1.5)),
            ],
            vec![("occlusion", common::upload(&gpu, src, ty))],
            &["image"],
            (8, 8),
        )
        .expect("radial")
        .remove("image")
        .expect("image");
        assert!(rel_err(&got, &rb::reference(src, &p)) <= 1e-5, "{ty:?}");
    }
}

/// σr = 0 keeps only equal guide values; a huge σr is a plain Gaussian; radius 0 and σs = 0 are
/// the identity; a depth step is kept while the flat sides are smoothed.
#[test]
fn bilateral_limits_and_edges() {
    let (w, h) = (12, 6);
    let mut img = Raster::new(w, h, 1, 0.0);
    let mut guide = vec![0.0f32; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let k = (y * w + x) as usize;
            img.data[k] = if x < 6 { 0.0 } else { 1.0 } + 0.1 * ((x * 7 + y * 3) % 5) as f32;
            guide[k] = if x < 6 { 2.0 } else { 8.0 };
        }
    }
    let s = |r, ss, sr| bf::Settings {
        radius: r,
        sigma_spatial: ss,
        sigma_range: sr,
    };
    assert_eq!(
        bf::reference(&img, Some(&guide), s(0, 2.0, 1.0)).data,
        img.data
    );
    assert_eq!(
        bf::reference(&img, Some(&guide), s(3, 0.0, 1.0)).data,
        img.data
    );
    // The step survives a strong filter: no value crosses from one side to the other.
    let kept = bf::reference(&img, Some(&guide), s(4, 3.0, 0.5));
    for y in 0..h {
        for x in 0..w {
            let v = kept.data[(y * w + x) as usize];
            assert!(if x < 6 { v < 0.5 } else { v > 0.9 }, "({x},{y}) = {v}");
        }
    }
    // σr = 0: a constant guide region averages only within itself, like σr small.
    let zero = bf::reference(&img, Some(&guide), s(4, 3.0, 0.0));
    assert!(zero.data.iter().all(|v| v.is_finite()));
    assert_eq!(
        zero.data,
        bf::reference(&img, Some(&guide), s(4, 3.0, 1e-9)).data
    );
    // Huge σr: equals the separable Gaussian with the same taps (edges blur across).
    let huge = bf::reference(&img, Some(&guide), s(2, 1.0, 1e9));
    let flat = vec![0.0f32; guide.len()];
    let gauss = bf::reference(&img, Some(&flat), s(2, 1.0, 1.0));
    for (a, b) in huge.data.iter().zip(&gauss.data) {
        assert!((a - b).abs() < 1e-6);
    }
}

/// Extremes stay finite on the GPU: radius 0 and 64, σ 0 and huge, infinite depths in the guide,
/// a light far off screen, on a pixel centre, samples 1 and 1024, density 0.
#[test]
fn extremes_stay_finite() {
    let gpu = require_gpu!();
    let (w, h) = (9, 5);
    let img = common::random_raster(w, h, 4, 0.0, 1.0, 21);
    let mut guide = common::random_raster(w, h, 1, 1.0, 50.0, 22);
    guide.data[3] = f32::INFINITY;
    guide.data[7] = 1e30;
    for (r, ss, sr) in [
        (0, 0.0, 0.0),
        (64, 256.0, 1e9),
        (5, 0.0, 1e9),
        (5, 256.0, 0.0),
    ] {
        let out = common::run_node(
            &gpu,
            "BilateralFilter",
            &[
                ("radius", ParamValue::Int(r)),
                ("sigma_spatial", ParamValue::Float(ss)),
                ("sigma_range", ParamValue::Float(sr)),
            ],
            vec![
                ("image", common::upload(&gpu, &img, PortType::Image)),
                ("guide", common::upload(&gpu, &guide, PortType::Depth)),
            ],
            &["image"],
            (8, 8),
        )
        .expect("bilateral");
        assert!(
            out["image"].data.iter().all(|v| v.is_finite()),
            "{r} {ss} {sr}"
        );
    }
    for (lx, ly, n, density) in [
        (1e6, -1e6, 1024, 10.0),
        (4.5, 2.5, 1, 1.0),
        (4.5, 2.5, 64, 0.0),
        (-3.0, 2.0, 64, 1.0),
    ] {
        let out = common::run_node(
            &gpu,
            "RadialBlur",
            &[
                ("light_x", ParamValue::Float(lx)),
                ("light_y", ParamValue::Float(ly)),
                ("samples", ParamValue::Int(n)),
                ("density", ParamValue::Float(density)),
            ],
            vec![("occlusion", common::upload(&gpu, &img, PortType::Image))],
            &["image"],
            (8, 8),
        )
        .expect("radial");
        assert!(
            out["image"].data.iter().all(|v| v.is_finite()),
            "{lx} {ly} {n}"
        );
    }
}

/// The sun's screen position against pinhole trigonometry, independently of the camera
/// matrices: a camera at the origin looking along +Z (so world +X is screen left), vertical
/// field of view 60°, 960 × 540; a sun at azimuth a (clockwise from +Z seen from above) and
/// elevation e lies tan(a)/(aspect·tan 30°) half-widths left of the centre and
/// tan(e)/(cos(a)·tan 30°) half-heights above it.
#[test]
fn light_pixel_of_a_sun_follows_pinhole_trigonometry() {
    let mut scene = tyndall::scene::builtin("window", 1).expect("scene");
    scene.camera.position = glam::Vec3::ZERO;
    scene.camera.target = glam::Vec3::Z;
    scene.camera.fov_y = 60.0;
    let t30 = 30f32.to_radians().tan();
    let aspect = 960.0 / 540.0;
    for (az, el) in [(0.0f32, 0.0f32), (0.0, 15.0), (20.0, 0.0), (-25.0, 10.0)] {
        let sun = tyndall::scene::Sun {
            azimuth: az,
            elevation: el,
            colour: [1.0; 3],
            intensity: 1.0,
        };
        let p = rb::light_pixel(&scene, &tyndall::scene::Light::sun("sun", sun), 960, 540);
        let (a, e) = (az.to_radians(), el.to_radians());
        let want = [
            480.0 - 480.0 * a.tan() / (aspect * t30),
            270.0 - 270.0 * e.tan() / (a.cos() * t30),
        ];
        // 1e-2 px: f32 matrix products against f32 trigonometry.
        assert!(
            (p[0] - want[0]).abs() < 1e-2 && (p[1] - want[1]).abs() < 1e-2,
            "azimuth {az}, elevation {el}: {p:?} vs {want:?}"
        );
    }
}
