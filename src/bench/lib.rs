//! `tyndall bench`: speed against accuracy for a node's quality settings, measured in one run on
//! one input against a high-quality reference.
//!
//! A suite is a RON file (`benches/<name>.ron`) naming a graph, the node to measure, the output
//! to compare, an optional reference setting and the settings to measure. In a setting, plain
//! keys are parameters of the measured node, `node.param` keys set other nodes (e.g. the map
//! resolution), the key `node` measures another node, `output` compares another of its ports,
//! `time` (`a+b+c`) times the sum of several nodes (all re-run each time: a chain such as
//! downsample + march + upsample), `runs` lowers the suite's run count for a slow setting,
//! and `reference` compares with one of the suite's named
//! `references` instead of its `reference`. Each setting runs `runs` times, or fewer once its
//! runs have taken the suite's `row_budget_ms` (the measured node's cached result dropped each
//! time, its inputs kept; a reference that is also a later setting counts as that setting's
//! first run when more runs follow or it took at least the row budget, so a long one is
//! evaluated once); the table reports the
//! median (of two runs, the faster) and minimum wall-clock time of that node (GPU work included: the evaluator waits for
//! completion), the RMSE and maximum error against the reference, and optionally the ratio to
//! the first setting of its group (same settings but the kernel parameter) and hole counts.
//!
//! A **chain** suite (`chain: true`) measures a whole graph instead: its settings are steps run
//! in order on one evaluator (changes accumulate), each reporting every node's time and how many
//! nodes ran, were reused and were not needed ([`chain`]). `tyndall bench` with no name runs every
//! suite, writes one long CSV ([`report::results_csv`]), the plots ([`plot`]) and the tables of
//! BENCHMARKS.md between their markers ([`report::update_doc`]).
#![deny(missing_docs)]

pub mod chain;
pub mod documents;
pub mod interactive;
mod metrics;
use metrics::errors;
pub use metrics::{count_components, discontinuities, masked_rmse};
pub use suite::Suite;
pub mod plot;
mod quality;
pub mod record;
pub mod report;
mod suite;
pub mod temporal;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use tyndall_engine::eval::{
    download, resolve_files, EvalOptions, Evaluator, PathPolicy, Registry, Target,
};
use tyndall_engine::gpu::Gpu;
use tyndall_engine::graph::{load_file, split_endpoint, Graph};
use tyndall_engine::io::Raster;

/// One measured row.
#[derive(Debug, Clone)]
pub struct Row {
    /// `key=value` pairs of the setting.
    pub setting: String,
    /// The setting.
    pub params: BTreeMap<String, String>,
    /// Median time, ms.
    pub median_ms: f64,
    /// Minimum time, ms.
    pub min_ms: f64,
    /// RMSE against the reference (NaN without one).
    pub rmse: f64,
    /// Maximum absolute error against the reference (NaN without one).
    pub max_err: f64,
    /// Median time over the group's first row's (1 for that row; NaN without `kernel`).
    pub growth: f64,
    /// Holes in the `before` map and in the output (when `holes` is set).
    pub holes: Option<(usize, usize)>,
    /// Iterations run and the final residual over the start (when `convergence` is set).
    pub convergence: Option<(usize, f64)>,
    /// Peak signal-to-noise ratio against the reference, dB (peak: the reference's largest
    /// value; NaN without a reference).
    pub psnr: f64,
    /// RMSE at depth discontinuities (when `edges` is set).
    pub edge_rmse: f64,
    /// Share of texels (all channels) that differ from the reference (when `differ` is set;
    /// NaN otherwise).
    pub differ: f64,
    /// The measured node's id (empty for a chain step).
    pub node: String,
    /// Its kind (empty for a chain step).
    pub kind: String,
    /// A chain step's counts and per-node times.
    pub chain: Option<chain::Step>,
    /// A temporal suite's `(flicker, reference change)` ([`temporal`]).
    pub temporal: Option<(f64, f64)>,
    /// Bytes read back from the GPU per measured evaluation (an interactive suite's update:
    /// what the editor's worker would read before the window shows the picture).
    pub readback: Option<u64>,
}

impl Row {
    /// A row with the setting and times only (error columns NaN).
    pub fn timed(params: &BTreeMap<String, String>, median_ms: f64, min_ms: f64) -> Self {
        Self {
            setting: describe(params),
            params: params.clone(),
            median_ms,
            min_ms,
            rmse: f64::NAN,
            max_err: f64::NAN,
            growth: f64::NAN,
            holes: None,
            convergence: None,
            psnr: f64::NAN,
            edge_rmse: f64::NAN,
            differ: f64::NAN,
            node: String::new(),
            kind: String::new(),
            chain: None,
            temporal: None,
            readback: None,
        }
    }
}

/// Errors of the bench runner.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The suite or its graph is unusable.
    #[error("{0}")]
    Input(String),
    /// An evaluation failed.
    #[error(transparent)]
    Eval(#[from] Box<tyndall_engine::eval::EvalError>),
}

fn set_one(
    registry: &Registry,
    g: &mut Graph,
    node: &str,
    name: &str,
    value: &str,
) -> Result<(), BenchError> {
    g.set_param_text(registry.catalog(), node, name, value)
        .map_err(|e| BenchError::Input(e.to_string()))
}

/// Apply a setting; returns the measured node.
pub(crate) fn apply(
    registry: &Registry,
    g: &mut Graph,
    default_node: &str,
    setting: &BTreeMap<String, String>,
) -> Result<String, BenchError> {
    let node = setting
        .get("node")
        .cloned()
        .unwrap_or_else(|| default_node.to_string());
    for (key, value) in setting {
        if ["node", "output", "time", "reference", "runs"].contains(&key.as_str()) {
            continue;
        }
        match split_endpoint(key) {
            // `NODE.@data`: the node's data block, as RON text (a TF's layers, strokes…).
            Ok((n, "@data")) => {
                let data = tyndall_engine::graph::NodeData::from_text(value)
                    .map_err(|e| BenchError::Input(format!("{key}: {e}")))?;
                g.set_data(n, Some(data))
                    .map_err(|e| BenchError::Input(e.to_string()))?;
            }
            Ok((n, p)) => set_one(registry, g, n, p, value)?,
            Err(_) => set_one(registry, g, &node, key, value)?,
        }
    }
    Ok(node)
}

/// Load a suite file.
pub fn load_suite(path: &Path) -> Result<Suite, BenchError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| BenchError::Input(format!("{}: {e}", path.display())))?;
    let suite: Suite = ron::Options::default()
        .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
        .from_str(&text)
        .map_err(|e| {
            BenchError::Input(format!("{}:{}: {}", path.display(), e.span.start, e.code))
        })?;
    let n = suite.configs.len();
    for (field, list) in [("slow", &suite.slow), ("quick", &suite.quick)] {
        if let Some(i) = list.iter().find(|i| **i >= n) {
            return Err(BenchError::Input(format!(
                "{}: {field} names setting {i}, but the suite has {n} (0…{})",
                path.display(),
                n.saturating_sub(1)
            )));
        }
    }
    Ok(suite)
}

/// What every kind of suite runs with: the node kinds, the GPU, the suite, the timed runs per
/// setting (a setting's own `runs` may lower it) and the evaluation size (pixels).
pub struct SuiteRun<'a> {
    /// The node kinds.
    pub registry: Arc<Registry>,
    /// The GPU evaluated on.
    pub gpu: Arc<Gpu>,
    /// The suite.
    pub suite: &'a Suite,
    /// Timed runs per setting (≥ 1 is used).
    pub runs: usize,
    /// Evaluation size, pixels.
    pub size: (u32, u32),
}

/// Run a suite; `progress` is called with a line before each setting.
pub fn run(
    registry: Arc<Registry>,
    gpu: Arc<Gpu>,
    suite_path: &Path,
    suite: &Suite,
    runs: usize,
    size: (u32, u32),
    progress: impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let graph_path: PathBuf = suite_path
        .parent()
        .unwrap_or(Path::new("."))
        .join(&suite.graph);
    let run = SuiteRun {
        registry: registry.clone(),
        gpu,
        suite,
        runs,
        size,
    };
    if suite.documents {
        return documents::run(&run, progress);
    }
    let base =
        load_file(&graph_path, registry.catalog()).map_err(|e| BenchError::Input(e.to_string()))?;
    if suite.chain {
        // A chain resolves its files itself, with its sinks' outputs in their own folder.
        return chain::run(&run, &graph_path, &base, progress);
    }
    // The graph names its input files (a glTF shot, a VDB cache) relative to its folder, as
    // `tyndall render` reads them.
    let policy = PathPolicy {
        graph_dir: graph_path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        output_dir: std::env::temp_dir(),
        allow_any: true,
    };
    let base =
        resolve_files(&registry, &base, &policy).map_err(|e| BenchError::Input(e.to_string()))?;
    if !suite.proxies.is_empty() {
        return interactive::run(&run, &base, progress);
    }
    if !suite.frames.is_empty() {
        return temporal::run(&run, &base, progress);
    }
    quality::run(&run, &base, progress)
}

/// A row's time over that of the first row measured before it with equal settings but the
/// suite's `kernel` parameters (and the run count) (1 for that first row; NaN when the suite has no `kernel`).
pub(crate) fn kernel_growth(
    suite: &Suite,
    before: &[Row],
    setting: &BTreeMap<String, String>,
    median: f64,
) -> f64 {
    let group_of = |p: &BTreeMap<String, String>| -> BTreeMap<String, String> {
        p.iter()
            .filter(|(k, _)| !suite.kernel.contains(k) && k.as_str() != "runs")
            .map(|(k, v)| (k.clone(), v.clone()))
            .collect()
    };
    if suite.kernel.is_empty() {
        return f64::NAN;
    }
    before
        .iter()
        .find(|r| group_of(&r.params) == group_of(setting))
        .map_or(1.0, |first| median / first.median_ms.max(1e-9))
}

/// Evaluate `g` for `node.port` and read it back, with the summed cost of the `timed` nodes
/// (empty: the node itself), ms: their run times, or for a reused node the time its cached
/// result took.
pub(crate) fn read_port(
    ev: &mut Evaluator,
    gpu: &Gpu,
    g: &Graph,
    (node, port): (&str, &str),
    timed: &[String],
    opts: &EvalOptions,
) -> Result<(Raster, f64), BenchError> {
    let r = ev
        .evaluate(g, &[Target::Port(node.to_string(), port.to_string())], opts)
        .map_err(Box::new)?;
    let ms = r
        .stats
        .nodes
        .iter()
        .filter(|n| timed.contains(&n.id) || (timed.is_empty() && n.id == node))
        .map(|n| n.cost.as_secs_f64() * 1e3)
        .sum();
    let v = r
        .outputs
        .get(&(node.to_string(), port.to_string()))
        .ok_or_else(|| BenchError::Input(format!("{node}.{port} produced nothing")))?;
    Ok((
        download(&gpu.recorder(), v).map_err(|e| BenchError::Input(e.to_string()))?,
        ms,
    ))
}

/// The nodes a setting times: its `time` key's `a+b` list, else the measured node.
fn timed_of(setting: &Setting, node: &str) -> Vec<String> {
    setting
        .get("time")
        .map(|t| t.split('+').map(|s| s.trim().to_string()).collect())
        .unwrap_or_else(|| vec![node.to_string()])
}

/// One setting of a suite: `key = value` pairs.
type Setting = BTreeMap<String, String>;

/// A setting's own reference, `(name, setting)`: a named one, or the setting with the first
/// matching `reference_as` pair's values put in (named by its description); `None`: the
/// suite's reference, if any.
fn own_reference(
    suite: &Suite,
    setting: &BTreeMap<String, String>,
) -> Result<Option<(String, Setting)>, BenchError> {
    if let Some(name) = setting.get("reference") {
        let spec = suite.references.get(name).cloned().ok_or_else(|| {
            BenchError::Input(format!("no reference named '{name}' in the suite"))
        })?;
        return Ok(Some((name.clone(), spec)));
    }
    Ok(suite
        .reference_as
        .iter()
        .find(|(when, _)| when.iter().all(|(k, v)| setting.get(k) == Some(v)))
        .map(|(_, put)| {
            let mut spec = setting.clone();
            spec.extend(put.clone());
            (describe(&spec), spec)
        }))
}

/// A setting as `key=value` pairs separated by spaces (the CSV's `setting` column).
pub fn describe(p: &BTreeMap<String, String>) -> String {
    p.iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The speed-up of the fastest setting with parameter value `acc` over the fastest baseline
/// setting, both within RMSE `bound`: `(baseline row, accelerated row, factor)`.
pub fn speedup<'a>(
    suite: &Suite,
    rows: &'a [Row],
    acc: &str,
    bound: f64,
) -> Option<(&'a Row, &'a Row, f64)> {
    let (param, base, _) = suite.compare.as_ref()?;
    let best = |value: &str| {
        rows.iter()
            .filter(|r| r.params.get(param).map(String::as_str) == Some(value) && r.rmse <= bound)
            .min_by(|a, b| a.median_ms.total_cmp(&b.median_ms))
    };
    let (b, a) = (best(base)?, best(acc)?);
    Some((b, a, b.median_ms / a.median_ms.max(1e-9)))
}

/// The suite files a bench name stands for: `benches/NAME.ron`, every `.ron` file of the folder
/// `benches/NAME/` (in name order), or the path itself.
pub fn suite_files(name: &str) -> Result<Vec<PathBuf>, BenchError> {
    if name.ends_with(".ron") {
        return Ok(vec![PathBuf::from(name)]);
    }
    let dir = Path::new("benches").join(name);
    if dir.is_dir() {
        let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
            .map_err(|e| BenchError::Input(format!("{}: {e}", dir.display())))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "ron"))
            .collect();
        files.sort();
        return Ok(files);
    }
    Ok(vec![dir.with_extension("ron")])
}

/// A number with `digits` decimals, `-` for NaN.
pub fn cell(v: f64, digits: usize) -> String {
    if v.is_nan() {
        "-".into()
    } else {
        format!("{v:.digits$}")
    }
}
