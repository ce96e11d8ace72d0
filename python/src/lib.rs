//! The native module of the `tyndall` Python package (`tyndall._native`): the document
//! (`Graph`), the evaluator with its cache (`Evaluator`), one node on arrays (`node`), frame
//! rendering (`render`), the catalog, image files, and the exception classes. The Python side
//! (`python/tyndall/__init__.py`) wraps results in small classes and adds `tyndall.testing`.
//!
//! GPU work runs on a thread of its own while the calling thread waits without the GIL,
//! checking for Ctrl+C every 50 ms: an interrupted call raises `KeyboardInterrupt` at once and
//! the evaluation in flight finishes in the background (the next call on the same evaluator
//! waits for it), so the evaluator's cache is never left half-written.

use std::sync::{Arc, OnceLock};

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

mod colour;
mod evaluate;
mod graph;
mod render;
mod values;

create_exception!(
    _native,
    GraphError,
    PyValueError,
    "A graph was refused: bad file, unknown kind or node, bad edge, value of the wrong type or out of range. Attributes: node, port, param (None when not about one)."
);
create_exception!(
    _native,
    EvalError,
    PyRuntimeError,
    "An evaluation failed in a node. Attributes: node, port, param (None when not about one)."
);
create_exception!(
    _native,
    GpuError,
    PyRuntimeError,
    "No usable GPU adapter, or the device was lost. Attributes: node, port, param (None)."
);

/// The node registry, built once per process.
pub(crate) fn registry() -> Arc<tyndall_engine::eval::Registry> {
    static REGISTRY: OnceLock<Arc<tyndall_engine::eval::Registry>> = OnceLock::new();
    REGISTRY
        .get_or_init(|| Arc::new(tyndall_nodes::registry()))
        .clone()
}

/// What an error is about, for the exception's attributes.
#[derive(Default)]
pub(crate) struct About {
    pub node: Option<String>,
    pub port: Option<String>,
    pub param: Option<String>,
}

/// An exception of class `E` with message `msg` and the attributes `node`, `port`, `param`.
pub(crate) fn raise<E: pyo3::PyTypeInfo>(py: Python<'_>, msg: String, about: About) -> PyErr {
    let err = PyErr::new::<E, _>(msg);
    let v = err.value(py);
    // Setting an attribute on a fresh exception instance cannot fail.
    let _ = v.setattr("node", about.node);
    let _ = v.setattr("port", about.port);
    let _ = v.setattr("param", about.param);
    err
}

/// A document error as `GraphError`, with the node, port and parameter it names.
pub(crate) fn graph_err(py: Python<'_>, e: &tyndall_engine::graph::GraphError) -> PyErr {
    raise::<GraphError>(py, e.to_string(), about_graph(e))
}

/// A file that does not load as `GraphError` (the message names the file and the place).
pub(crate) fn load_err(py: Python<'_>, e: &tyndall_engine::graph::LoadError) -> PyErr {
    raise::<GraphError>(py, e.to_string(), about_graph(&e.error))
}

/// The node, port and parameter a document error names.
fn about_graph(e: &tyndall_engine::graph::GraphError) -> About {
    use tyndall_engine::graph::GraphError as G;
    let s = |x: &str| Some(x.to_string());
    let endpoint = |x: &str| x.split_once('.').map(|(n, p)| (s(n), s(p)));
    match e {
        G::UnknownKind { node, .. }
        | G::DuplicateNode { node }
        | G::UnknownNode { node }
        | G::EdgeMissingNode { node, .. }
        | G::LibraryGroup { node, .. } => About {
            node: s(node),
            ..About::default()
        },
        G::UnknownParam { node, param, .. }
        | G::WrongParamType { node, param, .. }
        | G::OutOfRange { node, param, .. } => About {
            node: s(node),
            param: s(param),
            ..About::default()
        },
        G::EdgeMissingPort { node, port, .. } => About {
            node: s(node),
            port: s(port),
            ..About::default()
        },
        G::TypeMismatch { to, .. } | G::InputTaken { to, .. } | G::Cycle { to, .. } => {
            let (node, port) = endpoint(to).unwrap_or((None, None));
            About {
                node,
                port,
                ..About::default()
            }
        }
        G::BadKeys { target, .. } => {
            let (node, param) = endpoint(target).unwrap_or((None, None));
            About {
                node,
                param,
                ..About::default()
            }
        }
        _ => About::default(),
    }
}

/// An evaluation error as `EvalError` (`GpuError` for a lost device, `GraphError` for a
/// document the registry refuses).
pub(crate) fn eval_err(py: Python<'_>, e: &tyndall_engine::eval::EvalError) -> PyErr {
    use tyndall_engine::eval::{EvalError as E, NodeError as N};
    match e {
        E::Graph(g) => graph_err(py, g),
        E::UnknownOutput { node, port, .. } => raise::<EvalError>(
            py,
            e.to_string(),
            About {
                node: Some(node.clone()),
                port: Some(port.clone()),
                param: None,
            },
        ),
        E::Node { node, source, .. } => {
            let mut about = About {
                node: Some(node.clone()),
                ..About::default()
            };
            match source {
                N::Input { port, .. } => about.port = Some(port.clone()),
                N::Param { param, .. } => about.param = Some(param.clone()),
                N::Gpu(_) if e.device_lost() => {
                    return raise::<GpuError>(py, e.to_string(), about);
                }
                _ => {}
            }
            raise::<EvalError>(py, e.to_string(), about)
        }
        E::Cancelled { before } => raise::<EvalError>(
            py,
            e.to_string(),
            About {
                node: Some(before.clone()),
                ..About::default()
            },
        ),
        // No node to name: the GPU work of several nodes was being submitted.
        E::Submit(_) => raise::<GpuError>(py, e.to_string(), About::default()),
        // The graph's working space: no node to name either.
        E::Colour(_) => raise::<EvalError>(py, e.to_string(), About::default()),
    }
}

/// A GPU context error as `GpuError`.
pub(crate) fn gpu_err(py: Python<'_>, e: &tyndall_engine::gpu::GpuError) -> PyErr {
    raise::<GpuError>(py, e.to_string(), About::default())
}

/// Wait for the GPU's queued work before the interpreter exits (registered with `atexit`):
/// Mesa's CPU drivers compile shaders on their queue thread, and a process that exits while
/// one runs crashes in LLVM's teardown (see `Gpu::settle_shared`).
#[pyfunction]
fn _settle(py: Python<'_>) {
    py.detach(tyndall_engine::gpu::Gpu::settle_shared);
}

/// The `tyndall._native` module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("GraphError", py.get_type::<GraphError>())?;
    m.add("EvalError", py.get_type::<EvalError>())?;
    m.add("GpuError", py.get_type::<GpuError>())?;
    m.add_class::<graph::Graph>()?;
    m.add_class::<evaluate::Evaluator>()?;
    m.add_function(wrap_pyfunction!(graph::catalog, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate::node, m)?)?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(values::read_image, m)?)?;
    m.add_function(wrap_pyfunction!(values::write_image, m)?)?;
    m.add_function(wrap_pyfunction!(colour::convert_colourspace, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(_settle, m)?)?;
    py.import("atexit")?
        .call_method1("register", (m.getattr("_settle")?,))?;
    Ok(())
}
