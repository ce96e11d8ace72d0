//! Temporal suites: error and flicker of each setting along an animation (a camera move).
//!
//! The suite's `frames` are the times the graph is evaluated at, in order. For every frame the
//! suite's `reference` setting gives the reference picture, then every setting is evaluated at
//! that frame (frame-major, so the scene, shadow map and G-buffer of a frame are computed once
//! and shared). Per setting the row reports:
//!
//! - the measured nodes' median time per frame (the `time` key's nodes, else the node), each
//!   node charged what its result cost even when another setting of the frame computed it
//!   (`NodeStat::cost`); a node with a history includes its earlier frames' runs, which only
//!   the first frame makes (the later ones find them in the cache);
//! - `RMSE`: the mean over the frames of the RMSE against that frame's reference; `max err`:
//!   the largest absolute error of any frame;
//! - `flicker`: the mean over consecutive frame pairs of mean |(mₖ − mₖ₋₁) − (rₖ − rₖ₋₁)| over
//!   every pixel and channel — how much more (or otherwise) the method's picture changes from
//!   one frame to the next than the reference's does; 0 for the reference itself. A method with
//!   a steady error (a fixed bias that moves with the scene) scores low; one whose error
//!   pattern changes between frames (slices that move with the epipole, jitter drawn anew)
//!   scores high;
//! - `ref change`: the reference's own mean |rₖ − rₖ₋₁|, the scale a flicker is read against.

use std::collections::BTreeMap;

use tyndall_engine::eval::{EvalOptions, Evaluator};
use tyndall_engine::graph::Graph;
use tyndall_engine::io::Raster;

use super::metrics::errors;
use super::{apply, read_port, timed_of, BenchError, Row, SuiteRun};

/// A setting's running sums over the frames.
#[derive(Default)]
struct Track {
    times: Vec<f64>,
    rmse_sum: f64,
    max_err: f64,
    flicker_sum: f64,
    previous: Option<Raster>,
}

/// Mean |(a − a₀) − (b − b₀)| over every value (the four rasters the same size).
fn change_difference(a: &Raster, a0: &Raster, b: &Raster, b0: &Raster) -> f64 {
    let n = a
        .data
        .len()
        .min(a0.data.len())
        .min(b.data.len())
        .min(b0.data.len());
    let sum: f64 = (0..n)
        .map(|i| {
            let da = a.data[i] as f64 - a0.data[i] as f64;
            let db = b.data[i] as f64 - b0.data[i] as f64;
            let d = (da - db).abs();
            if d.is_finite() {
                d
            } else {
                0.0
            }
        })
        .sum();
    sum / n.max(1) as f64
}

/// Mean |a − b| over every value.
fn mean_abs_change(a: &Raster, b: &Raster) -> f64 {
    let n = a.data.len().min(b.data.len());
    let sum: f64 = (0..n)
        .map(|i| (a.data[i] as f64 - b.data[i] as f64).abs())
        .filter(|d| d.is_finite())
        .sum();
    sum / n.max(1) as f64
}

/// Run a temporal suite (see the module docs); `progress` gets a line per frame.
pub fn run(
    run: &SuiteRun,
    base: &Graph,
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>, BenchError> {
    let (registry, gpu, suite, size) = (&run.registry, &run.gpu, run.suite, run.size);
    let reference = suite
        .reference
        .as_ref()
        .ok_or_else(|| BenchError::Input("a temporal suite needs a `reference`".into()))?;
    let mut ev = Evaluator::new(registry.clone(), gpu.clone());
    // Each setting's graph, measured node and output, built once.
    let mut graphs = Vec::new();
    for setting in std::iter::once(reference).chain(&suite.configs) {
        let mut g = base.clone();
        let node = apply(registry, &mut g, &suite.node, setting)?;
        let output = setting
            .get("output")
            .cloned()
            .unwrap_or_else(|| suite.output.clone());
        let timed = timed_of(setting, &node);
        graphs.push((g, node, output, timed));
    }
    let read = |ev: &mut Evaluator, k: usize, time: f64| -> Result<(Raster, f64), BenchError> {
        let (g, node, output, timed) = &graphs[k];
        let opts = EvalOptions {
            size,
            time,
            ..Default::default()
        };
        read_port(ev, gpu, g, (node, output), timed, &opts)
    };
    let mut tracks: Vec<Track> = suite.configs.iter().map(|_| Track::default()).collect();
    let mut ref_previous: Option<Raster> = None;
    let mut ref_change_sum = 0.0;
    for (f, &time) in suite.frames.iter().enumerate() {
        progress(&format!(
            "frame {time} ({}/{}): reference and {} settings",
            f + 1,
            suite.frames.len(),
            suite.configs.len()
        ));
        let (r, _) = read(&mut ev, 0, time)?;
        for (i, track) in tracks.iter_mut().enumerate() {
            let (m, ms) = read(&mut ev, i + 1, time)?;
            let (rmse, max_err) = errors(&m, &r);
            track.times.push(ms);
            track.rmse_sum += rmse;
            track.max_err = track.max_err.max(max_err);
            if let (Some(m0), Some(r0)) = (&track.previous, &ref_previous) {
                track.flicker_sum += change_difference(&m, m0, &r, r0);
            }
            track.previous = Some(m);
        }
        if let Some(r0) = &ref_previous {
            ref_change_sum += mean_abs_change(&r, r0);
        }
        ref_previous = Some(r);
    }
    let frames = suite.frames.len().max(1) as f64;
    let pairs = suite.frames.len().saturating_sub(1).max(1) as f64;
    let ref_change = ref_change_sum / pairs;
    let rows = suite
        .configs
        .iter()
        .zip(tracks)
        .zip(graphs.iter().skip(1))
        .map(|((setting, mut t), (g, node, _, _))| {
            t.times.sort_by(f64::total_cmp);
            let median = t
                .times
                .get((t.times.len().max(1) - 1) / 2)
                .copied()
                .unwrap_or(0.0);
            let params: BTreeMap<String, String> = setting.clone();
            Row {
                rmse: t.rmse_sum / frames,
                max_err: t.max_err,
                temporal: Some((t.flicker_sum / pairs, ref_change)),
                node: node.clone(),
                kind: g.node(node).map(|n| n.kind.clone()).unwrap_or_default(),
                ..Row::timed(&params, median, t.times.first().copied().unwrap_or(0.0))
            }
        })
        .collect();
    Ok(rows)
}
