//! The Blender add-on against the real Blender (Debian's `blender`, 3.4): runs
//! `scripts/test_blender.sh`, which installs and enables the add-on headless, renders shafts
//! for 3 frames of an animated camera and checks the EXRs and the compositor
//! (`integrations/blender/tests/test_addon.py`); and the scene scripts of `scripts/scenes/`,
//! which must regenerate the committed `scenes/*.glb` byte for byte; and Blender's colour config
//! through Tyndall against Blender's own "save as render". Without Blender on PATH the
//! tests are skipped, unless `TYNDALL_REQUIRE_BLENDER=1` (set by `.ci/run`), where that fails
//! them.

mod common;

use std::path::Path;
use std::process::Command;

/// Whether `blender` runs (see [`common::tool`]: `TYNDALL_REQUIRE_BLENDER=1` fails without it).
fn blender_found() -> bool {
    common::tool(
        "blender",
        "--version",
        "Debian: apt install blender python3-numpy",
    )
}

#[test]
fn scene_scripts_regenerate_the_committed_scenes_byte_for_byte() {
    if !blender_found() {
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("tempdir");
    for scene in [
        "cathedral",
        "forest",
        "workshop",
        "street",
        "stage",
        "rainbow",
        "glory",
        "halo",
    ] {
        let out = dir.path().join(format!("{scene}.glb"));
        let o = Command::new("blender")
            .args(["-b", "--factory-startup", "--python"])
            .arg(root.join(format!("scripts/scenes/{scene}.py")))
            .arg("--")
            .arg(&out)
            .output()
            .expect("run blender");
        assert!(
            o.status.success(),
            "{scene}: {}",
            tail(&String::from_utf8_lossy(&o.stderr))
        );
        let made = std::fs::read(&out).expect("the script wrote its .glb");
        let committed = std::fs::read(root.join(format!("scenes/{scene}.glb"))).expect("scene");
        // The issue's limit per file.
        assert!(
            committed.len() <= 5 << 20,
            "{scene}: {} bytes",
            committed.len()
        );
        assert!(
            made == committed,
            "{scene}: the script writes {} bytes that differ from scenes/{scene}.glb ({} bytes); \
             rerun scripts/scenes/make_all.sh and commit",
            made.len(),
            committed.len()
        );
    }
}

#[test]
fn blender_addon_renders_shafts_and_wires_the_compositor() {
    if !blender_found() {
        return;
    }
    let o = Command::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scripts/test_blender.sh"
    ))
    .arg(env!("CARGO_BIN_EXE_tyndall"))
    .output()
    .expect("run scripts/test_blender.sh");
    let out = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && out.contains("TYNDALL_ADDON_TEST OK"),
        "exit {:?}\nstdout (tail): {}\nstderr (tail): {}",
        o.status.code(),
        tail(&out),
        tail(&err)
    );
}

/// Blender's own colour config against Blender (issue #45, item 6): an EXR of saturated and
/// HDR swatches saved "as render" by Blender through its views and a look
/// (`scripts/blender_view.py`) and written by `tyndall --ocio <Blender's config.ocio> render`
/// through the same `display` / `view` / `look` of an `ImageOutput`, both 16-bit PNGs. Bound:
/// one 8-bit step (257 16-bit codes) — two OpenColorIO implementations (Blender's C++ library,
/// the `ocio` crate on Tyndall's GPU) evaluating the same LUTs; measured: printed.
#[test]
fn blenders_config_views_match_blender() {
    if !blender_found() {
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("tempdir");
    // 8 colours × 8 exposures from 1/16 to 8 (scene-linear, alpha 1).
    let colours = [
        [1.0, 1.0, 1.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.8, 0.1],
        [0.1, 0.9, 1.0],
        [0.9, 0.2, 0.8],
        [0.8, 0.45, 0.3],
    ];
    let mut swatches = tyndall::io::Raster::new(8, 8, 4, 1.0);
    for (y, c) in colours.iter().enumerate() {
        for x in 0..8 {
            let e = 2f32.powi(x as i32 - 4);
            let i = (y * 8 + x) * 4;
            swatches.data[i..i + 3].copy_from_slice(&c.map(|v| v * e));
        }
    }
    let exr = dir.path().join("swatches.exr");
    tyndall::io::write_image(&exr, &swatches, tyndall::io::Precision::F32, false).expect("exr");
    let mut pictures: Vec<Vec<f32>> = Vec::new();
    for (view, look) in [
        ("Filmic", "None"),
        ("Filmic", "Medium High Contrast"),
        ("Standard", "None"),
    ] {
        let theirs = dir.path().join("blender.png");
        let o = Command::new("blender")
            .args(["-b", "--factory-startup", "--python"])
            .arg(root.join("scripts/blender_view.py"))
            .arg("--")
            .args([exr.as_os_str(), theirs.as_os_str()])
            .args([view, look])
            .output()
            .expect("run blender");
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(
            o.status.success(),
            "{view}: {}",
            tail(&String::from_utf8_lossy(&o.stderr))
        );
        let config = out
            .lines()
            .find_map(|l| l.strip_prefix("OCIO_CONFIG "))
            .expect("the script names Blender's config");
        let tyndall_look = if look == "None" { "" } else { look };
        std::fs::write(
            dir.path().join("view.ron"),
            format!(
                r#"(version: 3, nodes: {{
                    "in": (kind: "ImageInput", params: {{"path": "swatches.exr"}}),
                    "out": (kind: "ImageOutput", params: {{"path": "tyndall.png", "precision": "u16",
                        "display": "sRGB", "view": "{view}", "look": "{tyndall_look}"}}),
                }}, edges: [("in.image", "out.image")])"#
            ),
        )
        .expect("graph");
        let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
            .current_dir(dir.path())
            .args(["--ocio", config, "render", "view.ron"])
            .output()
            .expect("run tyndall");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let ours = tyndall::io::read_image(&dir.path().join("tyndall.png"), false).expect("ours");
        let theirs = tyndall::io::read_image(&theirs, false).expect("Blender's");
        let codes = ours
            .data
            .chunks(4)
            .zip(theirs.data.chunks(theirs.channels as usize))
            .flat_map(|(a, b)| (0..3).map(move |c| ((a[c] - b[c]) * 65535.0).abs().round() as u32))
            .max()
            .expect("pixels");
        eprintln!("{view} / {look}: largest difference {codes} 16-bit codes");
        assert!(codes <= 257, "{view} / {look}: {codes} 16-bit codes apart");
        pictures.push(ours.data);
    }
    // The look and the views each change the picture by more than the bound (0.0039), so
    // agreeing with Blender says something (measured: the look moves it by 0.033).
    for (a, b) in [(0, 1), (0, 2)] {
        let apart = pictures[a]
            .iter()
            .zip(&pictures[b])
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        assert!(apart > 0.01, "pictures {a} and {b} differ by only {apart}");
    }
}

fn tail(s: &str) -> String {
    let lines: Vec<&str> = s.lines().collect();
    lines[lines.len().saturating_sub(30)..].join("\n")
}
