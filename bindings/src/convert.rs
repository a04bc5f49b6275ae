//! Python arguments to engine values and back: every array goes through
//! `numpy.asarray(x, dtype=float64)`; shapes and finiteness are checked here so
//! that a ValueError names the Python argument.

use nalgebra::DMatrixView;
use numpy::ndarray::{Array2, ShapeBuilder};
use numpy::{IntoPyArray, PyArray2, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// `numpy.asarray(obj, dtype=float64)`, with a ValueError naming `name` if
/// the object does not convert.
pub(crate) fn float_array<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    // A float64 array passes as it is; only other inputs pay for numpy.asarray.
    if let Ok(array) = obj.cast::<PyArrayDyn<f64>>() {
        return Ok(array.clone());
    }
    let py = obj.py();
    let fail = |why: String| PyValueError::new_err(format!("{name}: {why}"));
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let array = py
        .import("numpy")?
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| fail(format!("cannot convert to a float64 array ({e})")))?;
    array
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| fail(format!("cannot convert to a float64 array ({e})")))
}

/// The entries of `array` in logical (row-major) order: copied straight
/// from a C-contiguous buffer (no borrow bookkeeping), else read through a
/// borrow of the array.
pub(crate) fn entries(array: &Bound<'_, PyArrayDyn<f64>>) -> Vec<f64> {
    if array.is_c_contiguous() {
        if let Ok(values) = array.to_vec() {
            return values;
        }
    }
    array.readonly().as_array().iter().copied().collect()
}

/// A numpy array of a matrix or a block of one (a view with any strides):
/// its entries copied once, column by column, into a Fortran-ordered
/// array that numpy takes over.
pub(crate) fn to_numpy<'py>(py: Python<'py>, m: DMatrixView<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn(m.shape().f(), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// Two matrices returned together, as a tuple.
pub(crate) type MatrixPair<'py> = (Bound<'py, PyArray2<f64>>, Bound<'py, PyArray2<f64>>);

/// A 1-D array of length `n` with finite entries.
pub(crate) fn vector(
    obj: &Bound<'_, PyAny>,
    name: &str,
    n: usize,
    what: &str,
) -> PyResult<Vec<f64>> {
    let array = float_array(obj, name)?;
    if array.ndim() != 1 || array.len() != n {
        return Err(PyValueError::new_err(format!(
            "{name} must be 1-D of length {what} = {n}, got shape {}",
            shape(array.shape())
        )));
    }
    let values = entries(&array);
    check_finite(name, &values, |i| format!("[{i}]"))?;
    Ok(values)
}

/// A 2-D array with `n` columns and finite entries, in standard layout.
pub(crate) fn matrix(
    obj: &Bound<'_, PyAny>,
    name: &str,
    n: usize,
    what: &str,
) -> PyResult<Array2<f64>> {
    let array = float_array(obj, name)?;
    let dims = array.shape().to_vec();
    if dims.len() != 2 || dims[1] != n {
        return Err(PyValueError::new_err(format!(
            "{name} must be 2-D of shape (T, {what} = {n}), got shape {}",
            shape(&dims)
        )));
    }
    let values = entries(&array);
    check_finite(name, &values, |i| format!("[{}, {}]", i / n, i % n))?;
    Ok(Array2::from_shape_vec((dims[0], n), values).expect("shape checked above"))
}

/// A shape as Python prints it: (3,), (2, 4), ().
pub(crate) fn shape(dims: &[usize]) -> String {
    match dims {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            dims.iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

pub(crate) fn check_finite(
    name: &str,
    values: &[f64],
    index: impl Fn(usize) -> String,
) -> PyResult<()> {
    match values.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(PyValueError::new_err(format!(
            "{name}{} is not finite ({})",
            index(i),
            values[i]
        ))),
        None => Ok(()),
    }
}

/// The spelling of an option value.
pub(crate) fn name_of<T: PartialEq>(names: &[(&'static str, T)], value: T) -> &'static str {
    names
        .iter()
        .find(|(_, v)| *v == value)
        .map(|(n, _)| *n)
        .expect("every option value has a name")
}

/// An option value from its spelling; ValueError lists the choices.
pub(crate) fn keyword<T: Copy>(what: &str, text: &str, names: &[(&str, T)]) -> PyResult<T> {
    names
        .iter()
        .find(|(n, _)| *n == text)
        .map(|(_, v)| *v)
        .ok_or_else(|| {
            let choices: Vec<&str> = names.iter().map(|(n, _)| *n).collect();
            PyValueError::new_err(format!(
                "{what} must be one of {}, got '{text}'",
                choices.join(", ")
            ))
        })
}
