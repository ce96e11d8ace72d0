//! The `tyndall` binary end to end: exit codes, messages, files.

mod common;

use std::path::Path;
use std::process::{Command, Output};

fn tyndall(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(args)
        .output()
        .expect("run tyndall")
}

fn fixture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
        .display()
        .to_string()
}

fn gpu_available() -> bool {
    common::gpu().is_some()
}

#[test]
fn node_math_mul_equals_elementwise_product_of_openexr_files() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("C.exr");
    let o = tyndall(&[
        "node",
        "Math",
        "--param",
        "op=mul",
        "--input",
        &format!("a={}", fixture("A.exr")),
        "--input",
        &format!("b={}", fixture("B.exr")),
        "--output",
        &format!("out={}", out.display()),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let c = tyndall::io::read_image(&out, false).expect("C.exr");
    assert_eq!((c.width, c.height, c.channels), (16, 12, 1));
    let mut max_err = 0f32;
    for y in 0..12u32 {
        for x in 0..16u32 {
            let (xa, ya) = (x as f64, y as f64);
            let a = ((xa + 1.0) / (ya + 2.0) - 0.37 * xa) as f32;
            let b = ((ya - 5.5) * 0.25 + xa / 7.0) as f32;
            max_err = max_err.max((c.pixel(x, y)[0] - a * b).abs());
        }
    }
    assert!(max_err <= 1e-6, "max error {max_err}");
}

#[test]
fn validate_exits_2_with_location_for_every_malformed_graph() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/bad");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).expect("bad/") {
        let path = entry.expect("entry").path();
        let o = tyndall(&["validate", &path.display().to_string()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{}: {err}", path.display());
        let name = path
            .file_name()
            .and_then(|f| f.to_str())
            .unwrap_or_default();
        // file:line:col: message
        let needle = format!("{name}:");
        let rest = err
            .split(&needle)
            .nth(1)
            .unwrap_or_else(|| panic!("{name}: no file in {err}"));
        let mut parts = rest.splitn(3, ':');
        let line: usize = parts
            .next()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{name}: no line in {err}"));
        let col: usize = parts
            .next()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| panic!("{name}: no column in {err}"));
        assert!(line >= 1 && col >= 1);
        assert!(!err.contains("panicked"), "{err}");
        n += 1;
    }
    assert!(n >= 11);
    let ok = tyndall(&["validate", &fixture("v1_graph.ron")]);
    assert!(ok.status.success());
}

#[test]
fn wedge_reuses_the_independent_branch() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let graph = dir.path().join("g.ron");
    std::fs::write(&graph, common::two_branches_ron(dir.path())).expect("write graph");
    // The shared two-branch graph writes to absolute paths in the temporary folder.
    let o = tyndall(&[
        "eval",
        &graph.display().to_string(),
        "--wedge",
        "m1.b=1,2,3",
        "--stats",
        "--allow-any-path",
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let blocks: Vec<&str> = out.split("evaluation ").skip(1).collect();
    assert_eq!(blocks.len(), 3, "{out}");
    let status = |block: &str, node: &str| -> String {
        block
            .lines()
            .find(|l| l.split_whitespace().next() == Some(node))
            .map(|l| l.split_whitespace().nth(2).unwrap_or_default().to_string())
            .unwrap_or_else(|| panic!("{node} missing in {block}"))
    };
    for node in ["c1", "m1", "out1", "c2", "r2", "out2"] {
        assert_eq!(status(blocks[0], node), "ran", "{out}");
    }
    for block in &blocks[1..] {
        for node in ["c1", "c2", "r2", "out2"] {
            assert_eq!(status(block, node), "reused", "{node}: {out}");
        }
        for node in ["m1", "out1"] {
            assert_eq!(status(block, node), "ran", "{node}: {out}");
        }
    }
    for v in 1..=3 {
        let one = tyndall::io::read_image(&dir.path().join(format!("one_b-{v}.exr")), false)
            .expect("wedge file");
        assert!(one.data.iter().all(|x| *x == 2.0 * v as f32));
        assert!(dir.path().join(format!("two_b-{v}.exr")).exists());
    }
}

#[test]
fn nodes_json_lists_every_kind_with_ports_and_params() {
    let o = tyndall(&["nodes", "--json"]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
    let all = v.as_array().expect("array");
    let registry = tyndall::nodes::registry();
    // Built-in kinds, then the library groups of graphs/lib (tests run in the repository).
    let kinds: Vec<&serde_json::Value> = all.iter().filter(|k| k["library"].is_null()).collect();
    assert_eq!(kinds.len(), registry.catalog().iter().count());
    assert!(
        all.len() >= kinds.len() + 8,
        "the library groups are listed"
    );
    for k in kinds {
        let name = k["kind"].as_str().expect("kind");
        let schema = registry.catalog().get(name).expect("known kind");
        assert_eq!(
            k["ports"].as_array().expect("ports").len(),
            schema.inputs.len() + schema.outputs.len()
        );
        for p in k["ports"].as_array().expect("ports") {
            assert!(p["name"].is_string() && p["direction"].is_string() && p["types"].is_array());
        }
        for p in k["params"].as_array().expect("params") {
            assert!(
                p["name"].is_string()
                    && p["type"].is_string()
                    && p["doc"].as_str().is_some_and(|d| !d.is_empty())
            );
        }
    }
    let md = tyndall(&["nodes", "--markdown"]);
    assert!(String::from_utf8_lossy(&md.stdout).contains("## Math"));
}

#[test]
fn bad_arguments_exit_2_with_a_message() {
    for args in [
        vec!["node", "Blur9000", "--output", "out=x.exr"],
        vec![
            "node",
            "Math",
            "--param",
            "op=sqrt",
            "--output",
            "out=x.exr",
        ],
        vec!["node", "Math", "--param", "nope=1", "--output", "out=x.exr"],
        vec!["node", "Math", "--output", "nope=x.exr"],
        vec![
            "node",
            "Math",
            "--input",
            "a=/nonexistent.exr",
            "--output",
            "out=x.exr",
        ],
        vec!["eval", "/nonexistent.ron"],
        vec!["render", "/nonexistent.ron", "--frames", "5-1"],
        vec!["frobnicate"],
    ] {
        let o = tyndall(&args);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!o.stderr.is_empty(), "{args:?}");
        assert!(
            !String::from_utf8_lossy(&o.stderr).contains("panicked"),
            "{args:?}"
        );
    }
}

#[test]
fn evaluation_errors_exit_1_naming_the_node() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let graph = dir.path().join("g.ron");
    std::fs::write(
        &graph,
        r#"(version: 2, nodes: {"in": (kind: "ImageInput", params: {"path": "/nonexistent/file.exr"}), "o": (kind: "ImageOutput")}, edges: [("in.image", "o.image")])"#,
    )
    .expect("write");
    let o = tyndall(&["eval", &graph.display().to_string()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("node 'in' (ImageInput)") && err.contains("/nonexistent/file.exr"),
        "{err}"
    );
}

#[test]
fn docs_nodes_md_matches_the_catalog() {
    // The repository's library groups (graphs/lib) are part of the catalog; a user's own
    // library ($TYNDALL_PRESETS/lib) is not.
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(["nodes", "--markdown"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("TYNDALL_PRESETS", "/nonexistent")
        .output()
        .expect("run tyndall");
    let committed =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/nodes.md"))
            .expect("docs/nodes.md");
    assert_eq!(
        String::from_utf8_lossy(&o.stdout),
        committed,
        "docs/nodes.md is stale: run `cargo run -- nodes --markdown > docs/nodes.md`"
    );
}

#[test]
fn every_graph_in_graphs_validates_and_renders() {
    let files = common::presets();
    assert!(!files.is_empty());
    let dir = tempfile::tempdir().expect("tempdir");
    for f in files {
        let o = tyndall(&["validate", &f.display().to_string()]);
        assert!(
            o.status.success(),
            "{}: {}",
            f.display(),
            String::from_utf8_lossy(&o.stderr)
        );
        let registry = tyndall::nodes::registry();
        let g = tyndall::graph::load_file(&f, registry.catalog()).expect("load");
        let sinks = g
            .nodes()
            .filter(|n| registry.get(&n.kind).is_some_and(|k| k.is_sink()))
            .count();
        if gpu_available() && sinks > 0 {
            // One output: written as -o names it, in the sink's own format (an AovOutput
            // writes EXR only); several: each under --output-dir.
            let ext = g
                .nodes()
                .filter(|n| registry.get(&n.kind).is_some_and(|k| k.is_sink()))
                .find_map(|n| match n.params.get("path") {
                    Some(tyndall::graph::ParamValue::Text(p)) => std::path::Path::new(p)
                        .extension()
                        .map(|e| e.to_string_lossy().into_owned()),
                    _ => None,
                })
                .unwrap_or_else(|| "png".into());
            let out = dir.path().join(format!("r.{ext}"));
            let sub = dir.path().join(f.file_stem().expect("stem"));
            let graph = f.display().to_string();
            let (flag, target) = if sinks == 1 {
                ("-o", out.display().to_string())
            } else {
                ("--output-dir", sub.display().to_string())
            };
            // A 32×16 proxy at ¼ (light-space sizes divided too): whether every preset renders,
            // not how it looks (tests/backends.rs and the snapshots look).
            let o = tyndall(&[
                "render", &graph, flag, &target, "--size", "128x64", "--proxy", "4",
            ]);
            let err = String::from_utf8_lossy(&o.stderr);
            // A node this adapter cannot run, inside a group node too: a clean exit 1 naming it
            // (and its group) instead of a picture.
            let gpu = common::gpu().expect("adapter");
            let refused: Vec<String> = common::refused(&gpu, &g)
                .into_iter()
                .map(|(id, kind)| match id.split_once('/') {
                    Some((group, _)) => format!("'{id}' ({kind}): inside group node '{group}'"),
                    None => format!("'{id}' ({kind}): this adapter"),
                })
                .collect();
            if !refused.is_empty() {
                assert_eq!(o.status.code(), Some(1), "{}: {err}", f.display());
                assert!(
                    refused.iter().any(|r| err.contains(r.as_str())),
                    "{}: {err}",
                    f.display()
                );
                continue;
            }
            assert!(o.status.success(), "{}: {err}", f.display());
            assert!(
                if sinks == 1 {
                    out.exists()
                } else {
                    sub.exists()
                },
                "{}",
                f.display()
            );
        }
    }
}

#[test]
fn bench_visibility_runs_and_writes_its_csv() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("v.csv");
    let suite = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/visibility/tree.ron");
    let o = tyndall(&[
        "bench",
        &suite.display().to_string(),
        "--runs",
        "1",
        "--size",
        "16x9",
        "--full",
        "--csv",
        &csv.display().to_string(),
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for line in [
        "method=MinMax",
        "method=Epipolar",
        "speed-up of MinMax at RMSE <= 0.005",
        "speed-up of Epipolar at RMSE <= 0.005",
        "speed-up of Epipolar at RMSE <= 0.001",
    ] {
        assert!(out.contains(line), "{line}: {out}");
    }
    // The same columns as bench/results.csv.
    let bytes = std::fs::read(&csv).expect("csv");
    let suites = tyndall::bench::report::rows_from_csv(&bytes).expect("parse");
    let rows = &suites[0].2;
    // --full: the 33 settings, the two marked slow included.
    assert_eq!(rows.len(), 33);
    // MinMax at min_level 0 is exact: within the 4096-step reference's own sampling error.
    let exact = rows
        .iter()
        .find(|r| r.setting.contains("min_level=0"))
        .expect("MinMax row");
    assert!(exact.rmse <= 2e-3, "{}: {}", exact.setting, exact.rmse);
}

/// A first run without `XDG_RUNTIME_DIR` (CI, cron, a farm node) renders without printing the
/// driver's "error: XDG_RUNTIME_DIR is invalid or not set" lines.
#[test]
fn no_driver_error_lines_without_xdg_runtime_dir() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let png = dir.path().join("t.png");
    let preset = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/tree.ron");
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .env_remove("XDG_RUNTIME_DIR")
        .args([
            "render",
            &preset.display().to_string(),
            "--size",
            "32x18",
            "-o",
        ])
        .arg(&png)
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(png.is_file());
    assert!(
        !err.lines().any(|l| l.trim_start().starts_with("error:")),
        "{err}"
    );
}

/// An allocation beyond the adapter's limit (here lowered to 1 MiB with
/// `TYNDALL_GPU_MEMORY_MB`, since no parameter range reaches lavapipe's own) fails before the
/// driver does, naming the node, the parameter and the limit; exit 1.
#[test]
fn an_allocation_beyond_the_memory_limit_names_node_parameter_and_limit() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let preset = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/tree.ron");
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .env("TYNDALL_GPU_MEMORY_MB", "1")
        .args([
            "render",
            &preset.display().to_string(),
            "--size",
            "32x18",
            "-o",
        ])
        .arg(dir.path().join("t.png"))
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    // The tree preset's 2048² R32F shadow map: 16 MiB.
    assert!(err.contains("node 'shadow' (ShadowMap)"), "{err}");
    assert!(err.contains("parameter 'resolution'"), "{err}");
    assert!(
        err.contains("16 MiB") && err.contains("limit of 1 MiB"),
        "{err}"
    );
    assert!(err.contains("TYNDALL_GPU_MEMORY_MB"), "{err}");
}

/// What gives `oiiotool`.
const OIIOTOOL: &str = "Debian: apt install openimageio-tools";

/// AovOutput writes one multi-layer EXR that an independent reader (OpenImageIO's `oiiotool`,
/// Debian's openimageio-tools, installed by .ci/run) lists with the layer channels named as Nuke
/// and Blender read them, half or float per layer, and the camera matrices and frame in the
/// header.
#[test]
fn aov_output_writes_named_layers_an_independent_reader_lists() {
    if !gpu_available() || !common::tool("oiiotool", "--version", OIIOTOOL) {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let exr = dir.path().join("aovs.exr");
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/aov_tree.ron");
    let set = format!("aovs.path={}", exr.display());
    let o = tyndall(&[
        "render",
        &graph.display().to_string(),
        "--size",
        "48x27",
        "--set",
        &set,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let info = Command::new("oiiotool")
        .args(["--info", "-v"])
        .arg(&exr)
        .output()
        .expect("run oiiotool");
    assert!(
        info.status.success(),
        "{}",
        String::from_utf8_lossy(&info.stderr)
    );
    let text = String::from_utf8_lossy(&info.stdout);
    let expected = "channel list: R (half), G (half), B (half), A (half), N.R (half), N.G (half), \
                    N.B (half), N.A (half), depth.Z (float), inscatter.R (half), inscatter.G (half), \
                    inscatter.B (half), transmittance.Y (half), visibility.Y (half)";
    assert!(text.contains(expected), "{text}");
    assert!(text.contains("48 x   27"), "{text}");
    for key in [
        "worldToCamera:",
        "worldToNDC:",
        "frame:",
        "software: \"Tyndall\"",
    ] {
        assert!(text.contains(key), "{key} missing: {text}");
    }
    // An output path that is not .exr is refused, naming the file.
    let png = format!("aovs.path={}", dir.path().join("aovs.png").display());
    let o = tyndall(&[
        "render",
        &graph.display().to_string(),
        "--size",
        "8x4",
        "--set",
        &png,
    ]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("must be an .exr file"));
}

/// Frame specs as a farm writes them: ranges, steps and lists, in order, repeats dropped; the
/// chunks of a list cover every frame exactly once.
#[test]
fn frame_specs_and_chunks() {
    use tyndall::cli::{chunk_of, parse_frame_spec};
    assert_eq!(
        parse_frame_spec("1-10x3").expect("spec").0,
        vec![1, 4, 7, 10]
    );
    assert_eq!(
        parse_frame_spec("1,5,7-9").expect("spec").0,
        vec![1, 5, 7, 8, 9]
    );
    assert_eq!(parse_frame_spec("3,1-3").expect("spec").0, vec![3, 1, 2]);
    for bad in ["5-1", "1-4x0", "a", "-3", "1-", ""] {
        assert!(parse_frame_spec(bad).is_err(), "{bad}");
    }
    let frames = parse_frame_spec("1-16").expect("spec").0;
    for n in 1..=7 {
        let mut seen: Vec<i64> = (1..=n)
            .flat_map(|k| chunk_of(&frames, (k, n)).to_vec())
            .collect();
        seen.sort();
        assert_eq!(seen, frames, "{n} chunks");
    }
    assert_eq!(chunk_of(&frames, (2, 4)), &[5, 6, 7, 8]);
}

/// A 300-frame sequence render killed (SIGKILL, as a farm pre-empts a task) and resumed with
/// `--skip-existing` ends with every frame exactly once, every file complete, no temporaries
/// left, and the frames written before the kill untouched.
#[test]
fn killed_then_resumed_sequence_has_every_frame_once_and_no_partial_files() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/tree.ron");
    let pattern = dir.path().join("f.####.png").display().to_string();
    let frames = "1-300";
    let args = |extra: &[&str]| {
        let mut a = vec![
            "render".to_string(),
            graph.display().to_string(),
            "--frames".into(),
            frames.into(),
            "--size".into(),
            "160x90".into(),
            "--progress".into(),
            "none".into(),
            "-o".into(),
            pattern.clone(),
        ];
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    let finals = |d: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .expect("dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .filter(|n| !n.starts_with('.'))
            .collect();
        v.sort();
        v
    };
    let mut child = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(args(&[]))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("spawn");
    // Kill it once a few frames are out (waiting a minute at most); 300 frames leave ample
    // time for the kill to land mid-sequence, which the assertion below checks.
    let start = std::time::Instant::now();
    while finals(dir.path()).len() < 5 && start.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().expect("kill");
    let _ = child.wait();
    let before = finals(dir.path());
    assert!(
        before.len() < 300,
        "the render was killed before it finished ({} frames)",
        before.len()
    );
    let stamps: Vec<_> = before
        .iter()
        .map(|n| {
            std::fs::metadata(dir.path().join(n))
                .expect("file")
                .modified()
                .expect("mtime")
        })
        .collect();
    // Every file under a final name is a complete image.
    for n in &before {
        image::open(dir.path().join(n)).unwrap_or_else(|e| panic!("{n} is partial: {e}"));
    }
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(args(&["--skip-existing"]))
        .output()
        .expect("resume");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains(&format!("{} skipped", before.len())), "{out}");
    let all: Vec<String> = std::fs::read_dir(dir.path())
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    let expected: Vec<String> = (1..=300).map(|f| format!("f.{f:04}.png")).collect();
    assert_eq!(finals(dir.path()), expected, "every frame exactly once");
    assert_eq!(all.len(), 300, "no temporaries left: {all:?}");
    for (n, t) in before.iter().zip(stamps) {
        let now = std::fs::metadata(dir.path().join(n))
            .expect("file")
            .modified()
            .expect("mtime");
        assert_eq!(
            now, t,
            "{n} was written before the kill and is not rewritten"
        );
    }
}

/// `render` as a farm task: a chunk of a frame range with `####` padding and ALF progress, then
/// a resumed run (`--skip-existing`) that renders only what is missing, with JSON progress and a
/// one-line summary; `%04d` padding; bad specs exit 2.
#[test]
fn render_farm_chunks_padding_progress_and_resume() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/basics/grade.ron");
    let graph = graph.display().to_string();
    let hashes = dir.path().join("g.####.png").display().to_string();
    let listing = |d: &Path| -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .expect("dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    };
    let args = ["--size", "16x9", "-o", &hashes];
    let o = tyndall(
        &[
            &[
                "render",
                &graph,
                "--frames",
                "1-8",
                "--chunk",
                "2/4",
                "--progress",
                "alf",
            ][..],
            &args[..],
        ]
        .concat(),
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(listing(dir.path()), vec!["g.0003.png", "g.0004.png"]);
    assert!(
        out.contains("ALF_PROGRESS 50%") && out.contains("ALF_PROGRESS 100%"),
        "{out}"
    );
    assert!(
        out.contains("2 files written for 2 frames, 0 skipped"),
        "{out}"
    );
    let before = std::fs::metadata(dir.path().join("g.0003.png"))
        .expect("file")
        .modified()
        .expect("mtime");

    let o = tyndall(
        &[
            &[
                "render",
                &graph,
                "--frames",
                "1-8",
                "--skip-existing",
                "--progress",
                "json",
            ][..],
            &args[..],
        ]
        .concat(),
    );
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lines: Vec<serde_json::Value> = out
        .lines()
        .filter(|l| l.starts_with('{'))
        .map(|l| serde_json::from_str(l).expect("json line"))
        .collect();
    assert_eq!(lines.len(), 8);
    let skipped: Vec<i64> = lines
        .iter()
        .filter(|l| l["status"] == "skipped")
        .map(|l| l["frame"].as_i64().expect("frame"))
        .collect();
    assert_eq!(skipped, vec![3, 4]);
    assert!(
        out.contains("6 files written for 8 frames, 2 skipped"),
        "{out}"
    );
    let expected: Vec<String> = (1..=8).map(|f| format!("g.{f:04}.png")).collect();
    assert_eq!(listing(dir.path()), expected);
    let after = std::fs::metadata(dir.path().join("g.0003.png"))
        .expect("file")
        .modified()
        .expect("mtime");
    assert_eq!(before, after, "a skipped frame is not rewritten");

    let printf = dir.path().join("p%04d.exr").display().to_string();
    let o = tyndall(&[
        "render",
        &graph,
        "--frames",
        "7,9",
        "--size",
        "8x4",
        "--progress",
        "none",
        "-o",
        &printf,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.path().join("p0007.exr").is_file() && dir.path().join("p0009.exr").is_file());

    for bad in [
        &["--frames", "5-1"][..],
        &["--frames", "1-4", "--chunk", "5/4"][..],
        &["--chunk", "1/2"][..],
    ] {
        let o = tyndall(&[&["render", &graph][..], bad, &args[..]].concat());
        assert_eq!(
            o.status.code(),
            Some(2),
            "{bad:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

/// Paths in a graph: a relative input path is read from the graph file's folder (not the
/// working directory), a relative output path is written under `--output-dir`; an output path
/// that is absolute or climbs out with `..` is refused (exit 2, naming the node and the path)
/// unless `--allow-any-path`; paths given on the command line are the user's.
#[test]
fn graph_paths_resolve_against_the_graph_folder_and_outputs_stay_inside() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let shot = dir.path().join("shot");
    std::fs::create_dir_all(&shot).expect("mkdir");
    std::fs::copy(fixture("A.exr"), shot.join("A.exr")).expect("copy");
    let graph = |out: &str| {
        format!(
            r#"(
    version: 2,
    nodes: {{
        "in": (kind: "ImageInput", params: {{"path": "A.exr"}}),
        "out": (kind: "ImageOutput", params: {{"path": "{out}"}}),
    }},
    edges: [("in.image", "out.image")],
)"#
        )
    };
    let file = shot.join("g.ron");
    let outs = dir.path().join("outs");
    let render = |out: &str, extra: &[&str]| {
        std::fs::write(&file, graph(out)).expect("graph");
        let mut args = vec![
            "render",
            file.to_str().expect("utf8"),
            "--output-dir",
            outs.to_str().expect("utf8"),
        ];
        args.extend_from_slice(extra);
        tyndall(&args)
    };
    // The working directory is the crate's root, where no A.exr lies: read from the graph's folder.
    let o = render("frames/res.exr", &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(outs.join("frames/res.exr").is_file());

    let escape = "../escaped.exr";
    let o = render(escape, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("node 'out'") && err.contains(escape), "{err}");
    assert!(!dir.path().join("escaped.exr").exists());
    let absolute = dir.path().join("abs.exr").display().to_string();
    let o = render(&absolute, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("is absolute") && err.contains(&absolute),
        "{err}"
    );

    let o = render(escape, &["--allow-any-path"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.path().join("escaped.exr").is_file());
    // A path given on the command line is the user's choice.
    let mine = dir.path().join("mine.exr");
    let o = render("x.exr", &["-o", mine.to_str().expect("utf8")]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(mine.is_file());
}

/// A reference that is also one of the suite's settings is evaluated once: its evaluation is
/// that setting's first run (the suite's `reference` and a named one alike), and the header
/// states the row budget that stops a slow setting's repeats.
#[test]
fn bench_reference_that_is_a_setting_counts_as_its_first_run() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let suite = dir.path().join("blur.ron");
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/bench/blur.ron");
    std::fs::write(
        &suite,
        format!(
            r#"(title: "Blur reuse", graph: "{}", node: "blur", output: "out", size: (64, 36),
                runs: 2, row_budget_ms: 60000, reference: {{"truncate": "3"}},
                references: {{"wide": {{"truncate": "4"}}}},
                configs: [{{"truncate": "1", "reference": "wide"}}, {{"truncate": "3"}},
                          {{"truncate": "4", "reference": "wide"}}, {{"truncate": "2"}}])"#,
            graph.display()
        ),
    )
    .expect("suite");
    let csv = dir.path().join("b.csv");
    let o = tyndall(&[
        "bench",
        &suite.display().to_string(),
        "--csv",
        &csv.display().to_string(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{err}");
    // Settings 2 (the suite's reference) and 3 (the named one) reuse it; 1 and 4 do not.
    assert_eq!(
        err.matches("its first run: the reference's evaluation")
            .count(),
        2,
        "{err}"
    );
    assert!(
        out.contains("2 runs per setting (fewer once they pass 60 s)"),
        "{out}"
    );
    let rows =
        tyndall::bench::report::rows_from_csv(&std::fs::read(&csv).expect("csv")).expect("parse");
    let rows = &rows[0].2;
    assert_eq!(rows.len(), 4);
    // The reused rows still compare against their reference: themselves, exactly.
    assert_eq!(rows[1].rmse, 0.0, "{}", rows[1].setting);
    assert_eq!(rows[2].rmse, 0.0, "{}", rows[2].setting);
    assert!(rows[0].rmse > 0.0, "{}", rows[0].setting);
}

/// A temporal suite evaluates every setting at each frame against the reference of that frame:
/// a setting equal to the reference has no error and no flicker; a coarse one has both, and
/// the CSV carries the flicker and the reference's own change.
#[test]
fn bench_temporal_reports_error_and_flicker_along_the_frames() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let suite = dir.path().join("temporal.ron");
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/bench/temporal.ron");
    std::fs::write(
        &suite,
        format!(
            r#"(title: "Temporal test", graph: "{}", node: "scatter", output: "inscatter",
                size: (48, 27), runs: 1, frames: [1.0, 40.0, 80.0],
                reference: {{"method": "BruteForce", "steps": "64", "shadow.resolution": "256"}},
                configs: [{{"method": "BruteForce", "steps": "64", "shadow.resolution": "256"}},
                          {{"method": "BruteForce", "steps": "4", "shadow.resolution": "256"}}])"#,
            graph.display()
        ),
    )
    .expect("suite");
    let csv = dir.path().join("t.csv");
    let o = tyndall(&[
        "bench",
        &suite.display().to_string(),
        "--csv",
        &csv.display().to_string(),
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        out.contains("flicker") && out.contains("ref change"),
        "{out}"
    );
    let text = std::fs::read_to_string(&csv).expect("csv");
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let headers = r.headers().expect("headers").clone();
    let col = |name: &str| headers.iter().position(|h| h == name).expect(name);
    let (rmse, flicker, change) = (col("rmse"), col("flicker"), col("ref_change"));
    let rows: Vec<csv::StringRecord> = r.records().map(|x| x.expect("row")).collect();
    let f = |row: &csv::StringRecord, i: usize| row[i].parse::<f64>().expect("a number");
    assert_eq!(rows.len(), 2);
    assert_eq!(f(&rows[0], rmse), 0.0);
    assert_eq!(f(&rows[0], flicker), 0.0);
    assert!(f(&rows[1], rmse) > 0.0 && f(&rows[1], flicker) > 0.0);
    // The camera walks: the reference changes between frames.
    assert!(f(&rows[0], change) > 0.0);
}

/// `tyndall bench NAME` with a folder `benches/NAME/` runs every suite in it, one CSV each.
#[test]
fn bench_folder_runs_every_suite() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "bench",
            "visibility",
            "--runs",
            "1",
            "--size",
            "8x4",
            "--csv",
        ])
        .arg(dir.path())
        .output()
        .expect("run");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("(tree, 2048² map)") && out.contains("(window, 2048² map)"),
        "{out}"
    );
    for name in ["tree.csv", "window.csv"] {
        assert!(dir.path().join(name).is_file(), "{name} missing");
    }
}

/// `tyndall bench` with no suite runs every suite under `benches/` (folders included), writes
/// `bench/results.csv` (settings, chain steps and per-node rows), the plots, and rewrites the
/// suites' blocks of BENCHMARKS.md between their markers, keeping the prose and appending a
/// section for a suite without markers; `--quick` runs the reduced sets into `bench/quick/` and
/// leaves BENCHMARKS.md alone.
#[test]
fn bench_without_a_suite_runs_all_and_writes_csv_plots_and_tables() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let graph = |p: &str| root.join(p).display().to_string();
    std::fs::create_dir_all(dir.path().join("benches/sub")).expect("mkdir");
    std::fs::write(
        dir.path().join("benches/blur.ron"),
        format!(
            r#"(title: "Blur test", graph: "{}", node: "blur", output: "out", size: (64, 36),
                runs: 1, reference: {{"truncate": "6"}}, kernel: ["truncate"], quick: [0],
                configs: [{{"truncate": "1"}}, {{"truncate": "2"}}, {{"truncate": "3"}}])"#,
            graph("graphs/bench/blur.ron")
        ),
    )
    .expect("suite");
    std::fs::write(
        dir.path().join("benches/sub/chain.ron"),
        format!(
            r#"(title: "Chain test", graph: "{}", size: (32, 18), runs: 1, chain: true,
                configs: [{{"cold": "true"}}, {{"close.radius": "3"}},
                          {{"target": "tonemap_physical.out", "tonemap_physical.exposure": "1"}}])"#,
            graph("tests/fixtures/flat/tree_hole_filling.ron")
        ),
    )
    .expect("suite");
    let prose = "# Benchmarks\n\nProse stays.\n\n<!-- bench:blur -->\nold table\n<!-- /bench:blur -->\n\nMore prose.\n";
    std::fs::write(dir.path().join("BENCHMARKS.md"), prose).expect("doc");
    let run = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_tyndall"))
            .current_dir(dir.path())
            .arg("bench")
            .args(extra)
            .output()
            .expect("run")
    };
    let o = run(&[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("2 of 2 suites measured"), "{out}");
    // The CSV: a row per setting, a row per chain step with its counts, a row per node and step.
    let csv = std::fs::read_to_string(dir.path().join("bench/results.csv")).expect("results.csv");
    let mut lines = csv.lines();
    let header = lines.next().expect("header");
    assert!(header.starts_with("suite,adapter,node,kind,setting,row,median_ms,min_ms,rmse"));
    let rows: Vec<&str> = lines.collect();
    let of = |suite: &str, row: &str| {
        rows.iter()
            .filter(|l| l.starts_with(&format!("{suite},")) && l.contains(&format!(",{row},")))
            .count()
    };
    assert_eq!(of("blur", "setting"), 3, "{csv}");
    assert_eq!(of("sub/chain", "step"), 3, "{csv}");
    assert_eq!(of("sub/chain", "node"), 3 * 12, "{csv}");
    assert!(
        rows.iter().any(|l| l.starts_with("sub/chain")
            && l.contains("target=tonemap_physical.out")
            && l.ends_with(",1,5,6,,")),
        "the last step: 1 ran, 5 reused, 6 not needed\n{csv}"
    );
    for plot in ["blur-pareto.png", "blur-kernel.png"] {
        let img = image::open(dir.path().join("bench/plots").join(plot)).expect(plot);
        assert_eq!((img.width(), img.height()), (960, 640));
    }
    // The tables: the marked block replaced, the prose kept, the unmarked suite appended.
    let doc = std::fs::read_to_string(dir.path().join("BENCHMARKS.md")).expect("doc");
    assert!(doc.starts_with("# Benchmarks\n\nProse stays.\n\n<!-- bench:blur -->\n```\n$ tyndall bench\nBlur test\nadapter: "), "{doc}");
    assert!(
        !doc.contains("old table") && doc.contains("<!-- /bench:blur -->\n\nMore prose.\n"),
        "{doc}"
    );
    assert!(
        doc.contains("![blur-pareto](bench/plots/blur-pareto.png)"),
        "{doc}"
    );
    assert!(
        doc.contains("## Chain test\n\n<!-- bench:sub/chain -->"),
        "{doc}"
    );
    // --quick: the reduced sets, into bench/quick, BENCHMARKS.md untouched.
    let o = run(&["--quick"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let quick = std::fs::read_to_string(dir.path().join("bench/quick/results.csv")).expect("quick");
    assert_eq!(
        quick.lines().filter(|l| l.starts_with("blur,")).count(),
        1,
        "{quick}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("BENCHMARKS.md")).expect("doc"),
        doc
    );
}

#[test]
fn key_framed_sun_animates_across_frames() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let preset = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/torus.ron");
    let text = std::fs::read_to_string(&preset).expect("preset");
    // Add a custom sun whose elevation is key-framed from 30° at frame 1 to 80° at frame 3.
    let text = text
        .replace(r#""scene": (kind: "Scene", params: {"name": "torus"}"#, r#""scene": (kind: "Scene", params: {"light": "custom", "name": "torus"}"#)
        .replacen("    ],\n)", "    ],\n    keys: {\"scene.sun_elevation\": [(1.0, 30.0, Linear), (3.0, 80.0, Linear)]},\n)", 1);
    let graph = dir.path().join("anim.ron");
    std::fs::write(&graph, text).expect("write");
    let out = dir.path().join("f.png");
    let o = tyndall(&[
        "render",
        &graph.display().to_string(),
        "-o",
        &out.display().to_string(),
        "--frames",
        "1-3",
        "--size",
        "48x27",
        "--stats",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let frames: Vec<_> = (1..=3)
        .map(|f| {
            tyndall::io::read_image(&dir.path().join(format!("f_{f:04}.png")), false)
                .expect("frame")
        })
        .collect();
    assert_ne!(frames[0], frames[1], "the sun moved between frames 1 and 2");
    assert_ne!(frames[1], frames[2], "the sun moved between frames 2 and 3");
    // --stats prints one block per frame.
    let stats = String::from_utf8_lossy(&o.stdout);
    assert_eq!(stats.matches("frame ").count(), 3, "{stats}");
}

/// `tyndall pick`: JSON with V̄, depth, TF coordinates and the surface point; a pixel outside
/// the image is an evaluation error (exit 1), a malformed one bad input (exit 2).
#[test]
fn pick_prints_what_a_pixel_sees() {
    if !gpu_available() {
        return;
    }
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/color/alarm_tree.ron");
    let g = graph.display().to_string();
    let out = tyndall(&["pick", &g, "--pixel", "80,33", "--size", "160x90", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    // The transfer function is inside the preset's AlarmTF group: picked as group/inner.
    assert_eq!(v["node"], "alarm/alarm");
    assert_eq!(v["size"], serde_json::json!([160, 90]));
    let vis = v["visibility"].as_f64().expect("visibility");
    assert!((0.0..=1.0).contains(&vis));
    assert_eq!(v["tf"]["u"].as_f64(), Some(vis));
    assert_eq!(v["tf"]["depth_range"], "auto");
    assert_eq!(v["surface"]["object"], "canopy");
    assert_eq!(v["surface"]["bary"].as_array().map(Vec::len), Some(3));
    let text = tyndall(&["pick", &g, "--pixel", "80,33", "--size", "160x90"]);
    let s = String::from_utf8_lossy(&text.stdout);
    assert!(s.contains("anchor: Some((object: \"canopy\""), "{s}");
    let outside = tyndall(&["pick", &g, "--pixel", "500,10", "--size", "160x90"]);
    assert_eq!(outside.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&outside.stderr).contains("outside the 160×90 image"));
    let bad = tyndall(&["pick", &g, "--pixel", "12"]);
    assert_eq!(bad.status.code(), Some(2));
}

/// Long work reports progress: without a terminal, plain lines on stderr.
#[test]
fn a_light_map_solve_reports_progress_lines() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let g = dir.path().join("solve.ron");
    std::fs::write(
        &g,
        r#"(version: 2, nodes: {
    "scene": (kind: "Scene", params: {"name": "window"}),
    "shadow": (kind: "ShadowMap", params: {"resolution": 128}),
    "solve": (kind: "LightMapSolve", params: {"resolution": 8, "iterations": 3, "steps": 8},
              data: (views: [(camera: Scene, width: 48, height: 27, strokes: [
                  (colour: (1.0, 0.2, 0.0), width: 6.0, points: [(5.0, 18.0), (12.0, 14.0)])])])),
}, edges: [("scene.scene", "shadow.scene"), ("scene.scene", "solve.scene"), ("shadow.map", "solve.shadow")])"#,
    )
    .expect("write");
    let out_file = dir.path().join("r.exr");
    let out = tyndall(&[
        "eval",
        &g.display().to_string(),
        "--output",
        &format!("solve.residual={}", out_file.display()),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("solve: 0/3"), "{err}");
    assert!(
        err.contains("solve: 3/3") && err.contains("residual"),
        "{err}"
    );
}

#[test]
fn with_no_usable_adapter_every_gpu_command_exits_1_in_a_few_lines() {
    // Vulkan only, and the Vulkan drivers hidden: no adapter at all.
    let dir = tempfile::tempdir().expect("tempdir");
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let graph = graph.display().to_string();
    let out = dir.path().join("w.png").display().to_string();
    let a = format!("in={}", fixture("A.exr"));
    let c = format!("out={}", dir.path().join("C.exr").display());
    let commands: Vec<Vec<&str>> = vec![
        vec!["render", &graph, "-o", &out, "--size", "32x18"],
        vec!["eval", &graph],
        vec!["pick", &graph, "--pixel", "1,1"],
        vec!["node", "Blur", "--input", &a, "--output", &c],
        vec!["bench", "visibility", "--quick"],
    ];
    for args in commands {
        let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
            .args(&args)
            .env("WGPU_BACKEND", "vulkan")
            .env("VK_ICD_FILENAMES", "/nonexistent")
            .env("VK_DRIVER_FILES", "/nonexistent")
            .env_remove("TYNDALL_ADAPTER")
            .current_dir(dir.path())
            .output()
            .expect("run tyndall");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        assert!(lines.len() <= 4, "{args:?}: at most 4 lines, got:\n{err}");
        assert!(err.contains("no GPU adapter found"), "{args:?}: {err}");
        assert!(err.contains("mesa-vulkan-drivers"), "{args:?}: {err}");
        assert!(
            !err.contains("wgpu"),
            "{args:?}: no wgpu error stacks: {err}"
        );
    }
}

#[test]
fn info_lists_adapters_and_the_one_used_and_refuses_a_bad_choice() {
    if !gpu_available() {
        return;
    }
    let o = tyndall(&["info", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    assert_eq!(v["graph_format"], tyndall::graph::FORMAT_VERSION);
    assert_eq!(v["tyndall"], env!("CARGO_PKG_VERSION"));
    let adapters = v["adapters"].as_array().expect("adapters");
    assert!(!adapters.is_empty());
    let used = v["used"].as_u64().expect("an adapter is used") as usize;
    assert_eq!(adapters[used]["qualifies"], true);
    for a in adapters {
        for key in [
            "name",
            "backend",
            "device_type",
            "driver",
            "lacks",
            "nodes_unavailable",
            "limits",
        ] {
            assert!(a.get(key).is_some(), "adapter without {key}: {a}");
        }
    }
    let text = String::from_utf8_lossy(&tyndall(&["info"]).stdout).into_owned();
    assert!(text.contains("<- used"), "{text}");
    assert!(text.contains("graph format v"), "{text}");
    // By index: the one in use is accepted; one past the end is refused in one line.
    let dir = tempfile::tempdir().expect("tempdir");
    let a = format!("in={}", fixture("A.exr"));
    let c = format!("out={}", dir.path().join("C.exr").display());
    let blur = ["node", "Blur", "--input", &a, "--output", &c];
    let used_s = used.to_string();
    let o = tyndall(&[&["--adapter", &used_s][..], &blur[..]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let n = adapters.len().to_string();
    let o = tyndall(&[&blur[..], &["--adapter", "99"][..]].concat());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("there are only {n} adapters")),
        "{err}"
    );
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(blur)
        .env("TYNDALL_ADAPTER", "no-such-adapter")
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("names no adapter"), "{err}");
}

/// A parameter set where it is not in effect (Mie's `radius` under the default preset) is kept
/// but warned about, naming what would make it count; set where it counts, no warning.
#[test]
fn setting_a_parameter_that_is_not_in_effect_warns() {
    if common::gpu().is_none() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("mie.exr");
    let out = format!("phase={}", out.display());
    let quick = [
        "--param",
        "radii=2",
        "--param",
        "samples=900",
        "--output",
        &out,
    ];
    let mut args = vec!["node", "Mie", "--param", "radius=3"];
    args.extend(quick);
    let o = tyndall(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("mie.radius is set but changes nothing: it counts only with preset = custom"),
        "{err}"
    );
    let mut args = vec![
        "node",
        "Mie",
        "--param",
        "preset=custom",
        "--param",
        "radius=3",
    ];
    args.extend(quick);
    let o = tyndall(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("changes nothing"), "{err}");
}

/// `--proxy F`: the picture at 1/F of the size with the light-space sizes divided too (the
/// scattering of a 512² map instead of 2048²: a different picture than the full render at the
/// small size, which keeps the 2048² map); 0 and 65 are refused with exit 2.
#[test]
fn render_proxy_divides_the_size_and_the_light_space() {
    let dir = tempfile::tempdir().expect("tempdir");
    let graph = concat!(env!("CARGO_MANIFEST_DIR"), "/graphs/physical/window.ron");
    for bad in ["0", "65"] {
        let o = tyndall(&["render", graph, "-o", "/dev/null", "--proxy", bad]);
        assert_eq!(o.status.code(), Some(2), "--proxy {bad}");
    }
    if !gpu_available() {
        return;
    }
    let proxy = dir.path().join("p.exr");
    let small = dir.path().join("s.exr");
    let run = |args: &[&str]| {
        let o = tyndall(args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&[
        "render",
        graph,
        "-o",
        proxy.to_str().expect("path"),
        "--size",
        "128x72",
        "--proxy",
        "4",
    ]);
    run(&[
        "render",
        graph,
        "-o",
        small.to_str().expect("path"),
        "--size",
        "32x18",
    ]);
    let p = tyndall::io::read_image(&proxy, false).expect("proxy");
    let s = tyndall::io::read_image(&small, false).expect("small");
    assert_eq!((p.width, p.height), (32, 18));
    assert_eq!((s.width, s.height), (32, 18));
    assert_ne!(p.data, s.data, "the proxy's shadow map is not the full one");
}

/// Pipelines compiled once per machine: a second process rendering the same graph compiles none
/// (`--stats`), a corrupt cache file is ignored with a warning and rebuilt. On an adapter without
/// a pipeline cache (wgpu's GL backend) no such file is written and every process compiles. On
/// every adapter the second process makes pipelines up front on worker threads (the recipes
/// file), and its picture is the first's, byte for byte.
#[test]
fn a_second_render_compiles_no_pipeline_and_a_corrupt_cache_is_ignored() {
    if !gpu_available() {
        return;
    }
    let cache = tempfile::tempdir().expect("tempdir");
    let dir = tempfile::tempdir().expect("tempdir");
    let render = || {
        let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
            .env("TYNDALL_CACHE_DIR", cache.path())
            .args([
                "render",
                "graphs/physical/window.ron",
                "-o",
                &dir.path().join("w.png").display().to_string(),
                "--size",
                "64x36",
                "--stats",
            ])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .expect("run tyndall");
        let (out, err) = (
            String::from_utf8_lossy(&o.stdout).into_owned(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        );
        assert!(o.status.success(), "{err}");
        let line = out
            .lines()
            .find(|l| l.starts_with("pipelines: "))
            .unwrap_or_else(|| panic!("no pipelines line in {out}"))
            .to_string();
        let n = |what: &str| -> u64 {
            line.split(", ")
                .find(|p| p.contains(what))
                .and_then(|p| p.split_whitespace().find_map(|w| w.parse().ok()))
                .unwrap_or_else(|| panic!("{line}"))
        };
        let up_front = out
            .lines()
            .find_map(|l| l.strip_prefix("pipelines made up front on worker threads: "))
            .and_then(|l| l.split_whitespace().next()?.parse().ok())
            .unwrap_or(0u64);
        (n("compiled"), n("from the cache"), up_front, err)
    };
    let picture = || std::fs::read(dir.path().join("w.png")).expect("picture");
    let (compiled, cached, up_front, _) = render();
    assert!(compiled > 0 && cached == 0, "first: {compiled}, {cached}");
    assert_eq!(up_front, 0, "nothing is known before the first process");
    let first = picture();
    let files: Vec<_> = std::fs::read_dir(cache.path())
        .expect("cache dir")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "bin"))
        .collect();
    // The second process makes (at least most of) the pipelines up front: every compute
    // pipeline the first used; raster pipelines are made when their node runs.
    let (second, from_cache, up_front, err) = render();
    assert!(
        up_front > 0 && up_front <= second + from_cache,
        "up front {up_front} of {second} + {from_cache}: {err}"
    );
    assert!(
        first == picture(),
        "pipelines made up front change the picture"
    );
    if files.is_empty() {
        // No pipeline cache on this adapter: the next process compiles them all again.
        assert_eq!(second, compiled, "without a cache every process compiles");
        return;
    }
    assert_eq!(files.len(), 1, "{files:?}");
    assert_eq!((second, from_cache), (0, compiled), "second process: {err}");
    // A corrupt file (one byte flipped): a warning, everything compiled, the file rebuilt.
    let mut bytes = std::fs::read(&files[0]).expect("read cache");
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x55;
    std::fs::write(&files[0], &bytes).expect("corrupt");
    let (again, from_cache, _, err) = render();
    assert_eq!((again, from_cache), (compiled, 0), "{err}");
    assert!(err.contains("ignoring the pipeline cache"), "{err}");
    let (after, cached_after, _, err) = render();
    assert_eq!((after, cached_after), (0, compiled), "rebuilt: {err}");
    // A foreign file (another program's bytes under the same name): the same.
    std::fs::write(&files[0], b"not a pipeline cache").expect("foreign");
    let (foreign, _, _, err) = render();
    assert_eq!(foreign, compiled);
    assert!(err.contains("not a Tyndall pipeline cache"), "{err}");
}

/// `--trace FILE`: a Chrome trace-event JSON that parses, with a complete event (`"ph": "X"`)
/// for every node of the graph at every frame, the pipelines created, the read-backs with their
/// bytes, and each file written with its frame and path; with `--stats` the GPU passes too.
#[test]
fn the_trace_parses_and_names_every_node_at_every_frame() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let trace = dir.path().join("run.trace.json");
    let graph = "graphs/stylize/tree_holes_animated.ron";
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .env("TYNDALL_CACHE_DIR", "")
        .args([
            "render",
            graph,
            "-o",
            &dir.path().join("f_####.png").display().to_string(),
            "--frames",
            "1-2",
            "--size",
            "64x36",
            "--stats",
            "--trace",
            &trace.display().to_string(),
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("run tyndall");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&trace).expect("trace written")).expect("JSON");
    let events = doc["traceEvents"].as_array().expect("traceEvents");
    let complete: Vec<&serde_json::Value> = events.iter().filter(|e| e["ph"] == "X").collect();
    assert!(complete
        .iter()
        .all(|e| e["ts"].as_f64().is_some_and(|t| t >= 0.0)
            && e["dur"].as_f64().is_some_and(|d| d >= 0.0)));
    let of = |cat: &str| -> Vec<&serde_json::Value> {
        complete
            .iter()
            .copied()
            .filter(|e| e["cat"] == cat)
            .collect()
    };
    // Every node of the (flattened) graph ran at each frame: the first evaluates everything,
    // the second what the time changes; each node appears at least once, with its frame.
    let registry = tyndall::nodes::registry();
    let g = tyndall::graph::load_file(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(graph),
        registry.catalog(),
    )
    .expect("graph")
    .flatten(registry.catalog())
    .expect("flatten");
    let nodes = of("node");
    for n in g.nodes() {
        assert!(
            nodes
                .iter()
                .any(|e| e["name"] == n.id.as_str() && e["args"]["frame"] == 1),
            "node {} at frame 1",
            n.id
        );
    }
    assert!(
        nodes.iter().any(|e| e["args"]["frame"] == 2),
        "frame 2's nodes"
    );
    assert!(!of("pipeline").is_empty(), "pipeline creations");
    assert!(!of("gpu").is_empty(), "GPU passes (timed with --stats)");
    // The GPU track is on the trace's clock: a frame's passes end before its picture has been
    // read back (the read-back waits for them; the out node is the last of each frame here).
    // Passes are placed late by at most the shortest wait between a pass's end and the reading
    // of its timestamps (1.3–3.4 ms in five runs of this debug binary, more on a loaded
    // machine): 50 ms allowed. Placed by the first pass read instead, a pipelined frame's passes
    // fell late by about its whole GPU time (517 ms here), which this catches.
    let end =
        |e: &&serde_json::Value| e["ts"].as_f64().unwrap_or(0.0) + e["dur"].as_f64().unwrap_or(0.0);
    for f in [1, 2] {
        let of_frame = |cat: &str| -> Vec<f64> {
            of(cat)
                .iter()
                .filter(|e| e["args"]["frame"] == f)
                .map(end)
                .collect()
        };
        let read = of_frame("readback").into_iter().fold(0.0, f64::max);
        let gpu = of_frame("gpu").into_iter().fold(0.0, f64::max);
        assert!(
            read > 0.0 && gpu > 0.0,
            "frame {f}: read-back and GPU passes traced"
        );
        assert!(
            gpu <= read + 50e3,
            "frame {f}: GPU passes end at {gpu} µs, read back by {read} µs"
        );
    }
    assert!(of("readback")
        .iter()
        .all(|e| e["args"]["bytes"].as_u64().is_some_and(|b| b > 0)));
    let writes = of("write");
    assert_eq!(writes.len(), 2, "one file per frame");
    for (w, f) in writes.iter().zip([1, 2]) {
        assert_eq!(w["args"]["frame"], f);
        assert!(w["args"]["path"]
            .as_str()
            .is_some_and(|p| p.ends_with(&format!("f_000{f}.png"))));
    }
}

/// A sequence writes its files on background threads while the next frame evaluates (the
/// trace's write events are on writer threads, not the evaluating one, and so are the
/// read-backs of the written pictures: the evaluating thread never waits for them), and every
/// file is byte for byte the one the same frame rendered alone writes.
#[test]
fn a_sequence_written_in_the_background_equals_its_frames_rendered_alone() {
    if !gpu_available() {
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let render = |out: &str, frames: &str, trace: Option<&std::path::Path>| {
        let mut args = vec![
            "render".to_string(),
            "graphs/stylize/tree_holes_animated.ron".into(),
            "-o".into(),
            dir.path().join(out).display().to_string(),
            "--frames".into(),
            frames.into(),
            "--size".into(),
            "96x54".into(),
        ];
        if let Some(t) = trace {
            args.extend(["--trace".to_string(), t.display().to_string()]);
        }
        let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
            .args(&args)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .expect("run tyndall");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    let trace = dir.path().join("seq.json");
    render("seq_####.exr", "1-4", Some(&trace));
    for f in 1..=4 {
        render(&format!("one{f}_####.exr"), &format!("{f}-{f}"), None);
        let seq = std::fs::read(dir.path().join(format!("seq_000{f}.exr"))).expect("seq");
        let one = std::fs::read(dir.path().join(format!("one{f}_000{f}.exr"))).expect("alone");
        assert!(
            seq == one,
            "frame {f} differs from the frame rendered alone"
        );
    }
    let doc: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&trace).expect("trace")).expect("JSON");
    let events = doc["traceEvents"].as_array().expect("events");
    let track_of = |cat: &str| -> std::collections::BTreeSet<u64> {
        events
            .iter()
            .filter(|e| e["cat"] == cat)
            .filter_map(|e| e["tid"].as_u64())
            .collect()
    };
    let (writes, nodes) = (track_of("write"), track_of("node"));
    assert_eq!(events.iter().filter(|e| e["cat"] == "write").count(), 4);
    assert!(
        writes.is_disjoint(&nodes),
        "writes {writes:?} on the nodes' thread {nodes:?}"
    );
    let read_by_writers = events
        .iter()
        .filter(|e| e["cat"] == "readback")
        .filter(|e| e["tid"].as_u64().is_some_and(|t| writes.contains(&t)))
        .count();
    assert_eq!(
        read_by_writers, 4,
        "each frame's picture read back by its writer"
    );
}

/// The colour config (issue #45): `tyndall info` names the one in use (the built-in ACES 2.0 CG
/// config by default, `--ocio` or `$OCIO` another) with its displays, views and looks; a config
/// that cannot be read is bad input (exit 2) naming it.
#[test]
fn info_names_the_colour_config_and_a_bad_one_is_refused() {
    let o = tyndall(&["info", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON");
    let colour = &v["colour"];
    assert_eq!(
        colour["config"], "ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5",
        "{colour}"
    );
    assert_eq!(colour["working_space"], "Linear Rec.709 (sRGB)");
    let displays = colour["displays"].as_array().expect("displays");
    assert_eq!(displays[0]["name"], "sRGB - Display", "{colour}");
    assert!(
        displays[0]["views"]
            .as_array()
            .expect("views")
            .iter()
            .any(|v| v == "Un-tone-mapped"),
        "{colour}"
    );
    let text = String::from_utf8_lossy(
        &tyndall(&[
            "--ocio",
            "ocio://studio-config-v4.0.0_aces-v2.0_ocio-v2.5",
            "info",
        ])
        .stdout,
    )
    .into_owned();
    assert!(
        text.contains("colour config: ocio://studio-config-v4.0.0_aces-v2.0_ocio-v2.5"),
        "{text}"
    );
    let o = tyndall(&["--ocio", "/no/such/config.ocio", "info"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("/no/such/config.ocio"), "{err}");
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(["info"])
        .env("OCIO", "ocio://cg-config-v2.2.0_aces-v1.3_ocio-v2.4")
        .output()
        .expect("run");
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("colour config: ocio://cg-config-v2.2.0_aces-v1.3_ocio-v2.4"),
        "{text}"
    );
}

/// `tyndall job` refuses what it cannot turn into a job, as bad input (exit 2): a frame spec it
/// cannot read, a chunk of no frames, a graph that does not load.
#[test]
fn tyndall_job_refuses_bad_input() {
    let dir = tempfile::tempdir().expect("tempdir");
    let job = dir.path().join("job.yaml").display().to_string();
    let graph = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("graphs/physical/window.ron")
        .display()
        .to_string();
    for args in [
        vec![
            "job",
            &graph,
            "--frames",
            "9-x",
            "--output-dir",
            "r",
            "-o",
            &job,
        ],
        vec![
            "job",
            &graph,
            "--frames",
            "1-4",
            "--chunk",
            "0",
            "--output-dir",
            "r",
            "-o",
            &job,
        ],
        vec![
            "job",
            "no_such.ron",
            "--frames",
            "1-4",
            "--output-dir",
            "r",
            "-o",
            &job,
        ],
    ] {
        let o = tyndall(&args);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert!(!Path::new(&job).exists(), "{args:?} wrote a job");
    }
}
