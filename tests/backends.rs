//! Every preset in `graphs/` renders on wgpu's GL backend (Mesa's llvmpipe here, or a real GPU's
//! GL driver) and matches its Vulkan render.
//!
//! **Metric and tolerance.** Each preset is rendered by the `tyndall` binary with
//! `WGPU_BACKEND=vulkan` and with `WGPU_BACKEND=gl` into float EXR files; per file we take the
//! PSNR over every channel of every pixel, with the peak being the largest reference value (at
//! least 1), and require **≥ 50 dB** (an RMS difference under 0.3 % of the peak). Why not bit
//! equality: the two backends compile the same WGSL through different paths (naga → SPIR-V →
//! lavapipe vs naga → GLSL → Mesa's GLSL compiler), which contract multiply-adds and evaluate
//! `exp`, `pow` and `sin` differently in the last bits; single scattering integrates thousands of
//! such steps and tone mapping follows, so last-bit differences grow to ~1e-5; and a handful of
//! pixels on geometry edges fall on the other side of a triangle edge (GL renders with its
//! window origin flipped, so rasterisation tie-breaks differ: `graphs/physical/window.ron` at
//! 960×540 gives 64 dB with 5 of 518,400 pixels off by more than 0.01, measured with
//! `oiiotool vk.exr gl.exr --fail 0.01 --diff`; the foliage of the tree presets, ~54 dB, has
//! more such edges). Why not looser: a
//! real fault (a missed substitute, a wrong binding, a channel lost in the Rg32F → Rgba32F
//! storage) changes whole regions and falls far below 50 dB. The substitutes themselves are
//! checked bit for bit on one adapter in `tests/platform/gpu.rs`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

/// `tyndall info --json` with `WGPU_BACKEND=backend`.
fn info_on(backend: &str) -> serde_json::Value {
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args(["info", "--json"])
        .env("WGPU_BACKEND", backend)
        .env_remove("TYNDALL_ADAPTER")
        .output()
        .expect("run tyndall info");
    serde_json::from_slice(&o.stdout).expect("info --json is JSON")
}

/// The adapter `tyndall info` would use on `backend`, or why there is none.
fn adapter_on(backend: &str) -> Result<String, String> {
    let v = info_on(backend);
    match v["used"].as_u64() {
        Some(i) => Ok(v["adapters"][i as usize]["name"]
            .as_str()
            .unwrap_or("?")
            .to_string()),
        None => Err(v["error"].as_str().unwrap_or("no adapter").to_string()),
    }
}

/// The node kinds `tyndall info` says the adapter used on `backend` cannot run.
fn unavailable_on(backend: &str) -> Vec<String> {
    let v = info_on(backend);
    let used = v["used"].as_u64().unwrap_or(0) as usize;
    v["adapters"][used]["nodes_unavailable"]
        .as_array()
        .map(|a| {
            a.iter()
                .filter_map(|n| n["kind"].as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default()
}

/// Render `graph` into the folder `dir`: its one output as `dir/out.exr` (float, for a tight
/// comparison), or with several outputs each where the graph puts it under `dir`.
fn render(backend: &str, graph: &Path, dir: &Path, sinks: usize) -> Result<(), String> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_tyndall"));
    cmd.args(["render", &graph.display().to_string()]);
    if sinks == 1 {
        cmd.arg("-o").arg(dir.join("out.exr"));
    } else {
        cmd.arg("--output-dir").arg(dir);
    }
    // 160×90 pictures from a proxy at ¼ (every light-space size divided with the screen's): the
    // comparison is between backends on the same graph, and full-size shadow maps and soft
    // visibility buffers cost minutes of lavapipe time in CI (fence_soft_kernels: 30 s → 2 s).
    let o = cmd
        .args(["--size", "640x360", "--proxy", "4"])
        .env("WGPU_BACKEND", backend)
        .env_remove("TYNDALL_ADAPTER")
        .output()
        .expect("run tyndall render");
    if o.status.success() {
        Ok(())
    } else {
        Err(String::from_utf8_lossy(&o.stderr).into_owned())
    }
}

/// Every file under `dir`, in sub-folders too, sorted.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read_dir") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// PSNR of `b` against `a` (peak: the largest |value| of `a`, at least `peak_floor`) and the
/// largest absolute difference.
fn psnr_values(a: &[f32], b: &[f32], peak_floor: f64) -> (f64, f64) {
    assert_eq!(a.len(), b.len());
    let peak = a.iter().map(|v| v.abs() as f64).fold(peak_floor, f64::max);
    let mut se = 0.0;
    let mut max = 0.0f64;
    for (x, y) in a.iter().zip(b) {
        let d = (*x as f64 - *y as f64).abs();
        se += d * d;
        max = max.max(d);
    }
    let mse = se / a.len().max(1) as f64;
    let db = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (peak * peak / mse).log10()
    };
    (db, max)
}

/// PSNR of picture `b` against `a` (peak at least 1) and the largest absolute difference.
fn psnr(a: &tyndall::io::Raster, b: &tyndall::io::Raster) -> (f64, f64) {
    assert_eq!(
        (a.width, a.height, a.channels),
        (b.width, b.height, b.channels)
    );
    psnr_values(&a.data, &b.data, 1.0)
}

/// Both sides of a GL-vs-Vulkan comparison, or `None` after saying why one is missing (a
/// failure under `TYNDALL_REQUIRE_GPU=1`).
fn both<T, E: std::fmt::Display>(vk: Result<T, E>, gl: Result<T, E>) -> Option<(T, T)> {
    match (vk, gl) {
        (Ok(vk), Ok(gl)) => Some((vk, gl)),
        (vk, gl) => {
            let err = |r: Result<T, E>| r.err().map_or_else(|| "ok".into(), |e| e.to_string());
            let why = format!(
                "GL-vs-Vulkan comparison needs both: vulkan: {}; gl: {}",
                err(vk),
                err(gl)
            );
            if std::env::var("TYNDALL_REQUIRE_GPU").is_ok_and(|v| v == "1") {
                panic!("TYNDALL_REQUIRE_GPU=1: {why}");
            }
            eprintln!("skipping: {why}");
            None
        }
    }
}

#[test]
fn every_preset_renders_on_gl_and_matches_vulkan() {
    let Some((vk, gl)) = both(adapter_on("vulkan"), adapter_on("gl")) else {
        return;
    };
    eprintln!("vulkan: {vk}; gl: {gl}");
    // Nodes GL cannot give what they need (none on Mesa's GL since volumes are written through
    // storage buffers there; a driver with lower limits may have some): a preset using one must
    // fail with one line naming that node and what is missing.
    let unavailable = unavailable_on("gl");
    eprintln!("nodes GL cannot run: {unavailable:?}");
    let mut refused = 0;
    let registry = tyndall::nodes::registry();
    let dir = tempfile::tempdir().expect("tempdir");
    let mut rendered = 0;
    let mut failures = Vec::new();
    for f in common::presets() {
        // Flattened: the kinds inside groups are what GL may lack.
        let g = tyndall::graph::load_file(&f, registry.catalog())
            .expect("load")
            .flatten(registry.catalog())
            .expect("flatten");
        let sinks = g
            .nodes()
            .filter(|n| registry.get(&n.kind).is_some_and(|k| k.is_sink()))
            .count();
        if sinks == 0 {
            continue; // bench inputs: no outputs to render
        }
        let name = f.file_stem().and_then(|s| s.to_str()).unwrap_or("g");
        let (a_dir, b_dir) = (
            dir.path().join("vk").join(name),
            dir.path().join("gl").join(name),
        );
        std::fs::create_dir_all(&a_dir).expect("mkdir");
        std::fs::create_dir_all(&b_dir).expect("mkdir");
        render("vulkan", &f, &a_dir, sinks).expect("the Vulkan render");
        if let Err(e) = render("gl", &f, &b_dir, sinks) {
            let uses: Vec<&String> = unavailable
                .iter()
                .filter(|k| g.nodes().any(|n| &n.kind == *k))
                .collect();
            let lines: Vec<&str> = e.lines().filter(|l| l.contains("error")).collect();
            // Named as the node itself, or as a node inside a group node.
            let named = uses.iter().any(|k| {
                e.contains(&format!("({k}): this adapter"))
                    || e.contains(&format!("({k}): inside group node"))
            });
            if uses.is_empty() || !named || lines.len() != 1 {
                failures.push(format!("{}: GL render failed: {e}", f.display()));
            } else {
                eprintln!("{name}: refused on GL as expected: {}", lines[0]);
                refused += 1;
            }
            continue;
        }
        let files = files_under(&a_dir);
        assert!(!files.is_empty(), "{}: nothing written", f.display());
        for a in files {
            let b = b_dir.join(a.strip_prefix(&a_dir).expect("under a_dir"));
            let ra = tyndall::io::read_image(&a, false).expect("read the Vulkan EXR");
            let rb = match tyndall::io::read_image(&b, false) {
                Ok(r) => r,
                Err(e) => {
                    failures.push(format!("{}: GL wrote no {}: {e}", f.display(), b.display()));
                    continue;
                }
            };
            let (db, max) = psnr(&ra, &rb);
            eprintln!(
                "{name}/{}: {db:.1} dB, max |Δ| {max:.2e}",
                a.file_name().and_then(|s| s.to_str()).unwrap_or("?")
            );
            if db < 50.0 {
                failures.push(format!(
                    "{}: GL differs from Vulkan: {db:.1} dB < 50 dB (max |Δ| {max:.3e})",
                    f.display()
                ));
            }
            rendered += 1;
        }
    }
    assert!(
        rendered >= 18,
        "only {rendered} presets compared ({refused} refused)"
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A context on one backend only (`wgpu::Backends::VULKAN` or `GL`), in this process.
fn gpu_on(backends: wgpu::Backends) -> Result<std::sync::Arc<tyndall::gpu::Gpu>, String> {
    tyndall::gpu::Gpu::with_options(&tyndall::gpu::GpuOptions {
        backends,
        adapter: None,
        ..tyndall::gpu::GpuOptions::from_env()
    })
    .map(std::sync::Arc::new)
    .map_err(|e| e.to_string())
}

/// A value that is not a picture, read back: texels of a table, LUT or light map, or level 0
/// of a volume.
fn read_back(gpu: &tyndall::gpu::Gpu, v: &tyndall::eval::PortValue) -> Vec<f32> {
    use tyndall::eval::PortValue;
    match v {
        PortValue::Volume(vol, _) | PortValue::SoftShadow(vol, _) => {
            gpu.recorder().read_volume(vol, 0).expect("read the volume")
        }
        other => {
            tyndall::eval::download(&gpu.recorder(), other)
                .expect("read back")
                .data
        }
    }
}

/// The outputs that are not pictures — phase tables, volumes (noise, painted, soft visibility),
/// the transfer function's `lut`, light maps — of every preset, evaluated on GL and on Vulkan in
/// this process and compared with the same metric and bound as the pictures above (PSNR over
/// every value, peak the largest |Vulkan value|, ≥ 50 dB). A table, volume or map that comes
/// out empty on one backend (GL's phase tables once did, silently) is 0–30 dB and fails; so
/// does one that is all zero on both.
#[test]
fn every_preset_tables_volumes_and_maps_match_between_gl_and_vulkan() {
    use tyndall::eval::{EvalOptions, Evaluator, Target};
    use tyndall::graph::PortType;
    let Some((vk, gl)) = both(gpu_on(wgpu::Backends::VULKAN), gpu_on(wgpu::Backends::GL)) else {
        return;
    };
    let registry = std::sync::Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let kinds = [
        PortType::Phase,
        PortType::Volume,
        PortType::SoftShadow,
        PortType::Lut2D,
        PortType::LightMap,
    ];
    let opts = EvalOptions {
        size: (160, 90),
        ..EvalOptions::default()
    };
    let mut compared = std::collections::BTreeMap::<PortType, usize>::new();
    let mut failures = Vec::new();
    for f in common::presets() {
        let g = tyndall::graph::load_file(&f, &cat).expect("load");
        let policy = tyndall::eval::PathPolicy {
            graph_dir: f.parent().expect("a file in a folder").to_path_buf(),
            output_dir: std::env::temp_dir(),
            allow_any: false,
        };
        let g = tyndall::eval::resolve_files(&registry, &g, &policy).expect("files");
        // At ¼, light-space sizes divided too (as the picture comparison renders).
        let g = tyndall::eval::proxy::proxy_graph(&g.flatten(&cat).expect("flatten"), &cat, 4);
        if !g
            .nodes()
            .any(|n| registry.get(&n.kind).is_some_and(|k| k.is_sink()))
        {
            continue; // bench inputs (graphs/bench/): no outputs, and their quality is the bench's
        }
        let ports: Vec<((String, String), PortType)> = g
            .output_types(&cat)
            .into_iter()
            .filter(|(_, t)| kinds.contains(t))
            .collect();
        if ports.is_empty() {
            continue;
        }
        let targets: Vec<Target> = ports
            .iter()
            .map(|((n, p), _)| Target::Port(n.clone(), p.clone()))
            .collect();
        let run = |gpu: &std::sync::Arc<tyndall::gpu::Gpu>| {
            let mut ev = Evaluator::new(registry.clone(), gpu.clone());
            let r = ev.evaluate(&g, &targets, &opts);
            r.map(|r| {
                ports
                    .iter()
                    .map(|(k, _)| read_back(gpu, &r.outputs[k]))
                    .collect::<Vec<_>>()
            })
        };
        let name = f.file_stem().and_then(|s| s.to_str()).unwrap_or("g");
        let (a, b) = match (run(&vk), run(&gl)) {
            (Ok(a), Ok(b)) => (a, b),
            (a, b) => {
                failures.push(format!(
                    "{name}: vulkan {:?}, gl {:?}",
                    a.err().map(|e| e.to_string()),
                    b.err().map(|e| e.to_string())
                ));
                continue;
            }
        };
        for ((((node, port), ty), a), b) in ports.iter().zip(&a).zip(&b) {
            let (db, _) = psnr_values(a, b, 0.0);
            let zero = a.iter().all(|v| *v == 0.0);
            eprintln!(
                "{name} {node}.{port} ({ty:?}, {} values): {db:.1} dB",
                a.len()
            );
            if db < 50.0 || zero {
                failures.push(format!(
                    "{name} {node}.{port} ({ty:?}): GL {db:.1} dB against Vulkan (< 50 dB){}",
                    if zero { ", and all zero on Vulkan" } else { "" }
                ));
            }
            *compared.entry(*ty).or_default() += 1;
        }
    }
    eprintln!("compared: {compared:?}");
    for ty in kinds {
        assert!(
            compared.get(&ty).is_some_and(|n| *n > 0),
            "no preset has a {ty:?} output to compare"
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A GL context without compute shaders (what NVIDIA's driver gives wgpu's request for GL 3.3:
/// exactly 3.3, with `GL_ARB_compute_shader` listed) is refused by the adapter check in a few
/// lines naming the context, not by a wall of wgpu pipeline errors at the first node. Mesa's
/// `MESA_GL_VERSION_OVERRIDE=3.3` makes llvmpipe's context such a one.
#[test]
fn a_gl_3_3_context_is_refused_before_any_node_runs() {
    if adapter_on("gl").is_err() {
        if std::env::var("TYNDALL_REQUIRE_GPU").is_ok_and(|v| v == "1") {
            panic!("TYNDALL_REQUIRE_GPU=1 but no GL adapter");
        }
        eprintln!("skipping: no GL adapter");
        return;
    }
    let dir = tempfile::tempdir().expect("tempdir");
    let graph = Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/physical/window.ron");
    let o = Command::new(env!("CARGO_BIN_EXE_tyndall"))
        .args([
            "render",
            &graph.display().to_string(),
            "--size",
            "64x36",
            "-o",
        ])
        .arg(dir.path().join("w.png"))
        .env("WGPU_BACKEND", "gl")
        .env("MESA_GL_VERSION_OVERRIDE", "3.3")
        .env("MESA_GLSL_VERSION_OVERRIDE", "330")
        .env_remove("TYNDALL_ADAPTER")
        .output()
        .expect("run tyndall render");
    let err = String::from_utf8_lossy(&o.stderr);
    if !err.contains("3.3") {
        // Not Mesa (a real GPU's GL driver ignores the override): nothing to check here.
        eprintln!("skipping: the driver did not take MESA_GL_VERSION_OVERRIDE: {err}");
        assert!(o.status.success(), "{err}");
        return;
    }
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("lacks compute shaders") && err.contains("OpenGL 3.3"),
        "{err}"
    );
    assert!(!err.contains("create_compute_pipeline"), "{err}");
    assert!(err.lines().count() <= 4, "{err}");
    assert!(!dir.path().join("w.png").exists());
}
