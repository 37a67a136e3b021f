//! Numpy arrays in and out: any array-like is taken as a C-contiguous float64 matrix, checked
//! for its shape and for values that are not numbers before Rust code sees it.

use advise::domain::{Dim, Domain};
use numpy::{IntoPyArray, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::error::simple;

/// A row-major matrix of `cols` columns from `obj` (`name` in messages): its values and rows.
/// `None` for `cols` takes any width. Wrong shapes and values that are not finite are
/// `advise::py::shape` and `advise::py::not_finite`.
pub fn matrix(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    name: &str,
    cols: Option<usize>,
) -> PyResult<(Vec<f64>, usize)> {
    let np = py.import("numpy")?;
    let arr = np
        .call_method1("ascontiguousarray", (obj, "float64"))
        .map_err(|e| {
            simple(
                py,
                "advise::py::not_numbers",
                format!("`{name}` is not an array of numbers: {e}"),
                "pass a numpy array (or nested lists) of floats",
            )
        })?;
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let want = cols.map_or("(n, k)".to_string(), |c| format!("(n, {c})"));
    if ndim != 2 || cols.is_some_and(|c| shape[1] != c) {
        return Err(simple(
            py,
            "advise::py::shape",
            format!("`{name}` has shape {shape:?}, expected {want}"),
            "one row per point, one column per dimension of the domain, in the domain's order",
        ));
    }
    let arr = arr.cast_into::<PyArray2<f64>>()?;
    let ro = arr.readonly();
    let values = ro.as_slice()?.to_vec();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        let w = shape[1].max(1);
        return Err(simple(
            py,
            "advise::py::not_finite",
            format!(
                "`{name}` holds {} at row {}, column {}",
                values[i],
                i / w,
                i % w
            ),
            "every value must be a finite number: drop or repair the row",
        ));
    }
    Ok((values, ro.shape()[0]))
}

/// `values` (`rows * cols`, row-major) as a numpy array of shape `(rows, cols)`.
pub fn to_numpy<'py>(
    py: Python<'py>,
    values: Vec<f64>,
    rows: usize,
    cols: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    values.into_pyarray(py).reshape([rows, cols])
}

/// `strings` as a numpy array of str (numpy's own `array`, so its dtype is numpy's choice).
pub fn str_array<'py>(py: Python<'py>, strings: Vec<&str>) -> PyResult<Bound<'py, PyAny>> {
    py.import("numpy")?.call_method1("array", (strings,))
}

/// `observation_names` and `action_names` of `domain` into `d`: its dimensions' names, in order.
pub fn set_dim_names(d: &Bound<'_, PyDict>, domain: &Domain) -> PyResult<()> {
    let names = |dims: &[Dim]| dims.iter().map(|x| x.name.clone()).collect::<Vec<_>>();
    d.set_item("observation_names", names(&domain.observe))?;
    d.set_item("action_names", names(&domain.act))
}
