//! The quality suite: per setting, the median time of the timed nodes and the output's errors
//! against its reference (the suite's, a named one, or the setting with `reference_as`).

use super::*;

/// What the quality suite's steps share: the suite, its base graph and the evaluation options.
struct Quality<'a> {
    run: &'a SuiteRun<'a>,
    base: &'a Graph,
    opts: EvalOptions,
}

impl Quality<'_> {
    /// Port `node.port` of `g` read back, with the time of the `timed` nodes (ms).
    fn read(
        &self,
        ev: &mut Evaluator,
        g: &Graph,
        (node, port): (&str, &str),
        timed: &[String],
    ) -> Result<(Raster, f64), BenchError> {
        read_port(ev, &self.run.gpu, g, (node, port), timed, &self.opts)
    }

    /// The base graph with `setting` applied: (graph, measured node).
    fn graph_of(&self, setting: &Setting) -> Result<(Graph, String), BenchError> {
        let mut g = self.base.clone();
        let node = apply(&self.run.registry, &mut g, &self.run.suite.node, setting)?;
        Ok((g, node))
    }

    /// A reference's evaluation of `spec` (its timed nodes run again), kept in `runs` as that
    /// setting's first run.
    fn reference(
        &self,
        ev: &mut Evaluator,
        spec: &Setting,
        runs: &mut FirstRuns,
    ) -> Result<Raster, BenchError> {
        let (g, node) = self.graph_of(spec)?;
        let timed = timed_of(spec, &node);
        for t in &timed {
            ev.invalidate(t);
        }
        let (r, ms) = self.read(ev, &g, (&node, &output_of(self.run.suite, spec)), &timed)?;
        runs.insert(describe(spec), (r.clone(), ms));
        Ok(r)
    }

    /// The suite's `edges` mask: depth discontinuities of the named port of the base graph.
    fn edge_mask(&self, ev: &mut Evaluator) -> Result<Option<Vec<bool>>, BenchError> {
        let Some((port, threshold)) = &self.run.suite.edges else {
            return Ok(None);
        };
        let (n, p) = split_endpoint(port).map_err(|e| BenchError::Input(e.to_string()))?;
        let (d, _) = self.read(ev, self.base, (n, p), &[])?;
        Ok(Some(discontinuities(&d, *threshold)))
    }

    /// The suite's `holes`: connected components of the named port of `g` (before the node)
    /// and of the node's output `out`.
    fn holes(
        &self,
        ev: &mut Evaluator,
        g: &Graph,
        out: &Raster,
    ) -> Result<Option<(usize, usize)>, BenchError> {
        let Some((before, threshold)) = &self.run.suite.holes else {
            return Ok(None);
        };
        let (n, p) = split_endpoint(before).map_err(|e| BenchError::Input(e.to_string()))?;
        let (b, _) = self.read(ev, g, (n, p), &[])?;
        Ok(Some((
            count_components(&b, *threshold),
            count_components(out, *threshold),
        )))
    }
}

/// The quality suite: each setting's median time and its errors against its reference.
pub(crate) fn run(
    run: &SuiteRun,
    base: &Graph,
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let suite = run.suite;
    let q = Quality {
        run,
        base,
        opts: EvalOptions {
            size: run.size,
            ..Default::default()
        },
    };
    let mut ev = Evaluator::new(run.registry.clone(), run.gpu.clone());
    // References computed before their own row: (raster, time of the row's timed nodes).
    let mut first_runs = FirstRuns::new();
    let reference = match &suite.reference {
        Some(setting) => {
            progress(&format!("reference {}", describe(setting)));
            Some(q.reference(&mut ev, setting, &mut first_runs)?)
        }
        None => None,
    };
    // Named references are computed when a setting first asks for one (a reduced run may
    // need none of them).
    let mut named: BTreeMap<String, Raster> = BTreeMap::new();
    let edge_mask = q.edge_mask(&mut ev)?;
    let wanted = measured_references(suite)?;
    let mut rows: Vec<Row> = Vec::new();
    for (i, setting) in suite.configs.iter().enumerate() {
        progress(&format!(
            "[{}/{}] {}",
            i + 1,
            suite.configs.len(),
            describe(setting)
        ));
        // The setting's own reference first: when that reference is a later setting of the
        // suite (e.g. the exact method, or the most steps), its evaluation is timed as that
        // setting's first run, so the later row does not evaluate it again.
        let own = own_reference(suite, setting)?;
        if let Some((name, spec)) = &own {
            if !named.contains_key(name) {
                progress(&format!("reference {name}: {}", describe(spec)));
                let r = q.reference(&mut ev, spec, &mut first_runs)?;
                named.insert(name.clone(), r);
            }
        }
        let (g, node) = q.graph_of(setting)?;
        let output = output_of(suite, setting);
        let timed = timed_of(setting, &node);
        let runs_here = runs_for(setting, run.runs);
        let (times, last) = match first_run(&mut first_runs, setting, runs_here, suite) {
            Some((raster, ms)) => {
                progress("  (its first run: the reference's evaluation)");
                (vec![ms], Some(raster))
            }
            None => (Vec::new(), None),
        };
        let (times, out) = repeat_runs(times, last, runs_here.max(1), suite.row_budget_ms, || {
            for t in &timed {
                ev.invalidate(t);
            }
            q.read(&mut ev, &g, (&node, &output), &timed)
        })?;
        let this = describe(setting);
        if wanted.contains(&this) && !named.contains_key(&this) {
            named.insert(this, out.clone());
        }
        let reference = match &own {
            Some((name, _)) => named.get(name),
            None => reference.as_ref(),
        };
        // Holes (connected components) before the node and after it.
        let holes = q.holes(&mut ev, &g, &out)?;
        let c = compare(&out, reference, suite, edge_mask.as_deref());
        // The median; of two runs, the faster.
        let median = times[(times.len() - 1) / 2];
        rows.push(Row {
            growth: kernel_growth(suite, &rows, setting, median),
            holes,
            kind: g.node(&node).map(|n| n.kind.clone()).unwrap_or_default(),
            node,
            ..c.row(Row::timed(setting, median, times[0]))
        });
    }
    Ok(rows)
}

/// The timed runs of `setting`: its own `runs` (e.g. 1 for a slow high-quality row) where it
/// has one, at most the suite's `runs` (≥ 1).
fn runs_for(setting: &Setting, runs: usize) -> usize {
    setting
        .get("runs")
        .and_then(|r| r.parse::<usize>().ok())
        .unwrap_or(runs)
        .min(runs.max(1))
}

/// References that are measured settings too (by description): kept from their row instead of
/// computed again.
fn measured_references(suite: &Suite) -> Result<std::collections::BTreeSet<String>, BenchError> {
    suite
        .configs
        .iter()
        .filter_map(|c| own_reference(suite, c).transpose())
        .map(|r| r.map(|(name, _)| name))
        .collect()
}

/// References computed before their own row, by setting: (raster, time of the row's timed
/// nodes).
type FirstRuns = BTreeMap<String, (Raster, f64)>;

/// The port a setting reads: its own `output`, else the suite's.
fn output_of(suite: &Suite, setting: &Setting) -> String {
    setting
        .get("output")
        .cloned()
        .unwrap_or_else(|| suite.output.clone())
}

/// The reference's evaluation of `setting`, if one was made, as the row's first run. It may
/// include compiling the node's shaders: it stands in for a run when the median absorbs that
/// (more runs follow) or when it is long enough (at least the row budget) for a compile to be
/// noise.
fn first_run(
    first_runs: &mut FirstRuns,
    setting: &Setting,
    runs_here: usize,
    suite: &Suite,
) -> Option<(Raster, f64)> {
    let as_reference: Setting = setting
        .iter()
        .filter(|(k, _)| !matches!(k.as_str(), "reference" | "runs"))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    let (raster, ms) = first_runs.remove(&describe(&as_reference))?;
    (runs_here > 1 || ms >= suite.row_budget_ms).then_some((raster, ms))
}

/// Evaluations of one row until it has `runs` times or its times reach `budget_ms` (at least
/// one), after those it starts with: the sorted times and the last output.
fn repeat_runs(
    mut times: Vec<f64>,
    mut last: Option<Raster>,
    runs: usize,
    budget_ms: f64,
    mut run: impl FnMut() -> Result<(Raster, f64), BenchError>,
) -> Result<(Vec<f64>, Raster), BenchError> {
    while times.len() < runs && (times.is_empty() || times.iter().sum::<f64>() < budget_ms) {
        let (raster, ms) = run()?;
        times.push(ms);
        last = Some(raster);
    }
    times.sort_by(f64::total_cmp);
    let out = last.ok_or_else(|| BenchError::Input("no run".into()))?;
    Ok((times, out))
}

/// A row's output against its reference.
struct Compared {
    differ: f64,
    rmse: f64,
    max_err: f64,
    convergence: Option<(usize, f64)>,
    psnr: f64,
    edge_rmse: f64,
}

impl Compared {
    /// `row` with these errors.
    fn row(self, row: Row) -> Row {
        Row {
            rmse: self.rmse,
            max_err: self.max_err,
            convergence: self.convergence,
            psnr: self.psnr,
            edge_rmse: self.edge_rmse,
            differ: self.differ,
            ..row
        }
    }
}

/// The errors of `out` against `reference` (NaN without one) that `suite` asks for.
fn compare(
    out: &Raster,
    reference: Option<&Raster>,
    suite: &Suite,
    edge_mask: Option<&[bool]>,
) -> Compared {
    let differ = match reference {
        Some(r) if suite.differ && r.data.len() == out.data.len() => {
            let n = out.data.iter().zip(&r.data).filter(|(a, b)| a != b).count();
            n as f64 / out.data.len().max(1) as f64
        }
        _ => f64::NAN,
    };
    let (rmse, max_err) = reference.map_or((f64::NAN, f64::NAN), |r| errors(out, r));
    let convergence = suite.convergence.then(|| {
        let first = out.data.first().copied().unwrap_or(0.0) as f64;
        let last = out.data.last().copied().unwrap_or(0.0) as f64;
        (
            out.data.len().saturating_sub(1),
            if first > 0.0 { last / first } else { f64::NAN },
        )
    });
    let psnr = reference.map_or(f64::NAN, |r| {
        let peak = r
            .data
            .iter()
            .filter(|v| v.is_finite())
            .fold(0.0f64, |m, v| m.max(v.abs() as f64));
        20.0 * (peak / rmse).log10()
    });
    let edge_rmse = match (edge_mask, reference) {
        (Some(mask), Some(r)) => masked_rmse(out, r, mask),
        _ => f64::NAN,
    };
    Compared {
        differ,
        rmse,
        max_err,
        convergence,
        psnr,
        edge_rmse,
    }
}
