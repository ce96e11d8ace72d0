//! Document suites (`documents: true`): how loading, planning and evaluating grow with the
//! graph's size, on a generated chain of Math nodes after a Constant ([`math_chain`], the graph
//! `scripts/make_chain.py` writes).
//!
//! Each setting names `nodes` (the chain's length) and `phase`:
//! - `load`: RON text to a checked graph (parse, one cycle check, every output's type, every
//!   edge's type) — what `tyndall validate` does after reading the file;
//! - `evaluate`: a cold evaluation of the last node's output at the suite's size (pipelined, as
//!   `tyndall eval` without `--stats`);
//! - `replan`: the same evaluation again with nothing changed (planning, cache keys and the
//!   reuse of every node's result: the cost a document pays on every edit that touches nothing
//!   upstream). Right after an `evaluate` of the same length it reuses that evaluator's cache
//!   (no cold evaluation of its own).
//!
//! With `kernel: ["nodes"]` the table's `x first` column (each row's time over its phase's
//! first row) and the kernel plot show the growth: linear is 3 at 3,000 nodes and 10 at 10,000
//! against 1,000.

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use tyndall_engine::eval::{EvalOptions, Evaluator, Target};
use tyndall_engine::graph::load_str;

use super::{BenchError, Row, SuiteRun};

/// A chain of `n` Math nodes (`m0` … `m{n-1}`, each adding 0.001) after a Constant `c`; with
/// `grid`, canvas positions in rows of 40 nodes (220 × 140 points apart).
pub fn math_chain(n: usize, grid: bool) -> String {
    let pos = |i: usize| {
        if grid {
            format!(", pos: ({}.0, {}.0)", (i % 40) * 220, (i / 40) * 140)
        } else {
            String::new()
        }
    };
    let mut s = format!(
        "(version: 3, nodes: {{\n    \"c\": (kind: \"Constant\", params: {{\"value\": 0.5}}{}),\n",
        pos(0)
    );
    for i in 0..n {
        s += &format!(
            "    \"m{i}\": (kind: \"Math\", params: {{\"op\": \"add\", \"b\": 0.001}}{}),\n",
            pos(i + 1)
        );
    }
    s += "}, edges: [\n";
    let mut prev = "c.value".to_string();
    for i in 0..n {
        s += &format!("    (\"{prev}\", \"m{i}.a\"),\n");
        prev = format!("m{i}.out");
    }
    s + "])\n"
}

fn setting_value<'a>(
    setting: &'a BTreeMap<String, String>,
    key: &str,
) -> Result<&'a str, BenchError> {
    setting
        .get(key)
        .map(String::as_str)
        .ok_or_else(|| BenchError::Input(format!("a documents setting needs '{key}'")))
}

/// Run a documents suite (see the module docs); `progress` gets a line per setting.
pub fn run(run: &SuiteRun, mut progress: impl FnMut(&str)) -> Result<Vec<Row>, BenchError> {
    let (registry, gpu, suite, runs, size) =
        (&run.registry, &run.gpu, run.suite, run.runs, run.size);
    let mut rows = Vec::new();
    // The evaluator of the last `evaluate` setting, with its chain's length: a `replan` of the
    // same length right after it starts from its cache instead of a cold evaluation of its own.
    let mut warm: Option<(usize, Evaluator)> = None;
    for (i, setting) in suite.configs.iter().enumerate() {
        let nodes: usize = setting_value(setting, "nodes")?
            .parse()
            .map_err(|e| BenchError::Input(format!("nodes: {e}")))?;
        let phase = setting_value(setting, "phase")?;
        let runs = setting
            .get("runs")
            .and_then(|r| r.parse().ok())
            .unwrap_or(runs)
            .max(1);
        progress(&format!(
            "[{}/{}] {phase} of a {nodes}-node chain",
            i + 1,
            suite.configs.len()
        ));
        let text = math_chain(nodes, false);
        let file = Path::new("chain.ron");
        let load = || {
            load_str(&text, file, registry.catalog()).map_err(|e| BenchError::Input(e.to_string()))
        };
        let target = [Target::Port(
            format!("m{}", nodes.saturating_sub(1)),
            "out".into(),
        )];
        let opts = EvalOptions {
            size,
            pipelined: true,
            ..Default::default()
        };
        let mut times = Vec::with_capacity(runs);
        for _ in 0..runs {
            let ms = match phase {
                "load" => {
                    let start = Instant::now();
                    load()?;
                    start.elapsed().as_secs_f64() * 1e3
                }
                "evaluate" | "replan" => {
                    let g = load()?;
                    let mut ev = match warm.take() {
                        Some((n, ev)) if phase == "replan" && n == nodes => ev,
                        _ => {
                            let mut ev = Evaluator::new(registry.clone(), gpu.clone());
                            if phase == "replan" {
                                ev.evaluate(&g, &target, &opts).map_err(Box::new)?;
                            }
                            ev
                        }
                    };
                    let start = Instant::now();
                    ev.evaluate(&g, &target, &opts).map_err(Box::new)?;
                    gpu.wait().map_err(|e| BenchError::Input(e.to_string()))?;
                    let ms = start.elapsed().as_secs_f64() * 1e3;
                    warm = Some((nodes, ev));
                    ms
                }
                other => {
                    return Err(BenchError::Input(format!(
                        "phase '{other}': expected load, evaluate or replan"
                    )))
                }
            };
            times.push(ms);
        }
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        let growth = super::kernel_growth(suite, &rows, setting, median);
        rows.push(Row {
            growth,
            ..Row::timed(setting, median, times[0])
        });
    }
    Ok(rows)
}
