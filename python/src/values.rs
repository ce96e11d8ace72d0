//! Conversions between Python values and Tyndall's: parameter values by the parameter's kind,
//! numpy `float32` arrays and rasters (H×W for one channel, H×W×4 for RGBA), camera matrices,
//! and image files.

use numpy::{PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use pyo3::IntoPyObjectExt;

use tyndall_engine::graph::{ParamKind, ParamSpec, ParamValue};
use tyndall_engine::io::Raster;

use crate::{raise, About, GraphError};

/// A Python value as the value of parameter `spec` of node `node` (a float for `Float`, an int
/// for `Int`, a bool, a string for `Enum`/`Text`, 3 or 4 floats for `Colour`, 3 for `Vec3`).
pub(crate) fn to_param(node: &str, spec: &ParamSpec, v: &Bound<'_, PyAny>) -> PyResult<ParamValue> {
    let py = v.py();
    let wrong = |what: &str| {
        raise::<GraphError>(
            py,
            format!(
                "node '{node}' parameter '{}': expected {what}, got {}",
                spec.name,
                v.repr().map(|r| r.to_string()).unwrap_or_default()
            ),
            About {
                node: Some(node.to_string()),
                port: None,
                param: Some(spec.name.to_string()),
            },
        )
    };
    let is_bool = v.is_instance_of::<pyo3::types::PyBool>();
    Ok(match spec.kind {
        ParamKind::Float if !is_bool => {
            ParamValue::Float(v.extract::<f64>().map_err(|_| wrong("a number"))?)
        }
        ParamKind::Int if !is_bool => {
            ParamValue::Int(v.extract::<i64>().map_err(|_| wrong("an integer"))?)
        }
        ParamKind::Bool if is_bool => ParamValue::Bool(v.extract::<bool>()?),
        ParamKind::Enum(names) => {
            let s: String = v.extract().map_err(|_| wrong("a string"))?;
            if !names.contains(&s.as_str()) {
                return Err(wrong(&format!("one of {}", names.join(", "))));
            }
            ParamValue::Enum(s)
        }
        ParamKind::Text => ParamValue::Text(v.extract().map_err(|_| wrong("a string"))?),
        ParamKind::Colour => {
            let c: Vec<f64> = v.extract().map_err(|_| wrong("3 or 4 numbers"))?;
            match c.as_slice() {
                [r, g, b] => ParamValue::Colour([*r, *g, *b, 1.0]),
                [r, g, b, a] => ParamValue::Colour([*r, *g, *b, *a]),
                _ => return Err(wrong("3 or 4 numbers")),
            }
        }
        ParamKind::Vec3 => {
            let c: Vec<f64> = v.extract().map_err(|_| wrong("3 numbers"))?;
            match c.as_slice() {
                [x, y, z] => ParamValue::Vec3([*x, *y, *z]),
                _ => return Err(wrong("3 numbers")),
            }
        }
        ParamKind::Float => return Err(wrong("a number")),
        ParamKind::Int => return Err(wrong("an integer")),
        ParamKind::Bool => return Err(wrong("a bool")),
    })
}

/// A parameter value as a Python value (colours and vectors as tuples).
pub(crate) fn from_param(py: Python<'_>, v: &ParamValue) -> PyResult<Py<PyAny>> {
    match v {
        ParamValue::Float(x) => x.into_py_any(py),
        ParamValue::Int(x) => x.into_py_any(py),
        ParamValue::Bool(x) => x.into_py_any(py),
        ParamValue::Enum(s) | ParamValue::Text(s) => s.into_py_any(py),
        ParamValue::Colour([r, g, b, a]) => (*r, *g, *b, *a).into_py_any(py),
        ParamValue::Vec3([x, y, z]) => (*x, *y, *z).into_py_any(py),
    }
}

/// A raster as a numpy `float32` array: H×W for one channel, H×W×C otherwise.
pub(crate) fn to_array(py: Python<'_>, r: Raster) -> PyResult<Py<PyAny>> {
    let (h, w, c) = (r.height as usize, r.width as usize, r.channels as usize);
    let flat = numpy::PyArray1::from_vec(py, r.data);
    let arr = if c == 1 {
        flat.reshape(vec![h, w])?
    } else {
        flat.reshape(vec![h, w, c])?
    };
    Ok(arr.into_any().unbind())
}

/// A numpy `float32` array as a raster: H×W or H×W×1 → one channel, H×W×3 → RGBA with alpha
/// 1, H×W×4 → RGBA.
pub(crate) fn from_array(what: &str, a: &PyReadonlyArrayDyn<'_, f32>) -> Result<Raster, String> {
    let shape = a.shape().to_vec();
    let view = a.as_array();
    let data: Vec<f32> = view.iter().copied().collect();
    let (h, w, c) = match shape.as_slice() {
        [h, w] => (*h, *w, 1),
        [h, w, c @ (1 | 3 | 4)] => (*h, *w, *c),
        _ => {
            return Err(format!(
                "{what}: an array of shape {shape:?} is not a picture (H×W, or H×W×1, 3 or 4)"
            ))
        }
    };
    if h == 0 || w == 0 {
        return Err(format!("{what}: an empty array ({shape:?})"));
    }
    let (channels, data) = if c == 3 {
        let rgba = data
            .chunks(3)
            .flat_map(|p| [p[0], p[1], p[2], 1.0])
            .collect();
        (4, rgba)
    } else {
        (c as u32, data)
    };
    Ok(Raster {
        width: w as u32,
        height: h as u32,
        channels,
        data,
    })
}

/// A camera's or light's matrices as a dict: `view` and `proj` (4×4 row-major nested lists,
/// the transposes of the column-major matrices the shaders use), `far`, `radiance`.
pub(crate) fn matrices<'py>(
    py: Python<'py>,
    m: &tyndall_engine::eval::Matrices,
) -> PyResult<Bound<'py, PyDict>> {
    let rows = |c: &tyndall_engine::eval::Mat4| -> Vec<Vec<f32>> {
        (0..4).map(|r| (0..4).map(|k| c[k][r]).collect()).collect()
    };
    let d = PyDict::new(py);
    d.set_item("view", rows(&m.view))?;
    d.set_item("proj", rows(&m.proj))?;
    d.set_item("far", m.far)?;
    d.set_item("radiance", m.radiance.to_vec())?;
    Ok(d)
}

/// read_image(path) -> numpy.ndarray
///
/// Read an EXR or PNG file as Tyndall reads it: one channel → H×W, colour → H×W×4 `float32`
/// (PNG colour decoded from sRGB to linear).
#[pyfunction]
pub(crate) fn read_image(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Py<PyAny>> {
    let r = tyndall_engine::io::read_image(&path, true)
        .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.to_string()))?;
    to_array(py, r)
}

/// write_image(path, array)
///
/// Write a `float32` array (H×W, H×W×3 or H×W×4) as EXR (32-bit float) or PNG (8-bit, sRGB),
/// by the file's extension; atomically, creating missing folders.
#[pyfunction]
pub(crate) fn write_image(
    path: std::path::PathBuf,
    array: PyReadonlyArrayDyn<'_, f32>,
) -> PyResult<()> {
    let r = from_array("array", &array).map_err(PyValueError::new_err)?;
    let png = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    let (precision, srgb) = if png {
        (tyndall_engine::io::Precision::U8, true)
    } else {
        (tyndall_engine::io::Precision::F32, false)
    };
    tyndall_engine::io::write_image(&path, &r, precision, srgb)
        .map_err(|e| pyo3::exceptions::PyOSError::new_err(e.to_string()))
}
