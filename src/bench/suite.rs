//! A benchmark suite file (`benches/*.ron`): what is measured, against which reference, and
//! which settings the default and `--quick` runs keep.

use std::collections::BTreeMap;

use serde::Deserialize;

/// A benchmark suite file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Suite {
    /// One line saying what is measured.
    pub title: String,
    /// The graph, relative to the suite file (unused by documents suites, which generate theirs).
    #[serde(default)]
    pub graph: String,
    /// Node measured (a setting's `node` key overrides it; unused by chain suites).
    #[serde(default)]
    pub node: String,
    /// Output port of the measured node (unused by chain suites).
    #[serde(default)]
    pub output: String,
    /// Evaluation size.
    pub size: (u32, u32),
    /// Runs per setting (the median is reported).
    pub runs: usize,
    /// Setting of the reference output (none: no error columns).
    #[serde(default)]
    pub reference: Option<BTreeMap<String, String>>,
    /// Further named references; a setting's `reference` key picks one (for suites that measure
    /// several nodes, each against its own high-quality setting).
    #[serde(default)]
    pub references: BTreeMap<String, BTreeMap<String, String>>,
    /// The measured settings.
    pub configs: Vec<BTreeMap<String, String>>,
    /// Error bounds of the speed-up comparison (one speed-up line per bound).
    #[serde(default)]
    pub target_rmse: Vec<f64>,
    /// `(parameter, baseline value, accelerated values)`: for each accelerated value and each
    /// bound, the speed-up reported is the time of the fastest baseline setting within the bound
    /// over that of the fastest setting with the accelerated value within it.
    #[serde(default)]
    pub compare: Option<(String, String, Vec<String>)>,
    /// Kernel-size parameters: rows equal in every other key form a group, and each row's time
    /// is also given relative to its group's first row (cost growth with kernel size).
    #[serde(default)]
    pub kernel: Vec<String>,
    /// Count connected holes (4-connected texels ≥ `threshold`) in `before` (`node.port`) and in
    /// the measured output: `(before, threshold)`.
    #[serde(default)]
    pub holes: Option<(String, f32)>,
    /// The measured output is a per-iteration residual (one texel per iteration, the first the
    /// start, as `LightMapSolve.residual`): the table adds the iterations run and the final
    /// residual over the start.
    #[serde(default)]
    pub convergence: bool,
    /// Also report the RMSE over the texels at depth discontinuities only: `(depth port,
    /// threshold)` — a texel whose depth differs from a 4-neighbour's by more than `threshold`
    /// times its own.
    #[serde(default)]
    pub edges: Option<(String, f32)>,
    /// `(when, put)` pairs: a setting that contains every pair of `when` (and names no
    /// `reference`) is compared with itself with `put`'s values put in — e.g.
    /// `({"shape": "Circle"}, {"method": "Exact"})`: each circle row against the exact method
    /// at the same radius and size. The first matching pair counts; each distinct reference
    /// is computed once.
    #[serde(default)]
    pub reference_as: Vec<(BTreeMap<String, String>, BTreeMap<String, String>)>,
    /// Also report the share of texels that differ from the reference at all (`differ %`).
    #[serde(default)]
    pub differ: bool,
    /// An interactive suite (see [`super::interactive`]): each setting is a change, timed from the
    /// change to the viewed picture read back, at full size (factor 1) and at each proxy
    /// factor listed (e.g. `[1, 2, 4]`); empty: not an interactive suite.
    #[serde(default)]
    pub proxies: Vec<u32>,
    /// A temporal suite (see [`super::temporal`]): the times (frames) the graph is evaluated
    /// at, in order, each setting against the `reference` of the same frame, with the flicker
    /// between consecutive frames; empty: not a temporal suite.
    #[serde(default)]
    pub frames: Vec<f64>,
    /// A whole-graph suite: the settings are steps (see [`super::chain`]).
    #[serde(default)]
    pub chain: bool,
    /// A document-size suite: each setting is a generated chain's `nodes` and a `phase` (see
    /// [`super::documents`]).
    #[serde(default)]
    pub documents: bool,
    /// A setting's repeated runs stop once its runs together have taken this long, ms (the
    /// first always runs; default 4000): a multi-second setting's run-to-run spread is a few
    /// per cent, and repeating it three times was a third of the default run's 15 minutes.
    #[serde(default = "default_row_budget_ms")]
    pub row_budget_ms: f64,
    /// Indices of settings too slow for the default run (it must stay under 15 minutes on two
    /// CPU cores for every suite together): they run only with `--full`.
    #[serde(default)]
    pub slow: Vec<usize>,
    /// `--quick`: the indices of the settings to keep (empty: all).
    #[serde(default)]
    pub quick: Vec<usize>,
    /// `--quick`: the evaluation size (default: the suite's).
    #[serde(default)]
    pub quick_size: Option<(u32, u32)>,
    /// The parameter whose value names a point's series in the plots (default: the `compare`
    /// parameter, else `node`, else `method`, else one series).
    #[serde(default)]
    pub series: Option<String>,
}

/// [`Suite::row_budget_ms`]'s default.
fn default_row_budget_ms() -> f64 {
    4000.0
}

impl Suite {
    /// The suite without its `slow` settings (the default run).
    pub fn without_slow(mut self) -> Self {
        let slow = std::mem::take(&mut self.slow);
        let configs = std::mem::take(&mut self.configs);
        // `quick` indices refer to the full list: renumber them.
        let mut renumber = Vec::new();
        for (i, c) in configs.into_iter().enumerate() {
            if slow.contains(&i) {
                continue;
            }
            if self.quick.contains(&i) {
                renumber.push(self.configs.len());
            }
            self.configs.push(c);
        }
        self.quick = renumber;
        self
    }

    /// The suite reduced for `--quick`: the `quick` settings at `quick_size`, one run each.
    pub fn reduced(mut self) -> Self {
        if !self.quick.is_empty() {
            let keep = self.quick.clone();
            self.configs = keep
                .iter()
                .filter_map(|i| self.configs.get(*i).cloned())
                .collect();
        }
        if let Some(size) = self.quick_size {
            self.size = size;
        }
        self.runs = 1;
        self
    }

    /// The series key of the plots.
    pub fn series_key(&self) -> Option<String> {
        if let Some(s) = &self.series {
            return Some(s.clone());
        }
        if let Some((p, _, _)) = &self.compare {
            return Some(p.clone());
        }
        ["node", "method"]
            .iter()
            .find(|k| self.configs.iter().any(|c| c.contains_key(**k)))
            .map(|k| k.to_string())
    }
}
