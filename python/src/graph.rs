//! `tyndall.Graph` (the document, with its own checks: a bad edge or value raises `GraphError`
//! naming node and parameter) and `tyndall.catalog()`.

use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

use tyndall_engine::graph::{Interp, Key, NodeSchema};

use crate::values::{from_param, to_param};
use crate::{graph_err, load_err, raise, registry, About, GraphError};

/// A Tyndall graph document: nodes, edges, parameters and key-frames, the groups it uses.
#[pyclass(module = "tyndall._native", name = "Graph")]
#[derive(Clone)]
pub struct Graph {
    pub(crate) g: tyndall_engine::graph::Graph,
    /// The file it came from: relative input files and library groups are found beside it.
    pub(crate) path: Option<PathBuf>,
}

impl Graph {
    fn schema(&self, py: Python<'_>, node: &str) -> PyResult<&'static NodeSchema> {
        let n = self.g.node(node).ok_or_else(|| {
            graph_err(
                py,
                &tyndall_engine::graph::GraphError::UnknownNode {
                    node: node.to_string(),
                },
            )
        })?;
        let cat = registry().catalog().clone();
        self.g.kind_schema(&cat, &n.kind).ok_or_else(|| {
            raise::<GraphError>(
                py,
                format!("node '{node}': unknown kind '{}'", n.kind),
                About {
                    node: Some(node.to_string()),
                    ..About::default()
                },
            )
        })
    }

    fn spec(
        &self,
        py: Python<'_>,
        node: &str,
        param: &str,
    ) -> PyResult<&'static tyndall_engine::graph::ParamSpec> {
        let schema = self.schema(py, node)?;
        param_spec(py, node, schema, param)
    }
}

#[pymethods]
impl Graph {
    /// Graph() -> an empty graph.
    #[new]
    fn new() -> Self {
        Self {
            g: tyndall_engine::graph::Graph::new(),
            path: None,
        }
    }

    /// Graph.load(path) -> Graph: read a graph file (any format version; library groups are
    /// looked up beside it). Raises GraphError naming the file, the place and the node.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let cat = registry().catalog().clone();
        let g = tyndall_engine::graph::load_file(&path, &cat).map_err(|e| load_err(py, &e))?;
        Ok(Self {
            g,
            path: Some(path),
        })
    }

    /// Graph.from_str(text, path=None) -> Graph: parse graph text; `path` is where relative
    /// files and library groups are looked up from (default: the working directory).
    #[staticmethod]
    #[pyo3(signature = (text, path=None))]
    fn from_str(py: Python<'_>, text: &str, path: Option<PathBuf>) -> PyResult<Self> {
        let cat = registry().catalog().clone();
        let file = path.clone().unwrap_or_else(|| PathBuf::from("<string>"));
        let g = tyndall_engine::graph::load_str(text, &file, &cat).map_err(|e| load_err(py, &e))?;
        Ok(Self { g, path })
    }

    /// g.save(path): write the graph (format v3, atomically); it becomes the graph's file.
    fn save(&mut self, py: Python<'_>, path: PathBuf) -> PyResult<()> {
        tyndall_engine::graph::save_file(&path, &self.g).map_err(|e| graph_err(py, &e))?;
        self.path = Some(path);
        Ok(())
    }

    /// g.to_str() -> str: the graph's text, as `save` writes it.
    fn to_str(&self) -> String {
        tyndall_engine::graph::save_string(&self.g)
    }

    /// The file the graph came from (or was saved to), or None.
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.path.clone()
    }

    /// dict node id → kind, in document order.
    #[getter]
    fn nodes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for n in self.g.nodes() {
            d.set_item(&n.id, &n.kind)?;
        }
        Ok(d)
    }

    /// list of ("node.port", "node.port") edges, source first.
    #[getter]
    fn edges(&self) -> Vec<(String, String)> {
        self.g
            .edges()
            .iter()
            .map(|e| {
                (
                    format!("{}.{}", e.from_node, e.from_port),
                    format!("{}.{}", e.to_node, e.to_port),
                )
            })
            .collect()
    }

    /// g.get(node, param, time=0.0): the parameter's value at `time` (its key-frames sampled;
    /// the default when it is not set).
    #[pyo3(signature = (node, param, time=0.0))]
    fn get(&self, py: Python<'_>, node: &str, param: &str, time: f64) -> PyResult<Py<PyAny>> {
        self.spec(py, node, param)?;
        let cat = registry().catalog().clone();
        let v = self
            .g
            .param_at(&cat, node, param, time)
            .map_err(|e| graph_err(py, &e))?;
        from_param(py, &v)
    }

    /// g.set(node, param, value): set a parameter (checked against its type and range; a
    /// group node's knobs too). Raises GraphError with .node and .param.
    fn set(
        &mut self,
        py: Python<'_>,
        node: &str,
        param: &str,
        value: &Bound<'_, PyAny>,
    ) -> PyResult<()> {
        let spec = self.spec(py, node, param)?;
        let v = to_param(node, spec, value)?;
        let cat = registry().catalog().clone();
        self.g
            .set_param(&cat, node, param, v)
            .map_err(|e| graph_err(py, &e))
    }

    /// g.add_node(id, kind, **params) -> id: add a node (a built-in kind or a group this graph
    /// uses) with parameters. An empty id takes a fresh one from the kind (`tonemap1`).
    #[pyo3(signature = (id, kind, **params))]
    fn add_node(
        &mut self,
        py: Python<'_>,
        id: &str,
        kind: &str,
        params: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<String> {
        let cat = registry().catalog().clone();
        let id = if id.is_empty() {
            self.g.fresh_id(kind)
        } else {
            id.to_string()
        };
        let before = self.g.clone();
        let node = tyndall_engine::graph::Node {
            id: id.clone(),
            kind: kind.to_string(),
            params: Default::default(),
            keys: Default::default(),
            pos: None,
            data: None,
        };
        self.g
            .insert_node(&cat, node)
            .map_err(|e| graph_err(py, &e))?;
        if let Some(params) = params {
            for (k, v) in params.iter() {
                let k: String = k.extract()?;
                if let Err(e) = self.set(py, &id, &k, &v) {
                    self.g = before;
                    return Err(e);
                }
            }
        }
        Ok(id)
    }

    /// g.remove_node(id): remove a node and its edges.
    fn remove_node(&mut self, py: Python<'_>, id: &str) -> PyResult<()> {
        self.g
            .remove_node(id)
            .map(|_| ())
            .map_err(|e| graph_err(py, &e))
    }

    /// g.connect("a.port", "b.port"): add an edge (type-checked; a cycle or a taken input is
    /// refused). Raises GraphError with .node and .port of the input.
    fn connect(&mut self, py: Python<'_>, source: &str, target: &str) -> PyResult<()> {
        let cat = registry().catalog().clone();
        self.g
            .connect(&cat, source, target)
            .map_err(|e| graph_err(py, &e))
    }

    /// g.disconnect("b.port") -> bool: remove the edge into an input; whether there was one.
    fn disconnect(&mut self, target: &str) -> bool {
        let (n, p) = target.split_once('.').unwrap_or((target, ""));
        self.g.disconnect(n, p)
    }

    /// g.keys(node, param) -> list of (t, value, interp): the parameter's key-frames
    /// (interp "linear" or "hold"); empty when it is not animated.
    fn keys(&self, py: Python<'_>, node: &str, param: &str) -> PyResult<Vec<(f64, f64, String)>> {
        self.spec(py, node, param)?;
        let n = self
            .g
            .node(node)
            .ok_or_else(|| PyErr::new::<GraphError, _>("no node"))?;
        Ok(n.keys
            .get(param)
            .map(|ks| {
                ks.iter()
                    .map(|k| {
                        let i = match k.interp {
                            Interp::Linear => "linear",
                            Interp::Hold => "hold",
                        };
                        (k.t, k.v, i.to_string())
                    })
                    .collect()
            })
            .unwrap_or_default())
    }

    /// g.set_keys(node, param, keys): key-frame a numeric parameter; `keys` is a list of
    /// (t, value) or (t, value, "linear" | "hold"); an empty list removes the animation.
    fn set_keys(
        &mut self,
        py: Python<'_>,
        node: &str,
        param: &str,
        keys: Vec<Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        self.spec(py, node, param)?;
        let mut out = Vec::new();
        for k in keys {
            let (t, v, interp) = match k.extract::<(f64, f64, String)>() {
                Ok(x) => x,
                Err(_) => {
                    let (t, v): (f64, f64) = k.extract()?;
                    (t, v, "linear".to_string())
                }
            };
            let interp = match interp.as_str() {
                "linear" => Interp::Linear,
                "hold" => Interp::Hold,
                other => {
                    return Err(raise::<GraphError>(
                        py,
                        format!("{node}.{param}: interpolation '{other}' is not linear or hold"),
                        About {
                            node: Some(node.to_string()),
                            port: None,
                            param: Some(param.to_string()),
                        },
                    ))
                }
            };
            out.push(Key { t, v, interp });
        }
        let cat = registry().catalog().clone();
        self.g
            .set_keys(&cat, node, param, out)
            .map_err(|e| graph_err(py, &e))
    }

    /// g.copy() -> Graph: an independent copy.
    fn copy(&self) -> Self {
        self.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "<tyndall.Graph {} nodes, {} edges{}>",
            self.g.len(),
            self.g.edges().len(),
            self.path
                .as_ref()
                .map(|p| format!(" from {}", p.display()))
                .unwrap_or_default()
        )
    }
}

/// Parameter `param` of node `node` (of `schema`'s kind), or GraphError naming both and the
/// parameters there are.
pub(crate) fn param_spec(
    py: Python<'_>,
    node: &str,
    schema: &'static NodeSchema,
    param: &str,
) -> PyResult<&'static tyndall_engine::graph::ParamSpec> {
    schema.param(param).ok_or_else(|| {
        graph_err(
            py,
            &tyndall_engine::graph::GraphError::UnknownParam {
                node: node.to_string(),
                kind: schema.kind.to_string(),
                param: param.to_string(),
                known: schema
                    .params
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", "),
            },
        )
    })
}

/// catalog() -> list of dict: every built-in node kind, then the library groups found for the
/// working directory (`graphs/lib`, `$TYNDALL_PRESETS/lib`): kind, category, doc, inputs and
/// outputs (name, types, required, doc), params (name, type, default, min, max, unit, doc,
/// choices for enums), and `library` (the group's reference) for groups.
#[pyfunction]
pub(crate) fn catalog<'py>(py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
    let reg = registry();
    let cat = reg.catalog().clone();
    let list = PyList::empty(py);
    for s in cat.iter() {
        list.append(schema_dict(py, s, None)?)?;
    }
    let here = PathBuf::from("graphs/untitled.ron");
    for (folder, reference) in
        tyndall_engine::graph::list_library(&tyndall_engine::graph::library_folders(&here))
    {
        if let Ok(def) = tyndall_engine::graph::load_library_group(&folder, &reference, &cat) {
            list.append(schema_dict(py, def.schema(), Some(&reference))?)?;
        }
    }
    Ok(list)
}

fn schema_dict<'py>(
    py: Python<'py>,
    s: &NodeSchema,
    library: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("kind", s.kind)?;
    d.set_item("category", s.category)?;
    d.set_item("doc", s.doc)?;
    let ports = |ps: &[tyndall_engine::graph::PortSpec]| -> PyResult<Bound<'py, PyList>> {
        let l = PyList::empty(py);
        for p in ps {
            let pd = PyDict::new(py);
            pd.set_item("name", p.name)?;
            pd.set_item(
                "types",
                p.types.iter().map(|t| t.to_string()).collect::<Vec<_>>(),
            )?;
            pd.set_item("required", p.required)?;
            pd.set_item("doc", p.doc)?;
            l.append(pd)?;
        }
        Ok(l)
    };
    d.set_item("inputs", ports(s.inputs)?)?;
    d.set_item("outputs", ports(s.outputs)?)?;
    let params = PyList::empty(py);
    for p in s.params {
        let pd = PyDict::new(py);
        pd.set_item("name", p.name)?;
        pd.set_item("type", p.kind.name())?;
        pd.set_item("default", from_param(py, &p.default.value())?)?;
        let numeric = p.kind.is_numeric();
        pd.set_item("min", numeric.then_some(p.min))?;
        pd.set_item("max", numeric.then_some(p.max))?;
        pd.set_item("unit", p.unit)?;
        pd.set_item("doc", p.doc)?;
        if let tyndall_engine::graph::ParamKind::Enum(names) = p.kind {
            pd.set_item("choices", names.to_vec())?;
        }
        params.append(pd)?;
    }
    d.set_item("params", params)?;
    d.set_item("library", library)?;
    Ok(d)
}
