//! The quality suite: per setting, the median time of the timed nodes and the output's errors
//! against its reference (the suite's, a named one, or the setting with `reference_as`).

use super::*;

/// The quality suite: each setting's median time and its errors against its reference.
pub(crate) fn run(
    registry: Arc<Registry>,
    gpu: Arc<Gpu>,
    base: &Graph,
    suite: &Suite,
    runs: usize,
    size: (u32, u32),
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    let opts = EvalOptions {
        size,
        ..Default::default()
    };
    let read = |ev: &mut Evaluator, g: &Graph, node: &str, port: &str, timed: &[String]| {
        read_port(ev, &gpu, g, (node, port), timed, &opts)
    };
    let output_of = |setting: &Setting| output_of(suite, setting);
    // References computed before their own row: (raster, time of the row's timed nodes).
    let mut first_runs = FirstRuns::new();
    let reference_run = |ev: &mut Evaluator, spec: &Setting, runs: &mut FirstRuns| {
        let mut g = base.clone();
        let node = apply(&registry, &mut g, &suite.node, spec)?;
        let timed = timed_of(spec, &node);
        for t in &timed {
            ev.invalidate(t);
        }
        let (r, ms) = read(ev, &g, &node, &output_of(spec), &timed)?;
        runs.insert(describe(spec), (r.clone(), ms));
        Ok::<_, BenchError>(r)
    };
    let reference = match &suite.reference {
        Some(setting) => {
            progress(&format!("reference {}", describe(setting)));
            Some(reference_run(&mut ev, setting, &mut first_runs)?)
        }
        None => None,
    };
    // Named references are computed when a setting first asks for one (a reduced run may
    // need none of them).
    let mut named: BTreeMap<String, Raster> = BTreeMap::new();
    let edge_mask = match &suite.edges {
        Some((port, threshold)) => {
            let (n, p) = split_endpoint(port).map_err(|e| BenchError::Input(e.to_string()))?;
            let (d, _) = read(&mut ev, base, n, p, &[])?;
            Some(discontinuities(&d, *threshold))
        }
        None => None,
    };
    // References that are measured settings too: kept from their row instead of computed again.
    let wanted = suite
        .configs
        .iter()
        .filter_map(|c| own_reference(suite, c).transpose())
        .map(|r| r.map(|(name, _)| name))
        .collect::<Result<std::collections::BTreeSet<_>, _>>()?;
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
                let r = reference_run(&mut ev, spec, &mut first_runs)?;
                named.insert(name.clone(), r);
            }
        }
        let mut g = base.clone();
        let node = apply(&registry, &mut g, &suite.node, setting)?;
        let output = output_of(setting);
        let timed = timed_of(setting, &node);
        // A setting's own `runs` (e.g. 1 for a slow high-quality row) overrides the suite's.
        let runs_here = setting
            .get("runs")
            .and_then(|r| r.parse::<usize>().ok())
            .unwrap_or(runs)
            .min(runs.max(1));
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
            read(&mut ev, &g, &node, &output, &timed)
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
        let holes = match &suite.holes {
            Some((before, threshold)) => {
                let (n, p) =
                    split_endpoint(before).map_err(|e| BenchError::Input(e.to_string()))?;
                let (b, _) = read(&mut ev, &g, n, p, &[])?;
                let count = |r: &Raster| count_components(r, *threshold);
                Some((count(&b), count(&out)))
            }
            None => None,
        };
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
