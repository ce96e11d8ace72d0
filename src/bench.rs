//! `tyndall bench`: speed against accuracy for a node's quality settings, measured in one run on
//! one input against a high-quality reference.
//!
//! A suite is a RON file (`benches/<name>.ron`) naming a graph, the node to vary, the output to
//! compare, a reference setting and the settings to measure. For each setting the node runs
//! `runs` times (its cached result dropped each time, its inputs kept); the table reports the
//! median and minimum wall-clock time of the node (GPU work included: the evaluator waits for
//! completion) and the RMSE and maximum error of the output against the reference.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Deserialize;

use crate::eval::{download, EvalOptions, Evaluator, Registry, Target};
use crate::gpu::Gpu;
use crate::graph::{load_file, Graph};
use crate::io::Raster;

/// A benchmark suite file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Suite {
    /// One line saying what is measured.
    pub title: String,
    /// The graph, relative to the suite file.
    pub graph: String,
    /// Node whose settings vary.
    pub node: String,
    /// Output port of that node compared with the reference.
    pub output: String,
    /// Evaluation size.
    pub size: (u32, u32),
    /// Runs per setting (the median is reported).
    pub runs: usize,
    /// Parameter values of the reference.
    pub reference: BTreeMap<String, String>,
    /// Parameter values of each measured setting.
    pub configs: Vec<BTreeMap<String, String>>,
    /// Error bound for the speed-up comparison.
    pub target_rmse: f64,
    /// `(parameter, baseline value, accelerated value)`: the speed-up reported is the time of the
    /// fastest baseline setting within `target_rmse` over that of the fastest accelerated one.
    pub compare: (String, String, String),
}

/// One measured row.
#[derive(Debug, Clone)]
pub struct Row {
    /// `name=value` pairs of the setting.
    pub setting: String,
    /// The setting's parameters.
    pub params: BTreeMap<String, String>,
    /// Median time, ms.
    pub median_ms: f64,
    /// Minimum time, ms.
    pub min_ms: f64,
    /// RMSE against the reference.
    pub rmse: f64,
    /// Maximum absolute error against the reference.
    pub max_err: f64,
}

/// Errors of the bench runner.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    /// The suite or its graph is unusable.
    #[error("{0}")]
    Input(String),
    /// An evaluation failed.
    #[error(transparent)]
    Eval(#[from] Box<crate::eval::EvalError>),
}

fn set(
    registry: &Registry,
    g: &mut Graph,
    node: &str,
    params: &BTreeMap<String, String>,
) -> Result<(), BenchError> {
    let kind = g
        .node(node)
        .map(|n| n.kind.clone())
        .ok_or_else(|| BenchError::Input(format!("no node '{node}'")))?;
    let schema = registry
        .catalog()
        .get(&kind)
        .ok_or_else(|| BenchError::Input(format!("unknown kind {kind}")))?;
    for (name, value) in params {
        let spec = schema
            .param(name)
            .ok_or_else(|| BenchError::Input(format!("{kind} has no parameter '{name}'")))?;
        let v = spec.parse_str(value).map_err(|_| {
            BenchError::Input(format!(
                "{node}.{name}: '{value}' is not {}",
                spec.expected()
            ))
        })?;
        g.set_param(registry.catalog(), node, name, v)
            .map_err(|e| BenchError::Input(e.to_string()))?;
    }
    Ok(())
}

fn errors(a: &Raster, b: &Raster) -> (f64, f64) {
    let n = a.data.len().max(1) as f64;
    let mut sq = 0.0;
    let mut mx = 0.0f64;
    for (x, y) in a.data.iter().zip(&b.data) {
        let d = (*x as f64 - *y as f64).abs();
        sq += d * d;
        mx = mx.max(d);
    }
    ((sq / n).sqrt(), mx)
}

/// Load a suite file.
pub fn load_suite(path: &Path) -> Result<Suite, BenchError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| BenchError::Input(format!("{}: {e}", path.display())))?;
    ron::from_str(&text)
        .map_err(|e| BenchError::Input(format!("{}:{}: {}", path.display(), e.span.start, e.code)))
}

/// Run a suite; `progress` is called with a line before each setting.
pub fn run(
    registry: Arc<Registry>,
    gpu: Arc<Gpu>,
    suite_path: &Path,
    suite: &Suite,
    runs: usize,
    size: (u32, u32),
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let graph_path: PathBuf = suite_path
        .parent()
        .unwrap_or(Path::new("."))
        .join(&suite.graph);
    let base =
        load_file(&graph_path, registry.catalog()).map_err(|e| BenchError::Input(e.to_string()))?;
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    let opts = EvalOptions {
        size,
        ..Default::default()
    };
    let target = [Target::Port(suite.node.clone(), suite.output.clone())];
    let eval_output = |ev: &mut Evaluator, g: &Graph| -> Result<(Raster, f64), BenchError> {
        let r = ev.evaluate(g, &target, &opts).map_err(Box::new)?;
        let ms = r
            .stats
            .nodes
            .iter()
            .find(|n| n.id == suite.node)
            .map_or(0.0, |n| n.time.as_secs_f64() * 1e3);
        let v = r
            .outputs
            .get(&(suite.node.clone(), suite.output.clone()))
            .ok_or_else(|| {
                BenchError::Input(format!("{}.{} produced nothing", suite.node, suite.output))
            })?;
        let raster = download(&gpu, v).map_err(|e| BenchError::Input(e.to_string()))?;
        Ok((raster, ms))
    };
    let mut g = base.clone();
    set(&registry, &mut g, &suite.node, &suite.reference)?;
    progress(&format!("reference {}", describe(&suite.reference)));
    let (reference, _) = eval_output(&mut ev, &g)?;
    let mut rows = Vec::new();
    for (i, cfg) in suite.configs.iter().enumerate() {
        progress(&format!(
            "[{}/{}] {}",
            i + 1,
            suite.configs.len(),
            describe(cfg)
        ));
        let mut g = base.clone();
        set(&registry, &mut g, &suite.node, cfg)?;
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..runs.max(1) {
            ev.invalidate(&suite.node);
            let (raster, ms) = eval_output(&mut ev, &g)?;
            times.push(ms);
            last = Some(raster);
        }
        times.sort_by(f64::total_cmp);
        let (rmse, max_err) = last
            .as_ref()
            .map_or((f64::NAN, f64::NAN), |r| errors(r, &reference));
        rows.push(Row {
            setting: describe(cfg),
            params: cfg.clone(),
            median_ms: times[times.len() / 2],
            min_ms: times[0],
            rmse,
            max_err,
        });
    }
    Ok(rows)
}

fn describe(p: &BTreeMap<String, String>) -> String {
    p.iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The speed-up of the fastest accelerated setting over the fastest baseline setting, both within
/// the suite's RMSE bound: `(baseline row, accelerated row, factor)`.
pub fn speedup<'a>(suite: &Suite, rows: &'a [Row]) -> Option<(&'a Row, &'a Row, f64)> {
    let (param, base, acc) = &suite.compare;
    let best = |value: &str| {
        rows.iter()
            .filter(|r| {
                r.params.get(param).map(String::as_str) == Some(value)
                    && r.rmse <= suite.target_rmse
            })
            .min_by(|a, b| a.median_ms.total_cmp(&b.median_ms))
    };
    let (b, a) = (best(base)?, best(acc)?);
    Some((b, a, b.median_ms / a.median_ms.max(1e-9)))
}

/// The table as text.
pub fn table(rows: &[Row]) -> String {
    let w = rows
        .iter()
        .map(|r| r.setting.len())
        .max()
        .unwrap_or(7)
        .max(7);
    let mut s = format!(
        "{:<w$}  {:>10}  {:>10}  {:>10}  {:>10}\n",
        "setting", "median ms", "min ms", "RMSE", "max err"
    );
    for r in rows {
        s.push_str(&format!(
            "{:<w$}  {:>10.3}  {:>10.3}  {:>10.6}  {:>10.6}\n",
            r.setting, r.median_ms, r.min_ms, r.rmse, r.max_err
        ));
    }
    s
}

/// The table as CSV.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("setting,median_ms,min_ms,rmse,max_err\n");
    for r in rows {
        s.push_str(&format!(
            "\"{}\",{:.4},{:.4},{:.8},{:.8}\n",
            r.setting, r.median_ms, r.min_ms, r.rmse, r.max_err
        ));
    }
    s
}
