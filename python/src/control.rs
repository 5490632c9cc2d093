//! The prioritised task stack from numpy (thesis Ch. 8): `TaskStack`.

use crate::arrays::{self, array, finite64, slice};
use crate::errors::{self, Kind, arg};
use nalgebra::{DMatrix, DVector};
use numpy::{PyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use skin_control::{Regularisation, Task, TaskStack as RustStack};

/// Solves a stack of tasks for joint velocities, highest priority first: each task asks that
/// J q_dot equal its reference, with an activation in 0..1 that fades it in or out.
/// `regularisation`: "activation_aware" (Simetti and Casalino; `lam`, `threshold`, `eta`),
/// "damped" (damped least squares, `lam`) or "exact" (singular values under `tolerance` dropped;
/// not for control).
#[pyclass(module = "skin._skin")]
pub(crate) struct TaskStack {
    inner: RustStack,
    joints: usize,
}

#[pymethods]
impl TaskStack {
    #[new]
    #[pyo3(signature = (joints, *, regularisation = "activation_aware", lam = 0.05, threshold = 0.01, eta = 1.0, tolerance = 1e-9))]
    fn new(
        joints: &Bound<'_, PyAny>,
        regularisation: &str,
        lam: f64,
        threshold: f64,
        eta: f64,
        tolerance: f64,
    ) -> PyResult<TaskStack> {
        let joints = arrays::count("joints", joints)?;
        if joints == 0 || joints > 1000 {
            return Err(arg("joints", format!("{joints}: expected 1 to 1000")));
        }
        for (name, v) in [
            ("lam", lam),
            ("threshold", threshold),
            ("eta", eta),
            ("tolerance", tolerance),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(arg(
                    name,
                    format!("{}: expected a number, 0 or more", arrays::num(v)),
                ));
            }
        }
        let r = match regularisation {
            "activation_aware" => Regularisation::ActivationAware {
                lambda: lam,
                threshold,
                eta,
            },
            "damped" => Regularisation::Damped { lambda: lam },
            "exact" => Regularisation::Exact { tolerance },
            other => {
                return Err(arg(
                    "regularisation",
                    format!("{other:?}: expected \"activation_aware\", \"damped\" or \"exact\""),
                ));
            }
        };
        Ok(TaskStack {
            inner: RustStack::new(joints, r),
            joints,
        })
    }

    /// `tasks`: a list of (jacobian (m, joints), reference (m,), activation) in priority order.
    /// Returns the joint velocities, (joints,).
    fn solve<'py>(
        &mut self,
        py: Python<'py>,
        tasks: Vec<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let mut stack = Vec::with_capacity(tasks.len());
        for (k, t) in tasks.iter().enumerate() {
            let (j, r, a): (Bound<'_, PyAny>, Bound<'_, PyAny>, f64) = t.extract().map_err(|_| {
                arg(
                    &format!("tasks[{k}]"),
                    "expected (jacobian, reference, activation)",
                )
            })?;
            let jn = format!("tasks[{k}] jacobian");
            let ja = array::<f64>(&jn, &j, "float64", 2)?;
            let (m, n) = (ja.shape()[0], ja.shape()[1]);
            if n != self.joints {
                return Err(arg(
                    &jn,
                    format!(
                        "shape {}: {n} columns, the stack has {} joints",
                        crate::arrays::shape(ja.shape()),
                        self.joints
                    ),
                ));
            }
            let jv = slice(&jn, &ja)?;
            finite64(&jn, jv, ja.shape())?;
            let rn = format!("tasks[{k}] reference");
            let ra = array::<f64>(&rn, &r, "float64", 1)?;
            if ra.shape()[0] != m {
                return Err(arg(
                    &rn,
                    format!("{} values, the jacobian has {m} rows", ra.shape()[0]),
                ));
            }
            let rv = slice(&rn, &ra)?;
            finite64(&rn, rv, ra.shape())?;
            if !(0.0..=1.0).contains(&a) {
                return Err(arg(
                    &format!("tasks[{k}] activation"),
                    format!("{}: expected 0 to 1", arrays::num(a)),
                ));
            }
            stack.push(Task {
                jacobian: DMatrix::from_row_slice(m, n, jv),
                reference: DVector::from_column_slice(rv),
                activation: a,
            });
        }
        let q = self
            .inner
            .solve(&stack)
            .map_err(|e| errors::raise(Kind::Control, &e))?;
        arrays::out(py, q.as_slice().to_vec(), &[self.joints])
    }

    fn __repr__(&self) -> String {
        format!("TaskStack({} joints)", self.joints)
    }
}
