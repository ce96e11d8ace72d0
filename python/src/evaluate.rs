//! `tyndall.Evaluator` (its cache kept across calls) and `tyndall.node` (one node on arrays);
//! `tyndall.render` is in render.rs. GPU work runs on a thread of its own while the caller waits
//! without the GIL, checking for Ctrl+C (see the crate doc).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use tyndall_engine::eval::{EvalError as RustEvalError, EvalOptions, Matrices, PortValue, Target};
use tyndall_engine::gpu::Gpu;
use tyndall_engine::io::Raster;

use crate::colour::colour_err;
use crate::graph::Graph;
use crate::values::{from_array, matrices, to_array, to_param};
use crate::{eval_err, gpu_err, graph_err, raise, registry, About, EvalError, GraphError};

/// Run `work` on a thread of its own; wait for it without the GIL, raising KeyboardInterrupt
/// (or whatever a signal handler raises) as soon as Ctrl+C is pressed — the work then finishes
/// in the background.
pub(crate) fn off_thread<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        let _ = tx.send(work());
    });
    // (In a mutex: the wait closure must be Send, a receiver is not Sync.)
    let rx = Mutex::new(rx);
    loop {
        let next = py.detach(|| {
            let rx = rx.lock().unwrap_or_else(|e| e.into_inner());
            rx.recv_timeout(Duration::from_millis(50))
        });
        match next {
            Ok(v) => return Ok(v),
            Err(RecvTimeoutError::Timeout) => py.check_signals()?,
            Err(RecvTimeoutError::Disconnected) => {
                return Err(pyo3::exceptions::PyRuntimeError::new_err(
                    "the evaluation thread stopped without a result (a panic: please report it)",
                ))
            }
        }
    }
}

/// What a finished evaluation brings back.
struct Fetched {
    /// `node.port` → picture and the matrices it carries.
    arrays: Vec<(String, Raster, Option<Matrices>)>,
    /// (id, kind, status, ms, GPU ms).
    stats: Vec<(String, String, &'static str, f64, Option<f64>)>,
}

/// Why a fetch failed: an evaluation error, or a value with no array form.
enum Failed {
    Eval(RustEvalError),
    NotAnArray {
        node: String,
        port: String,
        ty: String,
    },
}

fn status_name(s: tyndall_engine::eval::Status) -> &'static str {
    use tyndall_engine::eval::Status as S;
    match s {
        S::Ran => "ran",
        S::PassedThrough => "passed through",
        S::Reused => "reused",
        S::NotNeeded => "not needed",
    }
}

/// Evaluate `targets` (labels `node.port`) and read them back.
fn fetch(
    ev: &mut tyndall_engine::eval::Evaluator,
    graph: &tyndall_engine::graph::Graph,
    targets: &[Wanted],
    opts: &EvalOptions,
) -> Result<Fetched, Failed> {
    let t: Vec<Target> = targets
        .iter()
        .map(|(_, n, p)| Target::Port(n.clone(), p.clone()))
        .collect();
    let r = ev.evaluate(graph, &t, opts).map_err(Failed::Eval)?;
    let mut arrays = Vec::new();
    for (label, n, p) in targets {
        let Some(v) = r.outputs.get(&(n.clone(), p.clone())) else {
            continue;
        };
        let not_array = || Failed::NotAnArray {
            node: n.clone(),
            port: p.clone(),
            ty: v.port_type().to_string(),
        };
        let raster =
            tyndall_engine::eval::download(&ev.gpu().recorder(), v).map_err(|_| not_array())?;
        let m = match v {
            PortValue::Depth(_, m) | PortValue::ShadowMap(_, m) | PortValue::LightMap(_, m) => {
                Some(*m)
            }
            _ => None,
        };
        arrays.push((label.clone(), raster, m));
    }
    let stats = r
        .stats
        .nodes
        .iter()
        .map(|s| {
            (
                s.id.clone(),
                s.kind.clone(),
                status_name(s.status),
                s.time.as_secs_f64() * 1e3,
                s.gpu_time.map(|d| d.as_secs_f64() * 1e3),
            )
        })
        .collect();
    Ok(Fetched { arrays, stats })
}

/// The Python result of a fetch: (dict `node.port` → array, stats list, dict `node.port` →
/// matrices).
fn to_python<'py>(py: Python<'py>, r: Result<Fetched, Failed>) -> PyResult<Bound<'py, PyList>> {
    let f = match r {
        Ok(f) => f,
        Err(Failed::Eval(e)) => return Err(eval_err(py, &e)),
        Err(Failed::NotAnArray { node, port, ty }) => {
            return Err(raise::<EvalError>(
                py,
                format!("{node}.{port}: a {ty} value has no array form (ask for a picture port)"),
                About {
                    node: Some(node),
                    port: Some(port),
                    param: None,
                },
            ))
        }
    };
    let arrays = PyDict::new(py);
    let cams = PyDict::new(py);
    for (label, r, m) in f.arrays {
        arrays.set_item(&label, to_array(py, r)?)?;
        if let Some(m) = m {
            cams.set_item(&label, matrices(py, &m)?)?;
        }
    }
    let stats = PyList::empty(py);
    for s in f.stats {
        stats.append(s)?;
    }
    let out = PyList::empty(py);
    out.append(arrays)?;
    out.append(stats)?;
    out.append(cams)?;
    Ok(out)
}

/// An output asked for: its label (`node.port` as given) and the flattened node and port.
type Wanted = (String, String, String);

/// Where each group instance's output ports come from in the flattened graph.
type GroupPorts = BTreeMap<(String, String), (String, String)>;

/// The graph as evaluation sees it: flattened (`group/inner` ids) and its relative input files
/// resolved against its folder (outputs under `output_dir`, default its folder); and where the
/// group instances' outputs are in it.
pub(crate) fn prepared(
    py: Python<'_>,
    g: &Graph,
    output_dir: Option<&Path>,
) -> PyResult<(tyndall_engine::graph::Graph, GroupPorts)> {
    let reg = registry();
    let (flat, ports) =
        g.g.flatten_ports(reg.catalog())
            .map_err(|e| graph_err(py, &e))?;
    let dir = g
        .path
        .as_deref()
        .and_then(Path::parent)
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let policy = tyndall_engine::eval::PathPolicy {
        graph_dir: dir.clone(),
        output_dir: output_dir.map(Path::to_path_buf).unwrap_or(dir),
        allow_any: true,
    };
    let resolved = tyndall_engine::eval::resolve_files(&reg, &flat, &policy)
        .map_err(|e| raise::<GraphError>(py, e.to_string(), About::default()))?;
    Ok((resolved, ports))
}

/// `node.port` labels: as given (split at the last dot), else what the graph's output nodes
/// read.
fn targets(
    py: Python<'_>,
    g: &tyndall_engine::graph::Graph,
    ports: &GroupPorts,
    outputs: Option<Vec<String>>,
) -> PyResult<Vec<Wanted>> {
    let reg = registry();
    let Some(outputs) = outputs else {
        let mut out = Vec::new();
        for n in g.nodes() {
            let Some(kind) = reg.get(&n.kind).filter(|k| k.is_sink()) else {
                continue;
            };
            for port in kind.schema().inputs {
                if let Some((s, p)) = g.source_of(&n.id, port.name) {
                    let t = (format!("{s}.{p}"), s.to_string(), p.to_string());
                    if !out.contains(&t) {
                        out.push(t);
                    }
                }
            }
        }
        if out.is_empty() {
            return Err(raise::<GraphError>(
                py,
                "the graph has no output node: name the outputs (outputs=[\"node.port\"])".into(),
                About::default(),
            ));
        }
        return Ok(out);
    };
    outputs
        .into_iter()
        .map(|o| {
            let (n, p) = o.rsplit_once('.').ok_or_else(|| {
                raise::<GraphError>(
                    py,
                    format!("output '{o}' is not of the form node.port"),
                    About::default(),
                )
            })?;
            if let Some((fnode, fport)) = ports.get(&(n.to_string(), p.to_string())) {
                return Ok((o.clone(), fnode.clone(), fport.clone()));
            }
            if g.node(n).is_none() {
                return Err(graph_err(
                    py,
                    &tyndall_engine::graph::GraphError::UnknownNode {
                        node: n.to_string(),
                    },
                ));
            }
            Ok((o.clone(), n.to_string(), p.to_string()))
        })
        .collect()
}

/// A GPU evaluator with its cache: a second `eval` after a `Graph.set` re-runs only the nodes
/// whose parameters or inputs changed and those below them.
#[pyclass(module = "tyndall._native", name = "Evaluator")]
pub struct Evaluator {
    inner: Arc<Mutex<tyndall_engine::eval::Evaluator>>,
    gpu: Arc<Gpu>,
}

#[pymethods]
impl Evaluator {
    /// Evaluator(adapter=None, ocio=None): on the process's shared GPU context, or on a new one
    /// on the adapter whose name contains `adapter` (as `TYNDALL_ADAPTER`; `tyndall info` lists
    /// them). Raises GpuError when no adapter qualifies. `ocio`: the OpenColorIO config of its
    /// evaluations (a file or an `ocio://` name, as `--ocio`; None: `$OCIO`, else the built-in
    /// config); one that cannot be read raises ValueError.
    #[new]
    #[pyo3(signature = (adapter=None, ocio=None))]
    fn new(py: Python<'_>, adapter: Option<String>, ocio: Option<String>) -> PyResult<Self> {
        let gpu = match adapter {
            None => Gpu::shared().map_err(|e| gpu_err(py, &e))?,
            Some(a) => {
                tyndall_engine::gpu::set_adapter_choice(Some(a));
                let g = Gpu::new(false);
                tyndall_engine::gpu::set_adapter_choice(None);
                Arc::new(g.map_err(|e| gpu_err(py, &e))?)
            }
        };
        let mut ev = tyndall_engine::eval::Evaluator::new(registry(), gpu.clone());
        ev.set_colour_config(ocio.as_deref().unwrap_or(""))
            .map_err(|e| colour_err(&e))?;
        Ok(Self {
            inner: Arc::new(Mutex::new(ev)),
            gpu,
        })
    }

    /// The OpenColorIO config its evaluations use (as given, or the current one).
    #[getter]
    fn ocio(&self) -> String {
        let ev = self.inner.lock().unwrap_or_else(|e| e.into_inner());
        match ev.colour_config() {
            "" => tyndall_engine::colour::current_spec(),
            spec => spec.to_string(),
        }
    }

    /// The adapter: its name and backend.
    #[getter]
    fn adapter(&self) -> String {
        format!("{} ({:?})", self.gpu.info.name, self.gpu.info.backend)
    }

    /// Native half of `Evaluator.eval` (see tyndall/__init__.py): [arrays, stats, cameras].
    #[pyo3(signature = (graph, outputs=None, time=0.0, size=(512, 512)))]
    fn _eval<'py>(
        &self,
        py: Python<'py>,
        graph: &Graph,
        outputs: Option<Vec<String>>,
        time: f64,
        size: (u32, u32),
    ) -> PyResult<Bound<'py, PyList>> {
        let (g, ports) = prepared(py, graph, None)?;
        let t = targets(py, &g, &ports, outputs)?;
        let opts = EvalOptions {
            time,
            size,
            ..Default::default()
        };
        let inner = self.inner.clone();
        let r = off_thread(py, move || {
            let mut ev = inner.lock().unwrap_or_else(|e| e.into_inner());
            fetch(&mut ev, &g, &t, &opts)
        })?;
        to_python(py, r)
    }
}

/// A graph of one node `id` of `schema`'s kind with `params` and the data block `data`.
fn one_node_graph(
    py: Python<'_>,
    schema: &'static tyndall_engine::graph::NodeSchema,
    id: &str,
    params: Option<&Bound<'_, PyDict>>,
    data: Option<String>,
) -> PyResult<tyndall_engine::graph::Graph> {
    let cat = registry().catalog().clone();
    let (kind, id) = (schema.kind, id.to_string());
    let data = match data {
        Some(text) => Some(
            tyndall_engine::graph::NodeData::from_text(&text).map_err(|e| {
                raise::<GraphError>(
                    py,
                    format!("node '{id}' data block: {e}"),
                    About {
                        node: Some(id.clone()),
                        ..About::default()
                    },
                )
            })?,
        ),
        None => None,
    };
    let mut g = tyndall_engine::graph::Graph::new();
    g.insert_node(
        &cat,
        tyndall_engine::graph::Node {
            id: id.clone(),
            kind: kind.to_string(),
            params: BTreeMap::new(),
            keys: BTreeMap::new(),
            pos: None,
            data,
        },
    )
    .map_err(|e| graph_err(py, &e))?;
    for (k, v) in params
        .map(|p| p.iter().collect::<Vec<_>>())
        .unwrap_or_default()
    {
        let k: String = k.extract()?;
        let spec = crate::graph::param_spec(py, &id, schema, &k)?;
        let value = to_param(&id, spec, &v)?;
        g.set_param(&cat, &id, &k, value)
            .map_err(|e| graph_err(py, &e))?;
    }
    Ok(g)
}

/// Each input array as the port's type, as `tyndall node` makes it of a file.
type Feed = (String, Raster, tyndall_engine::graph::PortType);

fn array_feeds<'py>(
    py: Python<'py>,
    schema: &'static tyndall_engine::graph::NodeSchema,
    id: &str,
    inputs: Option<&Bound<'py, PyDict>>,
) -> PyResult<Vec<Feed>> {
    let (kind, id) = (schema.kind, id.to_string());
    let mut feeds = Vec::new();
    for (k, v) in inputs
        .map(|p| p.iter().collect::<Vec<_>>())
        .unwrap_or_default()
    {
        let port: String = k.extract()?;
        let about = || About {
            node: Some(id.clone()),
            port: Some(port.clone()),
            param: None,
        };
        let spec = schema.input(&port).ok_or_else(|| {
            raise::<GraphError>(
                py,
                format!(
                    "{kind} has no input port '{port}' (its inputs: {})",
                    schema.input_names()
                ),
                about(),
            )
        })?;
        let arr: PyReadonlyArrayDyn<'py, f32> = v.extract()?;
        let r = from_array(&format!("input '{port}'"), &arr)
            .map_err(|m| raise::<GraphError>(py, m, about()))?;
        let ty = tyndall_engine::graph::type_for_file(spec.types, r.channels).ok_or_else(|| {
            raise::<GraphError>(
                py,
                format!(
                    "input '{port}' of {kind} takes {}: a {}-channel array cannot feed it",
                    spec.types
                        .iter()
                        .map(|t| t.to_string())
                        .collect::<Vec<_>>()
                        .join(" | "),
                    r.channels
                ),
                about(),
            )
        })?;
        feeds.push((port, r, ty));
    }
    Ok(feeds)
}

/// Native half of `tyndall.node`: one node of `kind` on in-memory arrays.
#[pyfunction]
#[pyo3(signature = (kind, params=None, inputs=None, outputs=None, time=0.0, size=None, data=None, ocio=None))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn node<'py>(
    py: Python<'py>,
    kind: &str,
    params: Option<&Bound<'py, PyDict>>,
    inputs: Option<&Bound<'py, PyDict>>,
    outputs: Option<Vec<String>>,
    time: f64,
    size: Option<(u32, u32)>,
    data: Option<String>,
    ocio: Option<String>,
) -> PyResult<Bound<'py, PyList>> {
    let reg = registry();
    let cat = reg.catalog().clone();
    let schema = cat.get(kind).ok_or_else(|| {
        graph_err(
            py,
            &tyndall_engine::graph::GraphError::UnknownKind {
                node: kind.to_lowercase(),
                kind: kind.to_string(),
                known: cat.kind_names(),
            },
        )
    })?;
    let id = kind.to_lowercase();
    let g = one_node_graph(py, schema, &id, params, data)?;
    let feeds = array_feeds(py, schema, &id, inputs)?;
    let wanted: Vec<Wanted> = match outputs {
        Some(o) => o
            .into_iter()
            .map(|p| (format!("{id}.{p}"), id.clone(), p))
            .collect(),
        None => schema
            .outputs
            .iter()
            .filter(|p| {
                p.types.iter().any(|t| {
                    use tyndall_engine::graph::PortType as T;
                    matches!(
                        t,
                        T::Image | T::Scalar | T::Depth | T::ShadowMap | T::Lut2D | T::LightMap
                    )
                })
            })
            .map(|p| (format!("{id}.{}", p.name), id.clone(), p.name.to_string()))
            .collect(),
    };
    let ocio = ocio.unwrap_or_default();
    if !ocio.is_empty() {
        tyndall_engine::colour::load(&ocio).map_err(|e| colour_err(&e))?;
    }
    let gpu = Gpu::shared().map_err(|e| gpu_err(py, &e))?;
    let mut opts = EvalOptions {
        time,
        ..Default::default()
    };
    if let Some(s) = size {
        opts.size = s;
    }
    let r = off_thread(py, move || -> Result<Fetched, Failed> {
        for (port, r, ty) in feeds {
            let v = tyndall_engine::eval::upload_raster(&gpu, &r, ty).map_err(|source| {
                Failed::Eval(RustEvalError::Node {
                    node: id.clone(),
                    kind: g.node(&id).map(|n| n.kind.clone()).unwrap_or_default(),
                    source: tyndall_engine::eval::NodeError::Input {
                        port: port.clone(),
                        message: source.to_string(),
                    },
                })
            })?;
            let key = {
                use std::hash::{Hash, Hasher};
                let mut h = std::hash::DefaultHasher::new();
                (r.width, r.height, r.channels).hash(&mut h);
                r.data.iter().for_each(|x| x.to_bits().hash(&mut h));
                h.finish()
            };
            opts.inject.insert((id.clone(), port), (v, key));
        }
        let mut ev = tyndall_engine::eval::Evaluator::new(registry(), gpu);
        ev.set_colour_config(&ocio)
            .map_err(|e| Failed::Eval(e.into()))?;
        fetch(&mut ev, &g, &wanted, &opts)
    })?;
    to_python(py, r)
}
