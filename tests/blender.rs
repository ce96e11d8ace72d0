//! The Blender add-on against the real Blender (Debian's `blender`, 3.4): runs
//! `scripts/test_blender.sh`, which installs and enables the add-on headless, renders shafts
//! for 3 frames of an animated camera and checks the EXRs and the compositor
//! (`integrations/blender/tests/test_addon.py`); and the scene scripts of `scripts/scenes/`,
//! which must regenerate the committed `scenes/*.glb` byte for byte. Without Blender on PATH the
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
    for scene in ["cathedral", "forest", "workshop", "street", "stage"] {
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
        // The limit per file.
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

fn tail(s: &str) -> String {
    let lines: Vec<&str> = s.lines().collect();
    lines[lines.len().saturating_sub(30)..].join("\n")
}
