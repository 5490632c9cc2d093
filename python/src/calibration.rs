//! Spatial calibration from probe arrays (thesis Ch. 7): `read_probes`, `calibrate`.

use crate::arrays::{self, array, finite64, slice};
use crate::errors::{self, arg};
use nalgebra::{Point3, Vector3};
use numpy::{PyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use skin_core::TaxelId;
use skin_learn::calibration::{
    CalibrationOptions, CalibrationReport, ProbeContact, ProbeDataset, Status, TaxelEstimate,
};
use std::path::PathBuf;

/// Reads a probe dataset (the CSV of `skin probe-sim`, `contact,x_m,y_m,z_m,taxel,response`) as
/// arrays: `centroids` (K, 3) metres, `ids` (N,) the taxels that appear, `responses` (K, N) (0
/// where a taxel has no row for a contact).
#[pyfunction]
pub(crate) fn read_probes<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let data = ProbeDataset::read(&path).map_err(errors::core)?;
    let ids: Vec<TaxelId> = data.by_taxel().keys().copied().collect();
    // `ids` are the keys of the same contacts' responses, sorted: every id is found.
    let column = |id: TaxelId| ids.binary_search(&id).unwrap_or(0);
    let (k, n) = (data.contacts.len(), ids.len());
    let mut responses = vec![0.0f64; k * n];
    for (c, contact) in data.contacts.iter().enumerate() {
        for &(t, r) in &contact.responses {
            responses[c * n + column(t)] = r;
        }
    }
    let d = PyDict::new(py);
    d.set_item(
        "centroids",
        arrays::points(py, data.contacts.iter().map(|c| c.centroid.coords.into()))?,
    )?;
    d.set_item(
        "ids",
        arrays::out(py, ids.iter().map(|t| t.0).collect::<Vec<u32>>(), &[n])?,
    )?;
    d.set_item("responses", arrays::out(py, responses, &[k, n])?)?;
    Ok(d)
}

/// Every taxel's fitted position, normal and uncertainty, or the reason it could not be fitted.
#[pyclass(module = "skin._skin", frozen)]
pub(crate) struct Calibration {
    report: CalibrationReport,
}

#[pymethods]
impl Calibration {
    /// Taxel ids, ascending, (N,) uint32.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u32>>> {
        let t = &self.report.taxels;
        arrays::out(py, t.iter().map(|t| t.id.0).collect(), &[t.len()])
    }

    /// Fitted positions, (N, 3) metres; NaN rows for taxels not fitted.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        arrays::points(
            py,
            self.report
                .taxels
                .iter()
                .map(|t| t.position.map_or([f64::NAN; 3], |p| p.coords.into())),
        )
    }

    /// Fitted outward normals, (N, 3); NaN rows for taxels not fitted.
    #[getter]
    fn normals<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        arrays::points(
            py,
            self.report
                .taxels
                .iter()
                .map(|t| t.normal.map_or([f64::NAN; 3], |n| n.into_inner().into())),
        )
    }

    /// Standard deviation of each fitted centre, (N,) millimetres (NaN where not fitted).
    #[getter]
    fn centre_sd_mm<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let t = &self.report.taxels;
        arrays::out(
            py,
            t.iter().map(|t| t.centre_sd_mm.unwrap_or(f64::NAN)).collect(),
            &[t.len()],
        )
    }

    /// Answered contacts per taxel, (N,).
    #[getter]
    fn samples<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<u64>>> {
        let t = &self.report.taxels;
        arrays::out(py, t.iter().map(|t| t.samples as u64).collect(), &[t.len()])
    }

    /// Which taxels were fitted, (N,) bool.
    #[getter]
    fn fitted<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArrayDyn<bool>>> {
        let t = &self.report.taxels;
        arrays::out(
            py,
            t.iter().map(|t| t.status == Status::Fitted).collect(),
            &[t.len()],
        )
    }

    /// Each taxel's status: "fitted", or why it is flagged (as `skin calibrate --report` writes).
    #[getter]
    fn status(&self) -> Vec<String> {
        self.report.taxels.iter().map(|t| t.status.to_string()).collect()
    }

    /// The report table `skin calibrate --report` writes.
    fn to_tsv(&self) -> String {
        self.report.to_tsv()
    }

    fn __len__(&self) -> usize {
        self.report.taxels.len()
    }

    fn __repr__(&self) -> String {
        let fitted = self
            .report
            .taxels
            .iter()
            .filter(|t| t.status == Status::Fitted)
            .count();
        format!(
            "Calibration({} taxels, {fitted} fitted)",
            self.report.taxels.len()
        )
    }
}

/// `outward`: a direction (x, y, z), finite and not zero.
fn direction(o: &Bound<'_, PyAny>) -> PyResult<Vector3<f64>> {
    let a = array::<f64>("outward", o, "float64", 1)?;
    let &[x, y, z] = slice("outward", &a)? else {
        return Err(arg(
            "outward",
            format!("{} values: expected a direction (x, y, z)", a.len()),
        ));
    };
    let v = Vector3::new(x, y, z);
    if !(v.iter().all(|c| c.is_finite()) && v.norm() > 0.0) {
        return Err(arg(
            "outward",
            format!("({x}, {y}, {z}): expected a direction (finite, not zero)"),
        ));
    }
    Ok(v)
}

/// Fits every taxel's position and normal from probe contacts (thesis Ch. 7.2.4): `centroids`
/// (K, 3) metres where the probe pressed, `ids` (N,) taxel ids, `responses` (K, N) what each
/// taxel answered to each contact (0: no answer). The options are `skin calibrate`'s
/// (`min_responses` 8, `max_iterations` 200 by default). Taxels are
/// solved in parallel with the GIL released.
#[pyfunction]
#[pyo3(signature = (centroids, ids, responses, *, min_responses = None, epsilon = 1e-6, max_iterations = None,
    max_extrapolation_mm = 8.0, max_open_angle_deg = 170.0, outward = None))]
#[allow(clippy::too_many_arguments)] // keyword arguments, as `skin calibrate` has options
pub(crate) fn calibrate(
    py: Python<'_>,
    centroids: &Bound<'_, PyAny>,
    ids: &Bound<'_, PyAny>,
    responses: &Bound<'_, PyAny>,
    min_responses: Option<&Bound<'_, PyAny>>,
    epsilon: f64,
    max_iterations: Option<&Bound<'_, PyAny>>,
    max_extrapolation_mm: f64,
    max_open_angle_deg: f64,
    outward: Option<&Bound<'_, PyAny>>,
) -> PyResult<Calibration> {
    let defaults = CalibrationOptions::default();
    let min_responses = min_responses.map_or(Ok(defaults.min_responses), |v| {
        crate::arrays::count("min_responses", v)
    })?;
    let max_iterations = max_iterations.map_or(Ok(defaults.max_iterations), |v| {
        crate::arrays::count("max_iterations", v)
    })?;
    if max_iterations == 0 {
        return Err(arg("max_iterations", "0: at least one"));
    }
    if max_open_angle_deg > 360.0 {
        return Err(arg(
            "max_open_angle_deg",
            format!("{}: at most 360 degrees", crate::arrays::num(max_open_angle_deg)),
        ));
    }
    let outward = outward.map(direction).transpose()?;
    if min_responses < 5 {
        return Err(arg(
            "min_responses",
            format!("{min_responses}: at least 5 (the Gaussian's parameters)"),
        ));
    }
    for (name, v) in [
        ("epsilon", epsilon),
        ("max_extrapolation_mm", max_extrapolation_mm),
        ("max_open_angle_deg", max_open_angle_deg),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(arg(
                name,
                format!("{}: expected a positive number", crate::arrays::num(v)),
            ));
        }
    }
    let (data, taxels) = probe_dataset(centroids, ids, responses)?;
    let options = CalibrationOptions {
        min_responses,
        epsilon,
        max_iterations,
        max_extrapolation_mm,
        max_open_angle_deg,
        outward,
    };
    let mut report = py.detach(|| skin_learn::calibration::calibrate(&data, &options));
    // A taxel of `ids` that never answered is reported, flagged, as one whose rows in a probe
    // file are all zero.
    for &id in &taxels {
        if let Err(at) = report.taxels.binary_search_by_key(&id, |t| t.id) {
            report.taxels.insert(
                at,
                TaxelEstimate {
                    id,
                    status: Status::NoResponse,
                    position: None,
                    normal: None,
                    samples: 0,
                    fit: None,
                    centre_sd_mm: None,
                    open_angle_deg: None,
                },
            );
        }
    }
    Ok(Calibration { report })
}

/// Probe arrays as a dataset (zero responses left out, as a probe file has no row for them),
/// and the taxel ids in their order.
fn probe_dataset(
    centroids: &Bound<'_, PyAny>,
    ids: &Bound<'_, PyAny>,
    responses: &Bound<'_, PyAny>,
) -> PyResult<(ProbeDataset, Vec<TaxelId>)> {
    let c = array::<f64>("centroids", centroids, "float64", 2)?;
    let k = c.shape()[0];
    if c.shape()[1] != 3 {
        return Err(arg(
            "centroids",
            format!("shape {}, expected (K, 3)", crate::arrays::shape(c.shape())),
        ));
    }
    let cv = slice("centroids", &c)?;
    finite64("centroids", cv, c.shape())?;
    let i = array::<i64>("ids", ids, "int64", 1)?;
    let iv = slice("ids", &i)?;
    let n = iv.len();
    let r = array::<f64>("responses", responses, "float64", 2)?;
    if r.shape() != [k, n] {
        return Err(arg(
            "responses",
            format!(
                "shape {}, expected ({k}, {n}): one row per centroid, one column per id",
                crate::arrays::shape(r.shape())
            ),
        ));
    }
    let rv = slice("responses", &r)?;
    finite64("responses", rv, r.shape())?;
    let taxels = crate::arrays::taxel_ids("ids", iv, true)?;
    let contacts = (0..k)
        .map(|row| ProbeContact {
            centroid: Point3::new(cv[3 * row], cv[3 * row + 1], cv[3 * row + 2]),
            force_n: None,
            responses: (0..n)
                .filter(|&j| rv[row * n + j] != 0.0)
                .map(|j| (taxels[j], rv[row * n + j]))
                .collect(),
        })
        .collect();
    Ok((ProbeDataset { contacts }, taxels))
}
