//! Arguments from Python and results back to it: point arrays, counts, shapes.

use crate::errors::PlanicpError;
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Copies an (N, 2) float64 array into owned points; `what` names it in errors.
pub(crate) fn points_from(what: &str, array: &PyReadonlyArray2<'_, f64>) -> PyResult<Vec<[f64; 2]>> {
    let shape = array.shape();
    if shape[1] != 2 {
        return Err(PlanicpError::new_err(format!(
            "{what} must have shape (N, 2), got ({}, {})",
            shape[0], shape[1]
        )));
    }
    Ok(array.as_array().rows().into_iter().map(|r| [r[0], r[1]]).collect())
}

/// The (N, 2) float64 array of `points`.
pub(crate) fn points_to_array<'py>(py: Python<'py>, points: &[[f64; 2]]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = points.iter().flat_map(|p| [p[0], p[1]]).collect();
    Array2::from_shape_vec((points.len(), 2), flat).expect("length matches shape").into_pyarray(py)
}

/// Two (N,) bool arrays.
pub(crate) type BoolPair<'py> = (Bound<'py, PyArray1<bool>>, Bound<'py, PyArray1<bool>>);

/// A non-negative integer below 2**64 (a Python int or anything with `__index__`, e.g. numpy
/// integers): TypeError for a non-integer, PlanicpError out of range.
pub(crate) fn unsigned_arg(what: &str, value: &Bound<'_, PyAny>) -> PyResult<u64> {
    let out_of_range =
        || PlanicpError::new_err(format!("{what} must be a non-negative integer below 2**64, got {value}"));
    let wide: i128 = value.extract().map_err(|_| {
        if value.is_instance_of::<pyo3::types::PyInt>() {
            return out_of_range();
        }
        let name = value.get_type().name().map(|n| n.to_string()).unwrap_or_default();
        pyo3::exceptions::PyTypeError::new_err(format!("{what} must be an int, got {name}"))
    })?;
    u64::try_from(wide).map_err(|_| out_of_range())
}

/// A count (a size, a number of beams or directions) from Python: [`unsigned_arg`] (so a negative
/// int is a PlanicpError, not pyo3's OverflowError), saturated to `usize::MAX` where `usize` is
/// narrower, for the core to refuse as too large.
pub(crate) fn count_arg(what: &str, value: &Bound<'_, PyAny>) -> PyResult<usize> {
    unsigned_arg(what, value).map(|n| usize::try_from(n).unwrap_or(usize::MAX))
}

/// A shape as Python prints it: `(3,)`, `(2, 4)`.
pub(crate) fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", ")),
    }
}
