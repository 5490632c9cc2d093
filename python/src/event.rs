//! What a session gives Python: `Event`s (`kind` and the fields `events.jsonl` documents, as
//! attributes) and the `Contact`s of the last frame; both pickle by value.

use crate::errors::{self, Kind, arg};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use skin_learn::session::Event as RustEvent;

/// Something that happened in a session: `kind` ("appeared", "classified", "released",
/// "incomplete", "gate", ...) and the fields `events.jsonl` documents for it, as attributes
/// (`event.time`, `event.link`, `event.probability`, ...), with the same units and rounding (times
/// in s to 1 ms, centroids in m to 0.1 mm, areas in cm², pressures in counts above the baseline).
/// A `classified` event also has `image`, the (rows, cols) uint8 image it was decided on. A field
/// that is a Python keyword reads as `event["class"]`. Fields `events.jsonl` leaves out read as
/// what they stand for: `parts` of a decision that is not a hand is `[]`, `class` and
/// `probability` of a touch released undecided are None; `to_dict()` is the line itself.
#[pyclass(module = "skin._skin", frozen)]
pub(crate) struct Event {
    kind: String,
    /// The fields as `events.jsonl` writes them; each access makes new Python objects, so an
    /// event cannot be changed through what it returns.
    fields: serde_json::Map<String, serde_json::Value>,
    image: Option<Py<PyAny>>,
}

#[pymethods]
impl Event {
    /// The event's name, as `events.jsonl`'s `"event"` field.
    #[getter]
    fn kind(&self) -> &str {
        &self.kind
    }

    /// The tactile image a `classified` event was decided on, (rows, cols) uint8; None otherwise.
    #[getter]
    fn image(&self, py: Python<'_>) -> Option<Py<PyAny>> {
        self.image.as_ref().map(|i| i.clone_ref(py))
    }

    fn __getattr__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        self.field(py, name)?
            .ok_or_else(|| pyo3::exceptions::PyAttributeError::new_err(self.no_field(name)))
    }

    fn __dir__(&self) -> Vec<String> {
        let mut names: Vec<String> = self.fields.keys().cloned().collect();
        names.extend(["kind", "image", "to_dict"].map(String::from));
        names.sort();
        names
    }

    /// A field by name: `event["class"]` (a Python keyword as an attribute).
    fn __getitem__(&self, py: Python<'_>, name: &str) -> PyResult<Py<PyAny>> {
        self.field(py, name)?
            .ok_or_else(|| pyo3::exceptions::PyKeyError::new_err(self.no_field(name)))
    }

    /// The event as the line `skin run` writes to `events.jsonl`: a dict with "event" and the
    /// fields.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("event", &self.kind)?;
        for (k, v) in &self.fields {
            d.set_item(k, json(py, v)?)?;
        }
        Ok(d)
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Event>()
            .is_ok_and(|o| self.kind == o.get().kind && self.fields == o.get().fields)
    }

    fn __repr__(&self) -> String {
        let mut parts = vec![self.kind.clone()];
        parts.extend(self.fields.iter().map(|(k, v)| format!("{k}={v}")));
        format!("Event({})", parts.join(", "))
    }

    /// Pickles as its kind, its fields as JSON text (numbers exactly) and its image.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, EventState)> {
        let restore = py.import("skin._skin")?.getattr("_event")?;
        let fields = serde_json::to_string(&self.fields).map_err(|e| errors::error(Kind::Session, e))?;
        Ok((restore, (self.kind.clone(), fields, self.image(py))))
    }
}

/// What an [`Event`] pickles as: kind, fields as JSON text, image.
type EventState = (String, String, Option<Py<PyAny>>);

/// An unpickled [`Event`].
#[pyfunction]
pub(crate) fn _event(kind: String, fields: &str, image: Option<Bound<'_, PyAny>>) -> PyResult<Event> {
    let fields = match serde_json::from_str(fields) {
        Ok(serde_json::Value::Object(fields)) => fields,
        _ => return Err(arg("fields", "not the JSON object of a pickled Event")),
    };
    if let Some(image) = &image {
        image
            .cast::<numpy::PyArray2<u8>>()
            .map_err(|_| arg("image", "not the (rows, cols) uint8 image of a pickled Event"))?;
    }
    Ok(Event {
        kind,
        fields,
        image: image.map(Bound::unbind),
    })
}

impl Event {
    /// An event of `kind` with these fields (an events.jsonl line without its `"event"`), no
    /// image.
    pub(crate) fn from_fields(kind: String, fields: serde_json::Map<String, serde_json::Value>) -> Event {
        Event {
            kind,
            fields,
            image: None,
        }
    }

    /// A field, or the value a field `events.jsonl` leaves out stands for: no `parts` on a
    /// decision that is not a hand (an empty list), no `class` or `probability` on a touch
    /// released undecided (None).
    fn field(&self, py: Python<'_>, name: &str) -> PyResult<Option<Py<PyAny>>> {
        if let Some(v) = self.fields.get(name) {
            return json(py, v).map(Some);
        }
        Ok(match (self.kind.as_str(), name) {
            ("classified", "parts") => Some(PyList::empty(py).into_any().unbind()),
            ("released", "class" | "probability") => Some(py.None()),
            _ => None,
        })
    }

    fn no_field(&self, name: &str) -> String {
        let names: Vec<&str> = self.fields.keys().map(String::as_str).collect();
        format!(
            "a \"{}\" event has no field {name:?} (it has {})",
            self.kind,
            names.join(", ")
        )
    }

    /// The Python event of `event`: its JSON fields, and its image if it has one.
    pub(crate) fn of(py: Python<'_>, event: &RustEvent) -> PyResult<Event> {
        let value = serde_json::to_value(event).map_err(|e| errors::error(Kind::Session, e))?;
        let serde_json::Value::Object(mut fields) = value else {
            return Err(errors::error(Kind::Session, "an event that is not a JSON object"));
        };
        let kind = match fields.remove("event") {
            Some(serde_json::Value::String(s)) => s,
            _ => String::new(),
        };
        let image = match event {
            RustEvent::Classified { image, .. } if !image.is_empty() => Some(
                crate::arrays::out(
                    py,
                    image.pixels().to_vec(),
                    &[image.size().rows, image.size().cols],
                )?
                .into_any()
                .unbind(),
            ),
            _ => None,
        };
        Ok(Event { kind, fields, image })
    }
}

/// A JSON value as the Python value `json.loads` gives.
pub(crate) fn json(py: Python<'_>, v: &serde_json::Value) -> PyResult<Py<PyAny>> {
    use pyo3::IntoPyObjectExt;
    Ok(match v {
        serde_json::Value::Null => py.None(),
        serde_json::Value::Bool(b) => b.into_py_any(py)?,
        serde_json::Value::Number(n) => match (n.as_i64(), n.as_u64()) {
            (Some(i), _) => i.into_py_any(py)?,
            (None, Some(u)) => u.into_py_any(py)?,
            _ => n.as_f64().unwrap_or(f64::NAN).into_py_any(py)?,
        },
        serde_json::Value::String(s) => s.into_py_any(py)?,
        serde_json::Value::Array(a) => {
            PyList::new(py, a.iter().map(|x| json(py, x)).collect::<PyResult<Vec<_>>>()?)?
                .into_any()
                .unbind()
        }
        serde_json::Value::Object(o) => {
            let d = PyDict::new(py);
            for (k, x) in o {
                d.set_item(k, json(py, x)?)?;
            }
            d.into_any().unbind()
        }
    })
}

/// One contact of the last frame on a link. A value: compared, copied and pickled by its fields.
#[pyclass(module = "skin._skin", frozen, get_all, eq)]
#[derive(PartialEq)]
pub(crate) struct Contact {
    /// Its taxels as indices into the link's taxels (layout order, as `Link.ids` and a frame's
    /// readings are), ascending: not taxel ids ([`Contact::taxel_ids`] has those).
    pub(crate) taxels: Vec<usize>,
    /// Its taxels' ids, in the order of `taxels`.
    pub(crate) taxel_ids: Vec<u32>,
    /// Pressure-weighted centroid, metres in the link's frame.
    pub(crate) centroid: (f64, f64, f64),
    /// Pressure-weighted outward normal (unit), when the contact search carries normals (the
    /// session's searches on tactile maps do not: None).
    pub(crate) normal: Option<(f64, f64, f64)>,
    /// Mean pressure over its taxels, counts above the baseline.
    pub(crate) mean_pressure: f32,
    /// Largest pressure, counts above the baseline.
    pub(crate) peak_pressure: f32,
    /// Its force, newtons; None on a link without a force calibration.
    pub(crate) force_n: Option<f64>,
}

#[pymethods]
impl Contact {
    fn __repr__(&self) -> String {
        let (x, y, z) = self.centroid;
        let force = self.force_n.map_or(String::new(), |f| format!(", {f:.3} N"));
        format!(
            "Contact({} taxels at ({:.4}, {:.4}, {:.4}) m, mean {:.1}, peak {:.1} counts{force})",
            self.taxels.len(),
            x,
            y,
            z,
            self.mean_pressure,
            self.peak_pressure
        )
    }

    /// Pickles as its fields.
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, pyo3::types::PyTuple>)> {
        use pyo3::IntoPyObjectExt;
        let restore = py.import("skin._skin")?.getattr("_contact")?;
        let args = pyo3::types::PyTuple::new(
            py,
            [
                self.taxels.clone().into_py_any(py)?,
                self.taxel_ids.clone().into_py_any(py)?,
                self.centroid.into_py_any(py)?,
                self.normal.into_py_any(py)?,
                self.mean_pressure.into_py_any(py)?,
                self.peak_pressure.into_py_any(py)?,
                self.force_n.into_py_any(py)?,
            ],
        )?;
        Ok((restore, args))
    }
}

/// An unpickled [`Contact`].
#[pyfunction]
#[pyo3(signature = (taxels, taxel_ids, centroid, normal, mean_pressure, peak_pressure, force_n = None))]
pub(crate) fn _contact(
    taxels: Vec<usize>,
    taxel_ids: Vec<u32>,
    centroid: (f64, f64, f64),
    normal: Option<(f64, f64, f64)>,
    mean_pressure: f32,
    peak_pressure: f32,
    force_n: Option<f64>,
) -> PyResult<Contact> {
    if taxels.len() != taxel_ids.len() {
        return Err(arg("taxel_ids", "not one id per taxel: not a pickled Contact"));
    }
    Ok(Contact {
        taxels,
        taxel_ids,
        centroid,
        normal,
        mean_pressure,
        peak_pressure,
        force_n,
    })
}
