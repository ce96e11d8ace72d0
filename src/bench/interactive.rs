//! Interactive suites: the time from a parameter change to the updated viewer picture, at full
//! size and at proxy sizes (what the editor shows while a knob is dragged, `eval::proxy`).
//!
//! Each setting of the suite is a change (`node.param` keys, or `node.@data` for a data block
//! as RON text) to the suite's graph. For each factor of `proxies` and each run, the unchanged
//! graph is evaluated first (untimed: the cache then holds every node's result at that size,
//! and only those — `Evaluator::keep_latest` — so the change is computed, not found), then the
//! changed one, timed from the request to the viewed port (`node`.`output`) ready to draw, by
//! the path the editor takes on this adapter: where its window shares the evaluation's device
//! (every backend but GL), the display pass draws the evaluated texture on the GPU
//! ([`tyndall_engine::display`]) and the time ends when that pass has finished; on GL the
//! picture is read back to the CPU, as the editor's worker does there. Only the nodes the
//! change touches run again; which ran is counted in the row (`x first` column: the time over
//! the full-size row's). `read back B` is what one update read back from the GPU (the most
//! over the runs): nothing but what nodes read themselves where the display pass runs, the
//! whole viewed picture on GL.

use std::collections::BTreeMap;
use std::time::Instant;

use tyndall_engine::display::{Display, Look};
use tyndall_engine::eval::proxy::{proxy_graph, proxy_size};
use tyndall_engine::eval::{download, EvalOptions, Evaluator, Target};
use tyndall_engine::gpu::Gpu;
use tyndall_engine::graph::Graph;

use super::{apply, describe, BenchError, Row, SuiteRun};

/// One evaluation of `g` at `size` with the viewed port ready to draw — drawn by `display`
/// (finished on the GPU), or read back without one: the wall-clock time (ms) and the bytes read
/// back on the way (the evaluation's own and the picture's).
fn picture(
    ev: &mut Evaluator,
    gpu: &Gpu,
    display: Option<&Display>,
    g: &Graph,
    target: &Target,
    size: (u32, u32),
) -> Result<(f64, u64), BenchError> {
    let read_before = gpu.thread_readbacks().1;
    let opts = EvalOptions {
        size,
        ..Default::default()
    };
    let start = Instant::now();
    let r = ev
        .evaluate(g, std::slice::from_ref(target), &opts)
        .map_err(Box::new)?;
    let Target::Port(n, p) = target else {
        return Err(BenchError::Input("the viewed output must be a port".into()));
    };
    let v = r
        .outputs
        .get(&(n.clone(), p.clone()))
        .ok_or_else(|| BenchError::Input(format!("{n}.{p} produced nothing")))?;
    let failed = |e: &dyn std::fmt::Display| BenchError::Input(e.to_string());
    match (display, v.texture()) {
        (Some(display), Some(t)) => {
            let look = Look::viewer(tyndall_engine::display::Channel::Rgb, 0.0);
            let _shown = display.draw(gpu, t, look).map_err(|e| failed(&e))?;
            gpu.wait().map_err(|e| failed(&e))?;
        }
        _ => {
            download(&gpu.recorder(), v).map_err(|e| failed(&e))?;
        }
    }
    let ms = start.elapsed().as_secs_f64() * 1e3;
    Ok((ms, gpu.thread_readbacks().1 - read_before))
}

/// Run an interactive suite (see the module docs); `progress` gets a line per measurement.
pub fn run(
    run: &SuiteRun,
    base: &Graph,
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let (registry, gpu, suite, runs, size) =
        (&run.registry, &run.gpu, run.suite, run.runs, run.size);
    let cat = registry.catalog().clone();
    let target = Target::Port(suite.node.clone(), suite.output.clone());
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    // The editor's path on this adapter: the display pass where its window shares the device.
    let display = if tyndall_engine::display::window_shares_device(gpu) {
        Some(Display::new(gpu).map_err(|e| BenchError::Input(e.to_string()))?)
    } else {
        None
    };
    let display = display.as_ref();
    let mut rows: Vec<Row> = Vec::new();
    for (i, change) in suite.configs.iter().enumerate() {
        let mut changed = base.clone();
        apply(registry, &mut changed, &suite.node, change)?;
        let mut full_ms = f64::NAN;
        for &factor in &suite.proxies {
            let f = factor.max(1);
            let at = proxy_size(size, f);
            progress(&format!(
                "[{}/{}] {} at 1/{f} ({}x{})",
                i + 1,
                suite.configs.len(),
                describe(change),
                at.0,
                at.1
            ));
            let (before, after) = (proxy_graph(base, &cat, f), proxy_graph(&changed, &cat, f));
            let mut times = Vec::new();
            let mut read = 0;
            for _ in 0..runs.max(1) {
                picture(&mut ev, gpu, display, &before, &target, at)?;
                // The cache keeps several keys per node: without this the changed graph's
                // results from the previous run would be found, not computed.
                ev.keep_latest();
                let (ms, bytes) = picture(&mut ev, gpu, display, &after, &target, at)?;
                times.push(ms);
                read = read.max(bytes);
            }
            times.sort_by(f64::total_cmp);
            let median = times[times.len() / 2];
            if f == 1 {
                full_ms = median;
            }
            let mut params: BTreeMap<String, String> = change.clone();
            params.insert("proxy".into(), format!("1/{f}"));
            rows.push(Row {
                growth: median / full_ms,
                readback: Some(read),
                ..Row::timed(&params, median, times[0])
            });
        }
    }
    Ok(rows)
}
