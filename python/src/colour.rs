//! Colour conversions for Python (`tyndall.convert_colourspace`, and through it
//! `tyndall.testing`'s comparisons in a chosen colour space): OpenColorIO's CPU processor, the
//! same one the `ColourSpace` node is tested against.

use numpy::{PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A colour config error as `ValueError` (bad input, as the command line's exit 2).
pub(crate) fn colour_err(e: &tyndall_engine::colour::ColourError) -> PyErr {
    PyValueError::new_err(format!("ocio: {e}"))
}

/// convert_colourspace(array, to, source="", ocio=None) -> numpy.ndarray
///
/// `array` (H×W×3 or H×W×4, alpha kept) converted from colour space `source` (empty: the
/// working space, `Linear Rec.709 (sRGB)` or the config's `scene_linear`) to `to`, through
/// config `ocio` (a file or an `ocio://` name; None: `$OCIO`, else the built-in config), on the
/// CPU. Names may be aliases or roles. A returned `float32` array of the same shape.
#[pyfunction]
#[pyo3(signature = (array, to, source="", ocio=None))]
pub(crate) fn convert_colourspace(
    py: Python<'_>,
    array: PyReadonlyArrayDyn<'_, f32>,
    to: &str,
    source: &str,
    ocio: Option<&str>,
) -> PyResult<Py<PyAny>> {
    let shape = array.shape().to_vec();
    let channels = match shape.as_slice() {
        [_, _, c @ (3 | 4)] => *c,
        _ => {
            return Err(PyValueError::new_err(format!(
                "array: a colour conversion needs an H×W×3 or H×W×4 array, not {shape:?}"
            )))
        }
    };
    let config = tyndall_engine::colour::load(ocio.unwrap_or("")).map_err(|e| colour_err(&e))?;
    let working = tyndall_engine::colour::WORKING_SPACE;
    let from = config
        .colour_space(source, working)
        .map_err(|e| colour_err(&e))?;
    let to = config
        .colour_space(to, working)
        .map_err(|e| colour_err(&e))?;
    let cpu = config
        .processor(&from, &to)
        .map_err(|e| colour_err(&e))?
        .default_cpu_processor();
    let mut data: Vec<f32> = array.as_array().iter().copied().collect();
    py.detach(|| {
        if channels == 4 {
            cpu.apply_rgba_slice(&mut data);
        } else {
            cpu.apply_rgb_slice(&mut data);
        }
    });
    let flat = numpy::PyArray1::from_vec(py, data);
    Ok(flat.reshape(shape)?.into_any().unbind())
}
