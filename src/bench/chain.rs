//! Chain suites: a whole stylization graph, node by node, cold and after changes.
//!
//! The settings of a chain suite are steps run in order on one evaluator, so a step sees the
//! cache the steps before it left: its parameter changes accumulate (`node.param` keys), and
//! each step reports every node's wall-clock time and status — ran, reused (its inputs and
//! parameters unchanged), not needed (no requested output depends on it). Two keys are not
//! parameters: `cold` (`true`: drop every cached result first) and `target` (`node.port` or
//! `node`, comma-separated: what is asked for; default: the graph's sinks). Sinks write their
//! files into a temporary folder that is removed afterwards.
//!
//! With `runs` above 1 the whole sequence runs that many times on fresh evaluators; times are the
//! medians over the runs (compiled shaders are shared, so the first cold step of the first run
//! alone pays for compiling them).

use std::collections::BTreeMap;
use std::path::Path;

use tyndall_engine::eval::{resolve_files, EvalOptions, Evaluator, PathPolicy, Status, Target};
use tyndall_engine::graph::{split_endpoint, Graph};

use super::{apply, BenchError, Row, SuiteRun};

/// One node in one chain step.
#[derive(Debug, Clone)]
pub struct NodeTime {
    /// Node id.
    pub id: String,
    /// Node kind.
    pub kind: String,
    /// `ran`, `reused` or `not needed` (a node that forwarded its input counts as ran).
    pub status: &'static str,
    /// Median wall-clock time over the runs, ms (0 unless it ran).
    pub median_ms: f64,
}

/// What one chain step did.
#[derive(Debug, Clone)]
pub struct Step {
    /// Nodes that ran.
    pub ran: usize,
    /// Nodes whose cached result was reused.
    pub reused: usize,
    /// Nodes no requested output depends on.
    pub not_needed: usize,
    /// Every node of the graph, in topological order.
    pub nodes: Vec<NodeTime>,
}

fn status_name(s: Status) -> &'static str {
    match s {
        Status::Ran | Status::PassedThrough => "ran",
        Status::Reused => "reused",
        Status::NotNeeded => "not needed",
    }
}

fn targets_of(ev: &Evaluator, g: &Graph, spec: Option<&String>) -> Vec<Target> {
    match spec {
        None => ev.sinks(g),
        Some(list) => list
            .split(',')
            .map(str::trim)
            .filter(|t| !t.is_empty())
            .map(|t| match split_endpoint(t) {
                Ok((n, p)) => Target::Port(n.to_string(), p.to_string()),
                Err(_) => Target::Node(t.to_string()),
            })
            .collect(),
    }
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// Run a chain suite (see the module documentation); one row per step.
#[allow(clippy::too_many_arguments)]
pub fn run(
    run: &SuiteRun,
    graph_path: &Path,
    base: &Graph,
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let (registry, gpu, suite, runs, size) =
        (&run.registry, &run.gpu, run.suite, run.runs, run.size);
    let scratch = std::env::temp_dir().join(format!("tyndall-bench-{}", std::process::id()));
    std::fs::create_dir_all(&scratch)
        .map_err(|e| BenchError::Input(format!("{}: {e}", scratch.display())))?;
    let policy = PathPolicy {
        graph_dir: graph_path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        output_dir: scratch.clone(),
        allow_any: false,
    };
    let opts = EvalOptions {
        size,
        ..Default::default()
    };
    // Per step: per node, the times of every run; the statuses (equal in every run).
    let mut times: Vec<BTreeMap<String, Vec<f64>>> = vec![BTreeMap::new(); suite.configs.len()];
    let mut totals: Vec<Vec<f64>> = vec![Vec::new(); suite.configs.len()];
    let mut statuses: Vec<Vec<(String, String, Status)>> = vec![Vec::new(); suite.configs.len()];
    let result = (|| {
        for run in 0..runs.max(1) {
            let mut ev = Evaluator::new(registry.clone(), gpu.clone());
            let mut g = base.clone();
            for (i, step) in suite.configs.iter().enumerate() {
                progress(&format!(
                    "run {}/{}, step [{}/{}] {}",
                    run + 1,
                    runs.max(1),
                    i + 1,
                    suite.configs.len(),
                    super::describe(step)
                ));
                if step.get("cold").is_some_and(|v| v == "true") {
                    ev.clear();
                }
                let params: BTreeMap<String, String> = step
                    .iter()
                    .filter(|(k, _)| *k != "cold" && *k != "target")
                    .map(|(k, v)| (k.clone(), v.clone()))
                    .collect();
                apply(registry, &mut g, "", &params)?;
                let resolved = resolve_files(registry, &g, &policy)
                    .map_err(|e| BenchError::Input(e.to_string()))?;
                let targets = targets_of(&ev, &resolved, step.get("target"));
                let r = ev.evaluate(&resolved, &targets, &opts).map_err(Box::new)?;
                let mut total = 0.0;
                for n in &r.stats.nodes {
                    let ms = n.time.as_secs_f64() * 1e3;
                    total += ms;
                    times[i].entry(n.id.clone()).or_default().push(ms);
                }
                totals[i].push(total);
                statuses[i] = r
                    .stats
                    .nodes
                    .iter()
                    .map(|n| (n.id.clone(), n.kind.clone(), n.status))
                    .collect();
            }
        }
        Ok::<(), BenchError>(())
    })();
    // Best effort: the scratch folder holds only what the sinks wrote.
    let _ = std::fs::remove_dir_all(&scratch);
    result?;
    let mut rows = Vec::new();
    for (i, step) in suite.configs.iter().enumerate() {
        let nodes: Vec<NodeTime> = statuses[i]
            .iter()
            .map(|(id, kind, status)| NodeTime {
                id: id.clone(),
                kind: kind.clone(),
                status: status_name(*status),
                median_ms: times[i].get_mut(id).map_or(0.0, |v| median(v)),
            })
            .collect();
        let count = |s: &str| nodes.iter().filter(|n| n.status == s).count();
        let min = totals[i].iter().copied().fold(f64::INFINITY, f64::min);
        let mut row = Row::timed(step, median(&mut totals[i]), min);
        row.chain = Some(Step {
            ran: count("ran"),
            reused: count("reused"),
            not_needed: count("not needed"),
            nodes,
        });
        rows.push(row);
    }
    Ok(rows)
}

/// The steps as text: one line per step with its counts and total, then its nodes.
pub fn table(rows: &[Row]) -> String {
    let mut s = String::new();
    for (i, r) in rows.iter().enumerate() {
        let Some(step) = &r.chain else { continue };
        s.push_str(&format!(
            "step {}: {}\n  {} ran, {} reused, {} not needed; {:.1} ms (median; min {:.1})\n",
            i + 1,
            if r.setting.is_empty() {
                "(as saved)"
            } else {
                &r.setting
            },
            step.ran,
            step.reused,
            step.not_needed,
            r.median_ms,
            r.min_ms
        ));
        s.push_str(&format!(
            "  {:<20}  {:<18}  {:<10}  {:>10}\n",
            "node", "kind", "status", "median ms"
        ));
        for n in &step.nodes {
            let ms = if n.status == "ran" {
                format!("{:.3}", n.median_ms)
            } else {
                "-".into()
            };
            s.push_str(&format!(
                "  {:<20}  {:<18}  {:<10}  {:>10}\n",
                n.id, n.kind, n.status, ms
            ));
        }
    }
    s
}
