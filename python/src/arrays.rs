//! numpy arguments in, numpy arrays out. An argument already of the right dtype and C-contiguous
//! is read where it lies; anything else numpy can convert (a list, another real dtype, a strided
//! view) is converted once, and what cannot be (text, complex, objects, the wrong number of
//! dimensions) is an `ArrayError` naming the argument. Arrays going out take over the Rust
//! buffer they were built in, without a copy.

use crate::errors::arg;
use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{Element, IntoPyArray, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// `obj` as a C-contiguous array of `T` (numpy dtype `dtype`) with `ndim` dimensions.
pub(crate) fn array<'py, T: Element>(
    name: &str,
    obj: &Bound<'py, PyAny>,
    dtype: &str,
    ndim: usize,
) -> PyResult<PyReadonlyArrayDyn<'py, T>> {
    let py = obj.py();
    let array = match obj.cast::<PyArrayDyn<T>>() {
        Ok(a) if a.is_c_contiguous() => a.clone(),
        _ => {
            let np = py.import("numpy")?;
            let given = np.call_method1("asarray", (obj,)).map_err(|e| {
                if passes(py, &e) {
                    e
                } else {
                    arg(name, format!("not an array of numbers ({e})"))
                }
            })?;
            let kind: String = given.getattr("dtype")?.getattr("kind")?.extract()?;
            if !matches!(kind.as_str(), "i" | "u" | "f") {
                let dtype_name: String = given.getattr("dtype")?.str()?.extract()?;
                return Err(arg(
                    name,
                    format!("dtype {dtype_name}: expected real numbers ({dtype})"),
                ));
            }
            check_conversion(name, &np, &given, &kind, dtype)?;
            let converted = np.call_method1("ascontiguousarray", (given, dtype))?;
            converted
                .cast_into::<PyArrayDyn<T>>()
                .map_err(|_| arg(name, format!("cannot be read as {dtype}")))?
        }
    };
    if array.ndim() != ndim {
        return Err(arg(
            name,
            format!(
                "{} dimensions {}, expected {ndim}",
                array.ndim(),
                crate::arrays::shape(array.shape())
            ),
        ));
    }
    array
        .try_readonly()
        .map_err(|_| arg(name, "in use: written by another call right now"))
}

/// Refuses a conversion that would change values: fractions or non-finite values to integers,
/// numbers beyond float32's range to float32 (numpy would truncate, wrap or make them inf).
fn check_conversion(
    name: &str,
    np: &Bound<'_, PyModule>,
    given: &Bound<'_, PyAny>,
    kind: &str,
    dtype: &str,
) -> PyResult<()> {
    let size: usize = given.getattr("size")?.extract()?;
    if size == 0 || kind != "f" {
        return Ok(());
    }
    if dtype.starts_with("int") || dtype.starts_with("uint") {
        let whole = np.call_method1("equal", (given, np.call_method1("round", (given,))?))?;
        let bad = np.call_method1("argmin", (whole.call_method0("ravel")?,))?;
        if !whole.call_method0("all")?.extract::<bool>()? {
            let value = given.call_method0("ravel")?.get_item(&bad)?;
            return Err(arg(
                name,
                format!("{} is not a whole number ({dtype} expected)", value.str()?),
            ));
        }
        let largest: f64 = np
            .call_method1("max", (np.call_method1("abs", (given,))?,))?
            .extract()?;
        if largest >= 9.2e18 {
            return Err(arg(name, format!("{largest:e} is beyond {dtype}'s range")));
        }
    } else if dtype == "float32" {
        let finite = given.call_method1("__getitem__", (np.call_method1("isfinite", (given,))?,))?;
        if finite.getattr("size")?.extract::<usize>()? > 0 {
            let largest: f64 = np
                .call_method1("max", (np.call_method1("abs", (finite,))?,))?
                .extract()?;
            if largest > f64::from(f32::MAX) {
                return Err(arg(name, format!("{largest:e} is beyond float32's range")));
            }
        }
    }
    Ok(())
}

/// The values of a contiguous read-only array (always contiguous after [`array`]).
pub(crate) fn slice<'a, T: Element>(name: &str, a: &'a PyReadonlyArrayDyn<'_, T>) -> PyResult<&'a [T]> {
    a.as_slice().map_err(|_| arg(name, "not contiguous"))
}

/// Whether every value is finite: a branch-free test over blocks, which the compiler vectorises
/// (the per-frame path checks every reading of every frame).
pub(crate) fn all_finite(values: &[f32]) -> bool {
    const EXPONENT: u32 = 0x7f80_0000;
    values.chunks(256).all(|block| {
        block
            .iter()
            .fold(0u32, |any, v| any | u32::from(v.to_bits() & EXPONENT == EXPONENT))
            == 0
    })
}

/// Fails on the first value of `values` that is not finite, naming its index.
pub(crate) fn finite(name: &str, values: &[f32], shape: &[usize]) -> PyResult<()> {
    finite_from(name, values, shape, 0)
}

/// The same for `values` that start at flat index `offset` of an array of `shape`.
pub(crate) fn finite_from(name: &str, values: &[f32], shape: &[usize], offset: usize) -> PyResult<()> {
    if all_finite(values) {
        return Ok(());
    }
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(arg(
            name,
            format!("{} at index {:?}", values[i], unravel(offset + i, shape)),
        ));
    }
    Ok(())
}

/// The same for doubles.
pub(crate) fn finite64(name: &str, values: &[f64], shape: &[usize]) -> PyResult<()> {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(arg(
            name,
            format!("{} at index {:?}", values[i], unravel(i, shape)),
        ));
    }
    Ok(())
}

/// The multi-index of flat index `i` in a C-ordered array of `shape`.
fn unravel(mut i: usize, shape: &[usize]) -> Vec<usize> {
    let mut index = vec![0; shape.len()];
    for (k, &n) in shape.iter().enumerate().rev() {
        if n > 0 {
            index[k] = i % n;
            i /= n;
        }
    }
    index
}

/// A new array of `shape` over `data` (moved, not copied).
pub(crate) fn out<'py, T: Element>(
    py: Python<'py>,
    data: Vec<T>,
    shape: &[usize],
) -> PyResult<Bound<'py, PyArrayDyn<T>>> {
    let array = ArrayD::from_shape_vec(IxDyn(shape), data)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("array of shape {shape:?}: {e}")))?;
    Ok(array.into_pyarray(py))
}

/// Points as an (N, 3) array of doubles.
pub(crate) fn points<'py>(
    py: Python<'py>,
    p: impl ExactSizeIterator<Item = [f64; 3]>,
) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let n = p.len();
    out(py, p.flatten().collect(), &[n, 3])
}

/// Triangles as an (M, 3) array of indices.
pub(crate) fn faces<'py>(py: Python<'py>, f: &[[usize; 3]]) -> PyResult<Bound<'py, PyArrayDyn<i64>>> {
    out(py, f.iter().flatten().map(|&i| i as i64).collect(), &[f.len(), 3])
}

/// A number for a message: as written when it is of a usual size, in exponent form otherwise,
/// so that a huge argument (`10**300`) is not quoted as a 301-digit number.
pub(crate) fn num(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-6..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Whether `e` passes through as itself rather than as a bad argument: an exception that is not
/// an `Exception` (`KeyboardInterrupt` from Ctrl-C, `SystemExit`) says nothing of the argument.
pub(crate) fn passes(py: Python<'_>, e: &PyErr) -> bool {
    !e.is_instance_of::<pyo3::exceptions::PyException>(py)
}

/// A shape as Python writes it: `(2, 3)`, `(5,)`.
pub(crate) fn shape(s: &[usize]) -> String {
    match s {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            s.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
        ),
    }
}

/// Taxel ids from an integer array's values (`unique`: each once), named when one is not an id.
pub(crate) fn taxel_ids(name: &str, values: &[i64], unique: bool) -> PyResult<Vec<skin_core::TaxelId>> {
    let mut seen = std::collections::HashSet::new();
    values
        .iter()
        .enumerate()
        .map(|(j, &id)| {
            let id = u32::try_from(id)
                .map_err(|_| arg(name, format!("{id} at index {j}: ids are 0 to {}", u32::MAX)))?;
            if unique && !seen.insert(id) {
                return Err(arg(name, format!("{id} appears twice (again at index {j})")));
            }
            Ok(skin_core::TaxelId(id))
        })
        .collect()
}

/// A whole number, 0 or more (a Python or numpy integer), named when it is not one.
pub(crate) fn count(name: &str, v: &Bound<'_, PyAny>) -> PyResult<usize> {
    let n: i64 = v
        .extract()
        .map_err(|_| arg(name, format!("{}: expected a whole number", short(v))))?;
    usize::try_from(n).map_err(|_| arg(name, format!("{n}: expected 0 or more")))
}

/// (rows, cols): any sequence of two whole numbers (a tuple, a list, an array).
pub(crate) fn pair(name: &str, v: &Bound<'_, PyAny>) -> PyResult<(usize, usize)> {
    let items: Vec<Bound<'_, PyAny>> = v
        .try_iter()
        .and_then(|i| i.collect::<PyResult<Vec<_>>>())
        .map_err(|_| arg(name, format!("{}: expected (rows, cols)", short(v))))?;
    match items.as_slice() {
        [r, c] => Ok((count(name, r)?, count(name, c)?)),
        _ => Err(arg(
            name,
            format!("{}: expected (rows, cols), two numbers", short(v)),
        )),
    }
}

/// A value as Python shows it, cut short.
fn short(v: &Bound<'_, PyAny>) -> String {
    let text = v.repr().map(|r| r.to_string()).unwrap_or_else(|_| "?".into());
    if text.chars().count() > 40 {
        format!("{}...", text.chars().take(40).collect::<String>())
    } else {
        text
    }
}
