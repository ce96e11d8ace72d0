//! Shared test helpers.
#![allow(dead_code)]

use std::sync::Arc;

pub mod editor;

use tyndall::gpu::Gpu;

/// The shared GPU context, or `None` (with the reason printed) when no adapter exists here.
/// With `TYNDALL_REQUIRE_GPU=1` (set by `.ci/run`) a missing adapter fails the test instead.
pub fn gpu() -> Option<Arc<Gpu>> {
    match Gpu::shared() {
        Ok(g) => Some(g),
        Err(e) => {
            if std::env::var("TYNDALL_REQUIRE_GPU").is_ok_and(|v| v == "1") {
                panic!("TYNDALL_REQUIRE_GPU=1 but no GPU adapter: {e}");
            }
            eprintln!("skipping GPU test: {e}");
            None
        }
    }
}

/// Run `bash SCRIPT` (a path under the repository) with `TYNDALL_BIN` naming the binary under
/// test; fails the test with the script's output when it fails, else returns that output
/// (stdout, then stderr). The Python package's and the OpenJD farm's tests are such scripts.
pub fn run_script(script: &str) -> String {
    let out = std::process::Command::new("bash")
        .arg(script)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env("TYNDALL_BIN", env!("CARGO_BIN_EXE_tyndall"))
        .output()
        .expect("bash runs");
    let text = format!(
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{script} failed:\n{text}");
    text
}

/// Whether the program `name` runs here (`name ARG` exits 0). Without it the test is skipped
/// with one line naming what to install — or fails, under `TYNDALL_REQUIRE_<NAME>=1` (e.g.
/// `TYNDALL_REQUIRE_OIIOTOOL`, `TYNDALL_REQUIRE_BLENDER`; `.ci/run` sets them all).
pub fn tool(name: &str, arg: &str, install: &str) -> bool {
    let found = std::process::Command::new(name)
        .arg(arg)
        .output()
        .is_ok_and(|o| o.status.success());
    if !found {
        let var = format!("TYNDALL_REQUIRE_{}", name.to_uppercase());
        if std::env::var(&var).is_ok_and(|v| v == "1") {
            panic!("{var}=1 but no `{name}` on PATH ({install})");
        }
        eprintln!("skipping: no `{name}` on PATH ({install})");
    }
    found
}

/// Why the shared adapter cannot run node `kind` (`None`: it can, or `kind` runs no shader):
/// the one-line reason the evaluator gives (e.g. wgpu's GL backend writes no 3D storage
/// textures, so the volume nodes are refused there).
pub fn unsupported(gpu: &Gpu, kind: &str) -> Option<String> {
    let registry = tyndall::nodes::registry();
    let shaders = registry.get(kind)?.decl().shaders;
    shaders
        .iter()
        .find_map(|s| gpu.supports(*s).err())
        .map(|e| format!("{kind}: {e}"))
}

/// The nodes of `graph` the shared adapter cannot run, inside group nodes too (the graph is
/// flattened: ids `group/inner`), as `(id, kind)`.
pub fn refused(gpu: &Gpu, graph: &tyndall::graph::Graph) -> Vec<(String, String)> {
    let registry = tyndall::nodes::registry();
    let flat = graph.flatten(registry.catalog()).expect("flatten");
    flat.nodes()
        .filter(|n| unsupported(gpu, &n.kind).is_some())
        .map(|n| (n.id.clone(), n.kind.clone()))
        .collect()
}

/// [`gpu`], or `None` (printing why) when the adapter cannot run one of `kinds`: a capability
/// the adapter lacks is a skip even under `TYNDALL_REQUIRE_GPU=1` (the refusal itself is
/// tested in `tests/platform/gpu.rs` and `tests/backends.rs`).
pub fn gpu_for(kinds: &[&str]) -> Option<Arc<Gpu>> {
    let gpu = gpu()?;
    if let Some(why) = kinds.iter().find_map(|k| unsupported(&gpu, k)) {
        eprintln!("skipping on this adapter: {why}");
        return None;
    }
    Some(gpu)
}

/// Evaluate to a GPU context that can run these node kinds, or return from the test (see
/// [`gpu_for`]).
#[macro_export]
macro_rules! require_gpu_for {
    ($($kind:expr),+ $(,)?) => {
        match $crate::common::gpu_for(&[$($kind),+]) {
            Some(g) => g,
            None => return,
        }
    };
}

/// Evaluate to a GPU context or return from the test (see [`gpu`]).
#[macro_export]
macro_rules! require_gpu {
    () => {
        match $crate::common::gpu() {
            Some(g) => g,
            None => return,
        }
    };
}

/// Every graph file under `graphs/` (the preset library), sorted; not the library groups of
/// `graphs/lib/`.
pub fn presets() -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    let lib = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs/lib");
    let mut stack = vec![std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("graphs")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("read_dir") {
            let p = e.expect("entry").path();
            if p.is_dir() {
                if p != lib {
                    stack.push(p);
                }
            } else if p.extension().and_then(|x| x.to_str()) == Some("ron") {
                files.push(p);
            }
        }
    }
    files.sort();
    files
}

/// A deterministic pseudo-random sequence (xorshift) for test inputs.
pub struct Rng(pub u64);

impl Rng {
    /// Next value in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Next value in [lo, hi).
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }
}

/// A raster of random values in [lo, hi).
pub fn random_raster(
    w: u32,
    h: u32,
    channels: u32,
    lo: f32,
    hi: f32,
    seed: u64,
) -> tyndall::io::Raster {
    let mut rng = Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let mut r = tyndall::io::Raster::new(w, h, channels, 0.0);
    for v in &mut r.data {
        *v = rng.range(lo, hi);
    }
    r
}

use std::collections::BTreeMap;

use tyndall::eval::{download, upload_raster, EvalOptions, Evaluator, PortValue, Target};
use tyndall::graph::{Graph, ParamValue, PortType};
use tyndall::io::Raster;

/// Upload a raster as a value of `ty`.
pub fn upload(gpu: &tyndall::gpu::Gpu, r: &Raster, ty: PortType) -> PortValue {
    upload_raster(gpu, r, ty).expect("upload")
}

/// Run one node of `kind` on the GPU with these parameters and injected inputs; return the
/// requested outputs read back.
pub fn run_node(
    gpu: &Arc<tyndall::gpu::Gpu>,
    kind: &str,
    params: &[(&str, ParamValue)],
    inputs: Vec<(&str, PortValue)>,
    outputs: &[&str],
    size: (u32, u32),
) -> Result<BTreeMap<String, Raster>, tyndall::eval::EvalError> {
    run_node_with(gpu, kind, params, None, 0.0, inputs, outputs, size)
}

/// [`run_node`] with a data block (RON text) and an evaluation time.
#[allow(clippy::too_many_arguments)]
pub fn run_node_with(
    gpu: &Arc<tyndall::gpu::Gpu>,
    kind: &str,
    params: &[(&str, ParamValue)],
    data: Option<&str>,
    time: f64,
    inputs: Vec<(&str, PortValue)>,
    outputs: &[&str],
    size: (u32, u32),
) -> Result<BTreeMap<String, Raster>, tyndall::eval::EvalError> {
    let registry = Arc::new(tyndall::nodes::registry());
    let cat = registry.catalog().clone();
    let mut g = Graph::new();
    let id = g.add_node(&cat, kind).expect("add node");
    for (name, v) in params {
        g.set_param(&cat, &id, name, v.clone()).expect("param");
    }
    if let Some(d) = data {
        let d = tyndall::graph::NodeData::from_text(d).expect("data block is RON");
        g.set_data(&id, Some(d)).expect("data");
    }
    let mut opts = EvalOptions {
        size,
        time,
        ..Default::default()
    };
    for (i, (port, v)) in inputs.into_iter().enumerate() {
        opts.inject
            .insert((id.clone(), port.to_string()), (v, i as u64 + 1));
    }
    let mut targets: Vec<Target> = outputs
        .iter()
        .map(|p| Target::Port(id.clone(), p.to_string()))
        .collect();
    if targets.is_empty() {
        targets.push(Target::Node(id.clone())); // a sink: write its file
    }
    let mut ev = Evaluator::new(registry, gpu.clone());
    let result = ev.evaluate(&g, &targets, &opts)?;
    Ok(result
        .outputs
        .iter()
        .map(|((_, port), v)| {
            (
                port.clone(),
                download(&gpu.recorder(), v).expect("download"),
            )
        })
        .collect())
}

/// Largest |a − b| over two rasters of equal shape (panics on shape mismatch).
pub fn max_abs_diff(a: &Raster, b: &Raster) -> f32 {
    assert_eq!(
        (a.width, a.height, a.channels),
        (b.width, b.height, b.channels),
        "raster shapes differ"
    );
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

/// A graph with two independent branches writing into `dir`: c1 → m1 (mul by 3) → out1
/// (`one.exr`) and c2 → r2 → out2 (`two.exr`).
pub fn two_branches_ron(dir: &std::path::Path) -> String {
    format!(
        r#"(
    version: 2,
    nodes: {{
        "c1": (kind: "Constant", params: {{"value": 2.0, "width": 8, "height": 8}}),
        "m1": (kind: "Math", params: {{"op": "mul", "b": 3.0}}),
        "out1": (kind: "ImageOutput", params: {{"path": "{0}/one.exr"}}),
        "c2": (kind: "Constant", params: {{"colour": [0.5, 0.25, 1.0, 1.0], "width": 8, "height": 8}}),
        "r2": (kind: "Remap", params: {{"to_max": 2.0}}),
        "out2": (kind: "ImageOutput", params: {{"path": "{0}/two.exr"}}),
    }},
    edges: [("c1.value", "m1.a"), ("m1.out", "out1.image"), ("c2.colour", "r2.in"), ("r2.out", "out2.image")],
)"#,
        dir.display()
    )
}

/// The outputs of one evaluation, by (node, port).
pub struct Outputs {
    gpu: Arc<tyndall::gpu::Gpu>,
    values: BTreeMap<(String, String), PortValue>,
}

impl Outputs {
    /// The outputs of an evaluation on `gpu`.
    pub fn new(gpu: Arc<tyndall::gpu::Gpu>, values: BTreeMap<(String, String), PortValue>) -> Self {
        Self { gpu, values }
    }

    /// The value on `node.port`.
    pub fn get(&self, node: &str, port: &str) -> &PortValue {
        &self.values[&(node.to_string(), port.to_string())]
    }

    /// The value on `node.port`, read back.
    pub fn read(&self, node: &str, port: &str) -> Raster {
        tyndall::eval::download(&self.gpu.recorder(), self.get(node, port)).expect("download")
    }
}

/// Evaluate a graph written as RON for the `(node, port)` outputs at `size`.
pub fn eval_ron(
    gpu: &Arc<tyndall::gpu::Gpu>,
    text: &str,
    ports: &[(&str, &str)],
    size: (u32, u32),
) -> Outputs {
    let registry = Arc::new(tyndall::nodes::registry());
    let g = tyndall::graph::load_str(text, std::path::Path::new("g.ron"), registry.catalog())
        .expect("graph");
    let targets: Vec<tyndall::eval::Target> = ports
        .iter()
        .map(|(n, p)| tyndall::eval::Target::Port(n.to_string(), p.to_string()))
        .collect();
    let opts = tyndall::eval::EvalOptions {
        size,
        ..Default::default()
    };
    let r = tyndall::eval::Evaluator::new(registry, gpu.clone())
        .evaluate(&g, &targets, &opts)
        .expect("evaluate");
    Outputs {
        gpu: gpu.clone(),
        values: r.outputs,
    }
}
