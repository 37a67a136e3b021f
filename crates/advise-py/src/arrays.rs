//! Numpy arrays in and out: any array-like is taken as a C-contiguous float64 matrix, checked
//! for its shape and for values that are not numbers before Rust code sees it.

use advise::domain::{Dim, Domain};
use numpy::{IntoPyArray, PyArray2, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::error::simple;

/// A row-major matrix of `cols` columns from `obj` (`name` in messages): its values and rows.
/// `None` for `cols` takes any width. Only arrays of real numbers are taken (floats, integers):
/// complex numbers, booleans, dates and times, text and Python objects are refused
/// (`advise::py::dtype`) rather than converted, and a masked array with masked values
/// (`advise::py::masked`) rather than read without its mask. Wrong shapes and values that are
/// not finite are `advise::py::shape` and `advise::py::not_finite`; a copy that memory cannot
/// hold is `advise::py::memory` (never an abort).
pub fn matrix(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    name: &str,
    cols: Option<usize>,
) -> PyResult<(Vec<f64>, usize)> {
    let np = py.import("numpy")?;
    let not_numbers = |e: PyErr| {
        simple(
            py,
            "advise::py::not_numbers",
            format!("`{name}` is not an array of numbers: {e}"),
            "pass a numpy array (or nested lists) of floats",
        )
    };
    let ma = np.getattr("ma")?;
    if ma.call_method1("isMaskedArray", (obj,))?.is_truthy()?
        && ma.call_method1("is_masked", (obj,))?.is_truthy()?
    {
        return Err(simple(
            py,
            "advise::py::masked",
            format!("`{name}` is a masked array with masked values"),
            "a masked value has no number to use: drop those rows, or fill them (`x.filled(v)`) \
             if a value is known",
        ));
    }
    let raw = np.call_method1("asarray", (obj,)).map_err(not_numbers)?;
    let kind: String = raw.getattr("dtype")?.getattr("kind")?.extract()?;
    let refused = match kind.as_str() {
        "f" | "i" | "u" => None,
        "c" => Some("complex numbers (their imaginary part would be dropped)"),
        "b" => Some("booleans"),
        "M" | "m" => Some("dates or durations"),
        "U" | "S" => Some("text"),
        "O" => Some("Python objects"),
        _ => Some("values that are not numbers"),
    };
    if let Some(what) = refused {
        let dtype = raw.getattr("dtype")?.str()?.to_string();
        return Err(simple(
            py,
            "advise::py::dtype",
            format!("`{name}` holds {what} (dtype {dtype})"),
            "pass real numbers (a float or integer array); convert explicitly first if the \
             values are numbers held another way (`np.asarray(x, dtype=float)`)",
        ));
    }
    let arr = np
        .call_method1("ascontiguousarray", (raw, "float64"))
        .map_err(not_numbers)?;
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
    let slice = ro.as_slice()?;
    let values = copy_of(py, slice, name)?;
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

/// `values` copied into a vector, or `advise::py::memory` when memory cannot hold the copy
/// (an allocation that fails is refused, never an abort of the interpreter).
pub fn copy_of(py: Python<'_>, values: &[f64], name: &str) -> PyResult<Vec<f64>> {
    let mut out = Vec::new();
    if out.try_reserve_exact(values.len()).is_err() {
        return Err(simple(
            py,
            "advise::py::memory",
            format!(
                "`{name}` ({} values, {}) does not fit in the memory left",
                values.len(),
                advise::files::fmt_bytes((values.len() as u64).saturating_mul(8))
            ),
            "pass fewer rows at a time, or free memory first",
        ));
    }
    out.extend_from_slice(values);
    Ok(out)
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
