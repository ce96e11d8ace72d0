//! `tyndall.render`: a graph's sinks over a frame range, as `tyndall render` does, from Python.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use pyo3::prelude::*;

use tyndall_engine::eval::EvalOptions;
use tyndall_engine::gpu::Gpu;

use crate::colour::colour_err;
use crate::evaluate::{off_thread, prepared};
use crate::graph::Graph;
use crate::{eval_err, gpu_err, registry};

/// render(graph, frames=None, output_dir=None, size=(960, 540), progress=None, ocio=None)
/// -> list of frames
///
/// Render the graph's output nodes as `tyndall render` does: for each frame of `frames`
/// (`"1-24"`, `"1,5,7-9"`, `"1-24x2"`; None: one evaluation, file names as written) at time =
/// the frame, the outputs written under `output_dir` (default: the working directory) with the
/// frame in their names. As in `tyndall render`, files are encoded and written on background
/// threads while the next frame evaluates (the same bytes as written one by one); every write has
/// finished when `render` returns, and a failed one raises `OSError` naming its file.
/// `progress(frame, done, total)` is called after each frame's evaluation; Ctrl+C stops after the
/// frame in flight (its files are still written). `ocio`: the OpenColorIO config (as `--ocio`;
/// None: `$OCIO`, else the built-in config); one that cannot be read raises ValueError before
/// any work. Returns the frames rendered.
#[pyfunction]
#[pyo3(signature = (graph, frames=None, output_dir=None, size=(960, 540), progress=None, ocio=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn render(
    py: Python<'_>,
    graph: &Graph,
    frames: Option<&str>,
    output_dir: Option<PathBuf>,
    size: (u32, u32),
    progress: Option<Bound<'_, PyAny>>,
    ocio: Option<&str>,
) -> PyResult<Vec<i64>> {
    let out_dir = output_dir.unwrap_or_else(|| PathBuf::from("."));
    let (g, _) = prepared(py, graph, Some(&out_dir))?;
    let list: Vec<Option<i64>> = match frames {
        Some(s) => tyndall_engine::eval::parse_frame_spec(s)
            .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("frames: {e}")))?
            .0
            .into_iter()
            .map(Some)
            .collect(),
        None => vec![None],
    };
    let gpu = Gpu::shared().map_err(|e| gpu_err(py, &e))?;
    let mut ev = tyndall_engine::eval::Evaluator::new(registry(), gpu);
    ev.set_colour_config(ocio.unwrap_or(""))
        .map_err(|e| colour_err(&e))?;
    let ev = Arc::new(Mutex::new(ev));
    let g = Arc::new(g);
    let mut done = Vec::new();
    let rendered = render_frames(py, &list, &ev, &g, size, progress.as_ref(), &mut done);
    // Every file is written (or known to have failed) before returning, even after an error.
    let failures = py.detach(tyndall_engine::io::deferred::wait);
    rendered?;
    if !failures.is_empty() {
        let text: Vec<String> = failures.iter().map(ToString::to_string).collect();
        return Err(pyo3::exceptions::PyOSError::new_err(text.join("; ")));
    }
    Ok(done)
}

/// The frames of [`render`], each evaluated on its own thread with its image writes deferred.
fn render_frames(
    py: Python<'_>,
    list: &[Option<i64>],
    ev: &Arc<Mutex<tyndall_engine::eval::Evaluator>>,
    g: &Arc<tyndall_engine::graph::Graph>,
    size: (u32, u32),
    progress: Option<&Bound<'_, PyAny>>,
    done: &mut Vec<i64>,
) -> PyResult<()> {
    for (i, f) in list.iter().enumerate() {
        let (ev, g, f) = (ev.clone(), g.clone(), *f);
        let r = off_thread(py, move || {
            tyndall_engine::io::deferred::defer(true);
            let mut ev = ev.lock().unwrap_or_else(|e| e.into_inner());
            let opts = EvalOptions {
                time: f.unwrap_or(0) as f64,
                size,
                frame: f,
                ..Default::default()
            };
            let sinks = ev.sinks(&g);
            // As `tyndall render` does: the next frame needs only what this one used.
            let epoch = ev.epoch();
            let r = ev.evaluate(&g, &sinks, &opts).map(|_| ());
            ev.keep_used_since(epoch);
            r
        })?;
        r.map_err(|e| eval_err(py, &e))?;
        let frame = f.unwrap_or(0);
        done.push(frame);
        if let Some(cb) = progress {
            cb.call1((frame, i + 1, list.len()))?;
        }
    }
    Ok(())
}
