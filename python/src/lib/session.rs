//! The session from Python: `Session.from_config` (a `run.toml`) or `Session.from_layout` (from
//! code); frames in (`push`, `push_can`, `run_log`, `run_recording`), `Event`s out, the contacts
//! of the last frame. The classifier and segmenter may be Python callables ([`crate::models`]).

use crate::arrays::{array, slice};
use crate::errors::{self, Kind, arg};
use crate::geometry::Layout;
use crate::interrupt::Watch;
use crate::models::{Callable, Raised, reraise};
use crate::recordings::{BusMap, CanFrame, open_log, open_recording};
use numpy::{PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use skin_control::hri::{ClassGate, GateAction};
use skin_core::image::ImageSize;
use skin_core::{LinkSkin, Polarity};
use skin_learn::card::ModelCard;
use skin_learn::model::{Classes, Models};
use skin_learn::session::{
    Event as RustEvent, Flow, InputError, ProcessedFrame, Session as RustSession, SessionConfig,
    SessionError, SessionOptions, SimConfig, Sink,
};
use skin_learn::touch::{TouchOptions, TouchPipeline};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

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
    fn of(py: Python<'_>, event: &RustEvent) -> PyResult<Event> {
        let value = serde_json::to_value(event).map_err(|e| errors::error(Kind::Session, e))?;
        let serde_json::Value::Object(mut fields) = value else {
            return Err(errors::error(Kind::Session, "an event that is not a JSON object"));
        };
        let kind = match fields.remove("event") {
            Some(serde_json::Value::String(s)) => s,
            _ => String::new(),
        };
        let image = match event {
            RustEvent::Classified { image, .. } if !image.pixels.is_empty() => Some(
                crate::arrays::out(py, image.pixels.clone(), &[image.rows, image.cols])?
                    .into_any()
                    .unbind(),
            ),
            _ => None,
        };
        Ok(Event { kind, fields, image })
    }
}

/// A JSON value as the Python value `json.loads` gives.
fn json(py: Python<'_>, v: &serde_json::Value) -> PyResult<Py<PyAny>> {
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
    taxels: Vec<usize>,
    /// Its taxels' ids, in the order of `taxels`.
    taxel_ids: Vec<u32>,
    /// Pressure-weighted centroid, metres in the link's frame.
    centroid: (f64, f64, f64),
    /// Pressure-weighted outward normal (unit), when the contact search carries normals (the
    /// session's searches on tactile maps do not: None).
    normal: Option<(f64, f64, f64)>,
    /// Mean pressure over its taxels, counts above the baseline.
    mean_pressure: f32,
    /// Largest pressure, counts above the baseline.
    peak_pressure: f32,
}

#[pymethods]
impl Contact {
    fn __repr__(&self) -> String {
        let (x, y, z) = self.centroid;
        format!(
            "Contact({} taxels at ({:.4}, {:.4}, {:.4}) m, mean {:.1}, peak {:.1} counts)",
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
            ],
        )?;
        Ok((restore, args))
    }
}

/// An unpickled [`Contact`].
#[pyfunction]
pub(crate) fn _contact(
    taxels: Vec<usize>,
    taxel_ids: Vec<u32>,
    centroid: (f64, f64, f64),
    normal: Option<(f64, f64, f64)>,
    mean_pressure: f32,
    peak_pressure: f32,
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
    })
}

/// What the Python session holds.
struct Inner {
    session: RustSession,
    /// A callable model's exception, waiting to be re-raised.
    raised: Raised,
    /// Frames pushed so far (the next frame's number).
    cycle: u64,
    /// The frame's readings, per link (reused).
    readings: Vec<Vec<f32>>,
    events: Vec<RustEvent>,
    /// The last frame's stamp, µs: frames come in time order.
    last_us: Option<u64>,
    /// What ended the session (`finish()`, a whole log or recording): it takes no more frames.
    ended: Option<&'static str>,
}

/// A run configuration's `[sim]` table, checked, with the defaults filled in (all of them when
/// the file has none, or with no file), and `overrides` (a dict of `[sim]` keys) on top, checked
/// the same way: how a simulated skin answers (`skin.sim`). Units in the keys' names.
#[pyfunction]
#[pyo3(signature = (path = None, overrides = None))]
pub(crate) fn read_sim_config(
    py: Python<'_>,
    path: Option<PathBuf>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<Py<PyAny>> {
    let origin = path.clone().unwrap_or_else(|| PathBuf::from("[sim]"));
    let mut sim = match &path {
        Some(path) => SessionConfig::read(path)
            .map_err(errors::config)?
            .sim
            .unwrap_or_default(),
        None => SimConfig::default(),
    };
    let json = py.import("json")?;
    // Each key set as a file's `[sim]` table sets it: a wrong key or kind of value is named
    // with what the key takes (skin-learn's words).
    for (key, value) in overrides.into_iter().flat_map(|o| o.iter()) {
        let Ok(key) = key.extract::<String>() else {
            return Err(errors::config(SimConfig::value_error(
                &key.repr()?.to_string(),
                "",
                &origin,
            )));
        };
        match toml_value(&value, 0) {
            Some(value) => sim.set(&key, value, &origin),
            None => Err(SimConfig::value_error(&key, &value.repr()?.to_string(), &origin)),
        }
        .map_err(errors::config)?;
    }
    sim.check(&origin).map_err(errors::config)?;
    let text = serde_json::to_string(&sim).map_err(|e| errors::error(Kind::Config, e))?;
    Ok(json.call_method1("loads", (text,))?.unbind())
}

/// A Python value as a TOML file would hold it (a `[sim]` value: a bool, a whole number, a
/// number, text or a flat list of those); None for any other (None, a dict, a nested list, a
/// whole number past 64 bits).
fn toml_value(value: &Bound<'_, PyAny>, depth: usize) -> Option<toml::Value> {
    use pyo3::types::{PyBool, PyFloat, PyInt, PyString, PyTuple};
    if value.is_instance_of::<PyBool>() {
        return value.extract().ok().map(toml::Value::Boolean);
    }
    if value.is_instance_of::<PyInt>() {
        return value.extract().ok().map(toml::Value::Integer);
    }
    if value.is_instance_of::<PyFloat>() {
        return value.extract().ok().map(toml::Value::Float);
    }
    if value.is_instance_of::<PyString>() {
        return value.extract().ok().map(toml::Value::String);
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        // `[sim]`'s lists are flat: a list in a list is refused, not walked however deep.
        if depth > 0 {
            return None;
        }
        let items = value.try_iter().ok()?;
        return items
            .map(|item| item.ok().and_then(|item| toml_value(&item, depth + 1)))
            .collect::<Option<Vec<_>>>()
            .map(toml::Value::Array);
    }
    // numpy's scalars: whole numbers by `__index__`, others by `__float__`.
    value
        .extract::<i64>()
        .map(toml::Value::Integer)
        .or_else(|_| value.extract::<f64>().map(toml::Value::Float))
        .ok()
}

/// The whole per-frame pipeline of a skin (what `skin run` does), for a Python loop: readings
/// in, events out. Build it with `Session.from_config` or `Session.from_layout`. Methods on many
/// frames (`run_log`, `run_recording`) release the GIL. One thread uses a session at a time.
#[pyclass(module = "skin._skin")]
pub(crate) struct Session {
    inner: Mutex<Inner>,
    names: Vec<String>,
    sizes: Vec<usize>,
}

/// The models a session runs: callables where given, else the configuration's.
struct ModelChoice<'py> {
    classifier: Option<Bound<'py, PyAny>>,
    segmenter: Option<Bound<'py, PyAny>>,
    classes: Option<Vec<String>>,
    hand: Option<String>,
}

impl<'py> ModelChoice<'py> {
    /// The choice, the callables checked to be callable.
    fn new(
        classifier: Option<Bound<'py, PyAny>>,
        segmenter: Option<Bound<'py, PyAny>>,
        classes: Option<Vec<String>>,
        hand: Option<String>,
    ) -> PyResult<ModelChoice<'py>> {
        check_callable("classifier", classifier.as_ref())?;
        check_callable("segmenter", segmenter.as_ref())?;
        let choice = ModelChoice {
            classifier,
            segmenter,
            classes,
            hand,
        };
        choice.check_names()?;
        Ok(choice)
    }

    /// `classes` and `hand` name a callable classifier's scores: without one they are refused.
    fn check_names(&self) -> PyResult<()> {
        if self.classifier.is_none() {
            for (name, given) in [("classes", self.classes.is_some()), ("hand", self.hand.is_some())] {
                if given {
                    return Err(arg(
                        name,
                        "names the scores of a Python classifier (classifier=); the configuration's classifier takes its classes from its model card",
                    ));
                }
            }
        }
        Ok(())
    }

    fn is_builtin(&self) -> bool {
        self.classifier.is_none() && self.segmenter.is_none()
    }

    /// The classes a callable classifier's scores name: given, or the card of the
    /// configuration's classifier, or hand / non_hand.
    fn classes(&self, card_of: Option<&Path>) -> PyResult<Classes> {
        if let Some(names) = &self.classes {
            let hand = match &self.hand {
                Some(h) => Some(names.iter().position(|n| n == h).ok_or_else(|| {
                    arg(
                        "hand",
                        format!("{h:?} is none of the classes ({})", names.join(", ")),
                    )
                })?),
                None => names.iter().position(|n| n == "hand"),
            };
            if names.is_empty() {
                return Err(arg("classes", "no class"));
            }
            return Classes::named(names.clone(), hand).map_err(|e| arg("classes", e));
        }
        let mut classes = Classes::hand_or_not();
        if let Some(card) = card_of.and_then(ModelCard::for_model) {
            let path = ModelCard::path_for(card_of.unwrap_or(Path::new("")));
            if let Some(c) = Classes::from_card(&card)
                .map_err(|e| errors::error(Kind::Config, format!("{}: {e}", path.display())))?
            {
                classes = c;
            }
        }
        if let Some(h) = &self.hand {
            // The hand class named among the classes the scores already have.
            let names: Vec<String> = classes.iter().map(|c| c.name().to_owned()).collect();
            let at = names.iter().position(|n| n == h).ok_or_else(|| {
                arg(
                    "hand",
                    format!("{h:?} is none of the classes ({})", names.join(", ")),
                )
            })?;
            classes = Classes::new(names, Some(at));
        }
        Ok(classes)
    }

    /// The models: callables where given, the configuration's model files for the rest.
    fn models(&self, config: Option<&SessionConfig>, size: ImageSize, raised: &Raised) -> PyResult<Models> {
        let resolve = |field: &'static str, p: &Option<PathBuf>| -> PyResult<Option<PathBuf>> {
            match (config, p) {
                (Some(c), Some(p)) => c
                    .resolve(field, p)
                    .map(Some)
                    .map_err(|e| errors::raise(Kind::Config, &e)),
                _ => Ok(None),
            }
        };
        let config_classifier = resolve("classifier", &config.and_then(|c| c.classifier.clone()))?;
        let config_segmenter = resolve("segmenter", &config.and_then(|c| c.segmenter.clone()))?;
        let callable =
            |f: &Bound<'_, PyAny>, what| Callable::new(f.clone().unbind(), size, Arc::clone(raised), what);
        let mut models = match (&self.classifier, &config_classifier) {
            (Some(f), _) => Models::new(
                callable(f, "classifier"),
                self.classes(config_classifier.as_deref())?,
            ),
            (None, Some(p)) => builtin_classifier(p, size)?,
            (None, None) => Models::none(),
        };
        match (&self.segmenter, &config_segmenter) {
            (Some(f), _) => models = models.with_segmenter(callable(f, "segmenter")),
            (None, Some(p)) => {
                use skin_learn::classify::InputScale;
                let net = skin_learn::segment::Segmenter::load(p, InputScale::for_model(p))
                    .map_err(|e| errors::raise(Kind::Model, &e))?;
                models = models.with_segmenter(net);
            }
            (None, None) => {}
        }
        Ok(models)
    }
}

/// The configuration's classifier file, run in tract, with the classes its card names.
fn builtin_classifier(p: &Path, size: ImageSize) -> PyResult<Models> {
    use skin_learn::classify::{Classifier, InputScale};
    use skin_learn::model::HandClassifier;
    let net = Classifier::load(p, InputScale::for_model(p)).map_err(|e| errors::raise(Kind::Model, &e))?;
    let takes = HandClassifier::input_size(&net);
    if takes != size {
        return Err(errors::error(
            Kind::Config,
            format!("{}: takes {takes} images, the session makes {size}", p.display()),
        ));
    }
    let card = ModelCard::for_model(p);
    let classes = Classes::for_outputs(card.as_ref(), net.classes())
        .map_err(|e| errors::error(Kind::Config, format!("{}: {e}", ModelCard::path_for(p).display())))?
        .ok_or_else(|| {
            errors::error(
                Kind::Config,
                format!(
                    "{}: {} classes and no model card naming them",
                    p.display(),
                    net.classes()
                ),
            )
        })?;
    Ok(Models::new(net, classes))
}

#[pymethods]
impl Session {
    /// The session of a run configuration (`run.toml`, as `skin run` takes): its layout, bus map,
    /// models, baseline, touch and gate settings. `classifier` / `segmenter`: Python callables
    /// that replace the configuration's models; `classes` (and `hand`, the class that is a hand)
    /// name a callable classifier's scores (default: the classes of the configuration's
    /// classifier's model card, or ["hand", "non_hand"]).
    #[staticmethod]
    #[pyo3(signature = (path, *, classifier = None, segmenter = None, classes = None, hand = None))]
    fn from_config(
        py: Python<'_>,
        path: PathBuf,
        classifier: Option<Bound<'_, PyAny>>,
        segmenter: Option<Bound<'_, PyAny>>,
        classes: Option<Vec<String>>,
        hand: Option<String>,
    ) -> PyResult<Session> {
        let choice = ModelChoice::new(classifier, segmenter, classes, hand)?;
        let config = SessionConfig::read(&path).map_err(errors::config)?;
        let raised: Raised = Arc::default();
        let session = if choice.is_builtin() {
            py.detach(|| RustSession::from_config(&config))
                .map_err(errors::session)?
        } else {
            let (rows, cols) = config.image_size().map_err(|e| errors::raise(Kind::Config, &e))?;
            let size = ImageSize::new(rows, cols).map_err(|e| errors::error(Kind::Config, e))?;
            let models = choice.models(Some(&config), size, &raised)?;
            RustSession::from_config_with_models(&config, models).map_err(errors::session)?
        };
        say_setup(py, &session)?;
        Ok(Session::wrap(session, raised))
    }

    /// A session from code: the links of `layout` (a `Layout`), flattened with the default
    /// options; `busmap` to push CAN frames or run logs; `classifier` / `segmenter` callables
    /// (none: touches are tracked, not decided); the touch settings of `run.toml`'s `[touch]`,
    /// its `[baseline]` and `[gate]` (`gate={"hand": "comply", "non_hand": "stop"}`).
    #[staticmethod]
    #[pyo3(signature = (layout, *, busmap = None, classifier = None, segmenter = None, classes = None, hand = None,
        image_size = None, baseline_frames = None, polarity = "rising", threshold = 5.0, min_taxels = None,
        decide_frames = None, release_frames = None, gate = None))]
    #[allow(clippy::too_many_arguments)] // keyword arguments, the fields of run.toml
    fn from_layout(
        py: Python<'_>,
        layout: &Layout,
        busmap: Option<&BusMap>,
        classifier: Option<Bound<'_, PyAny>>,
        segmenter: Option<Bound<'_, PyAny>>,
        classes: Option<Vec<String>>,
        hand: Option<String>,
        image_size: Option<&Bound<'_, PyAny>>,
        baseline_frames: Option<&Bound<'_, PyAny>>,
        polarity: &str,
        threshold: f32,
        min_taxels: Option<&Bound<'_, PyAny>>,
        decide_frames: Option<&Bound<'_, PyAny>>,
        release_frames: Option<&Bound<'_, PyAny>>,
        gate: Option<std::collections::HashMap<String, String>>,
    ) -> PyResult<Session> {
        let choice = ModelChoice::new(classifier, segmenter, classes, hand)?;
        let (rows, cols) = image_size.map_or(Ok((68, 100)), |s| crate::arrays::pair("image_size", s))?;
        let size = ImageSize::new(rows, cols).map_err(|e| arg("image_size", e))?;
        // run.toml's bounds for the same fields.
        let whole =
            |name: &str, v: Option<&Bound<'_, PyAny>>, default: usize, range: (usize, usize), what: &str| {
                v.map_or(Ok(default), |v| {
                    crate::arrays::bounded(name, v, range.0, range.1, what)
                })
            };
        let baseline_frames = whole(
            "baseline_frames",
            baseline_frames,
            20,
            (2, 100_000),
            "untouched frames the baseline learns from; 2 at least to measure noise",
        )?;
        let min_taxels = whole("min_taxels", min_taxels, 2, (1, 1_000_000), "taxels")?;
        let decide_frames = whole("decide_frames", decide_frames, 3, (1, 1_000_000), "frames")?;
        let release_frames = whole("release_frames", release_frames, 2, (1, 1_000_000), "frames")?;
        if !(0.0..=1e9).contains(&threshold) {
            return Err(arg(
                "threshold",
                format!(
                    "{}: expected counts from 0 to 1e9",
                    crate::arrays::num(f64::from(threshold))
                ),
            ));
        }
        let polarity = match polarity {
            "rising" => Polarity::Rising,
            "falling" => Polarity::Falling,
            other => {
                return Err(arg(
                    "polarity",
                    format!("{other:?}: expected \"rising\" or \"falling\""),
                ));
            }
        };
        let gate = gate.map(|g| class_gate(&g)).transpose()?;
        let raised: Raised = Arc::default();
        let models = choice.models(None, size, &raised)?;
        let links: Vec<LinkSkin> = layout.links.clone();
        let maps = py
            .detach(|| {
                links
                    .iter()
                    .map(|l| skin_geom::TactileMap::flatten(l, &skin_geom::FlattenOptions::default()))
                    .collect::<Result<Vec<_>, _>>()
            })
            .map_err(errors::geom)?;
        let options = TouchOptions {
            threshold,
            min_taxels,
            decide_frames,
            release_frames,
            ..TouchOptions::default()
        };
        let pipeline =
            TouchPipeline::new(maps, models, options).map_err(|e| errors::raise(Kind::Config, &e))?;
        let session_options = SessionOptions {
            baseline_frames,
            polarity,
            gate,
            frame_images: false,
        };
        let mut session = RustSession::new(links, pipeline, session_options).map_err(errors::session)?;
        if let Some(b) = busmap {
            session = session.with_can(&b.inner).map_err(errors::session)?;
        }
        say_setup(py, &session)?;
        Ok(Session::wrap(session, raised))
    }

    /// One frame: `readings`, per link in layout order (a list of (N_link,) arrays, or a dict by
    /// link name, or one array for a one-link skin), raw counts; `time` in seconds (any origin;
    /// event times count from the first frame). Returns the frame's events.
    fn push(&self, py: Python<'_>, readings: &Bound<'_, PyAny>, time: f64) -> PyResult<Vec<Event>> {
        let time_us = seconds("time", time)?;
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        taking(inner, "time", time_us)?;
        self.gather(readings, &mut inner.readings)?;
        inner.last_us = Some(time_us);
        inner.cycle += 1;
        let result = inner
            .session
            .push(time_us, inner.cycle, &inner.readings, &mut inner.events);
        take(py, inner, result.map(|_| ()), "")
    }

    /// One assembled CAN frame (from `read_log`; needs a bus map). Returns the frame's events.
    fn push_can(&self, py: Python<'_>, frame: &CanFrame) -> PyResult<Vec<Event>> {
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        let Some(busmap) = inner.session.busmap() else {
            return Err(no_busmap());
        };
        let slots = busmap.slot_count();
        if frame.frame.values.len() != slots {
            return Err(arg(
                "frame",
                format!(
                    "a frame of {} slots, this session's bus map has {slots}: the frame comes from another bus map",
                    frame.frame.values.len()
                ),
            ));
        }
        taking(inner, "frame", frame.frame.time_us)?;
        inner.last_us = Some(frame.frame.time_us);
        let result = inner.session.push_can(&frame.frame, &mut inner.events);
        take(py, inner, result.map(|_| ()), "")
    }

    /// One frame as the buses would deliver it: `values`, (S,) raw counts in bus-map slot order
    /// (`BusMap.ids`; rounded, within 0 and 65,535), and the modules whose data did not arrive,
    /// as (interface, address) (their slots' values are not read). The same path as a CAN log's
    /// frame: an incomplete frame is reported, its modules held at their last reading. `time` in
    /// seconds, in order. Needs a bus map. Returns the frame's events.
    #[pyo3(signature = (values, time, missing = Vec::new()))]
    fn push_bus(
        &self,
        py: Python<'_>,
        values: &Bound<'_, PyAny>,
        time: f64,
        missing: Vec<(String, u32)>,
    ) -> PyResult<Vec<Event>> {
        let time_us = seconds("time", time)?;
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        let Some(busmap) = inner.session.busmap() else {
            return Err(no_busmap());
        };
        let values = array::<f32>("values", values, "float32", 1)?;
        let values = slice("values", &values)?;
        let slots = busmap.slot_count();
        if values.len() != slots {
            return Err(arg(
                "values",
                format!(
                    "{} values, this session's bus map has {slots} slots",
                    values.len()
                ),
            ));
        }
        let mut refs = Vec::with_capacity(missing.len());
        let mut skip = vec![false; slots];
        for (interface, address) in &missing {
            let found = busmap
                .module_slots()
                .find(|(b, m, _)| busmap.buses[*b].interface == *interface && m.address == *address)
                .map(|(b, _, range)| (b, range));
            let Some((bus, range)) = found else {
                return Err(arg(
                    "missing",
                    format!("no module {interface}:{address} in this session's bus map"),
                ));
            };
            skip[range].iter_mut().for_each(|s| *s = true);
            refs.push(skin_can::ModuleRef {
                bus: u16::try_from(bus).unwrap_or(u16::MAX),
                address: *address,
            });
        }
        let mut out = Vec::with_capacity(slots);
        for (i, (&v, &skipped)) in values.iter().zip(&skip).enumerate() {
            if skipped {
                out.push(None);
            } else if v.is_finite() {
                out.push(Some(v.round().clamp(0.0, 65_535.0) as u16));
            } else {
                return Err(arg(
                    "values",
                    format!(
                        "slot {i} (taxel {}) is {v}: give its module in `missing` instead",
                        busmap.taxel_ids()[i].0
                    ),
                ));
            }
        }
        taking(inner, "time", time_us)?;
        inner.last_us = Some(time_us);
        inner.cycle += 1;
        let frame = skin_can::AssembledFrame {
            cycle: inner.cycle,
            time_us,
            values: out,
            missing: refs,
            duplicated: Vec::new(),
        };
        let result = inner.session.push_can(&frame, &mut inner.events);
        take(py, inner, result.map(|_| ()), "")
    }

    /// Ends the session: touches still open are released. Returns those events. A session that
    /// ended before its baseline was learned had no touch to release: it returns none and warns
    /// (`SkinWarning`), where a whole log or recording that short (`run_log`) is an error.
    fn finish(&self, py: Python<'_>) -> PyResult<Vec<Event>> {
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        if inner.ended.is_some() {
            return Ok(Vec::new());
        }
        inner.ended = Some("finish()");
        let result = inner.session.finish(&mut inner.events);
        // The Rust session says the input was too short for its baseline; frames pushed one at a
        // time end where their caller stops, and a stop that early is no fault to raise.
        if let Err(e @ SessionError::Input(input)) = &result
            && matches!(**input, InputError::TooShort { .. })
        {
            inner.events.clear();
            errors::warn(py, &format!("finish(): {e}: no touch was tracked"))?;
            return Ok(Vec::new());
        }
        take(py, inner, result.map(|_| ()), "")
    }

    /// A whole candump log (gzip too) through the session, as `skin run --log` does; open touches
    /// are released at its end. Returns every event. The GIL is released while it runs; Ctrl-C
    /// stops it within a frame (a named pipe's wait too) and raises `KeyboardInterrupt`, the
    /// events so far dropped and the session ended.
    fn run_log(&self, py: Python<'_>, path: PathBuf) -> PyResult<Vec<Event>> {
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        if inner.session.busmap().is_none() {
            return Err(no_busmap());
        }
        fresh(inner, "run_log()")?;
        let watch = Arc::new(Watch::new());
        // A file that cannot be opened leaves the session as it was.
        let log = py
            .detach(|| open_log(&path, &watch))
            .map_err(|e| watch.raised().unwrap_or_else(|| errors::can(e)))?;
        inner.ended = Some("run_log()");
        let session = &mut inner.session;
        let mut sink = Collect {
            events: &mut inner.events,
            watch: &watch,
        };
        let result = py.detach(|| session.run_log(log, &path, &mut sink, &mut |_, _| {}).map(|_| ()));
        interrupted(inner, &watch, "run_log(), interrupted")?;
        take(py, inner, result, &path.display().to_string())
    }

    /// A whole Cyskin recording through the session, as `skin run --recording` does. Returns
    /// every event. The GIL is released while it runs; Ctrl-C stops it as it does `run_log`.
    fn run_recording(&self, py: Python<'_>, path: PathBuf) -> PyResult<Vec<Event>> {
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        fresh(inner, "run_recording()")?;
        let watch = Arc::new(Watch::new());
        let rec = py
            .detach(|| open_recording(&path, &watch))
            .map_err(|e| watch.raised().unwrap_or_else(|| errors::core(e)))?;
        inner.ended = Some("run_recording()");
        let session = &mut inner.session;
        let mut sink = Collect {
            events: &mut inner.events,
            watch: &watch,
        };
        let result = py.detach(|| session.run_recording(rec, &path, &mut sink).map(|_| ()));
        interrupted(inner, &watch, "run_recording(), interrupted")?;
        take(py, inner, result, &path.display().to_string())
    }

    /// The contacts of the last frame on `link` (a name or an index).
    fn contacts(&self, link: &Bound<'_, PyAny>) -> PyResult<Vec<Contact>> {
        let k = self.link_index(link)?;
        let guard = self.lock()?;
        let taxels = &guard.session.links()[k].taxels;
        Ok(guard
            .session
            .pipeline()
            .contacts(k)
            .iter()
            .map(|c| Contact {
                taxels: c.taxels.clone(),
                taxel_ids: c
                    .taxels
                    .iter()
                    .filter_map(|&i| taxels.get(i).map(|t| t.id.0))
                    .collect(),
                centroid: (c.centroid.x, c.centroid.y, c.centroid.z),
                normal: c.normal.map(|n| (n.x, n.y, n.z)),
                mean_pressure: c.mean_pressure,
                peak_pressure: c.peak_pressure,
            })
            .collect())
    }

    /// The links' names, in layout order.
    #[getter]
    fn links(&self) -> Vec<String> {
        self.names.clone()
    }

    /// Taxels per link, in layout order.
    #[getter]
    fn taxels(&self) -> Vec<usize> {
        self.sizes.clone()
    }

    /// The classifier's classes (empty without a classifier).
    #[getter]
    fn classes(&self) -> PyResult<Vec<String>> {
        let guard = self.lock()?;
        Ok(guard
            .session
            .classes()
            .iter()
            .map(|c| c.name().to_owned())
            .collect())
    }

    /// What the gate says now ("stop", "comply", "slow", "resume"), or None without a gate.
    #[getter]
    fn gate(&self) -> PyResult<Option<&'static str>> {
        Ok(self.lock()?.session.gate().map(GateAction::name))
    }

    /// Counts so far: frames, incomplete frames, counter resets, touches, contacts across joints.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.lock()?.session.stats();
        let d = PyDict::new(py);
        d.set_item("frames", s.frames)?;
        d.set_item("incomplete", s.incomplete)?;
        d.set_item("counter_resets", s.counter_resets)?;
        d.set_item("touches", s.touches)?;
        d.set_item("across_joints", s.across_joints)?;
        Ok(d)
    }

    /// The layout's taxels that no slot of the bus map carries, as (link name, taxel id), in
    /// layout order: they never read, and contacts and images bridge them as dead. Empty without
    /// a bus map. Building such a session warns (`SkinWarning`), as `skin run` does.
    #[getter]
    fn uncovered(&self) -> PyResult<Vec<(String, u32)>> {
        Ok(self
            .lock()?
            .session
            .uncovered()
            .into_iter()
            .map(|(link, id)| (link.to_owned(), id.0))
            .collect())
    }

    fn __repr__(&self) -> String {
        format!("Session(links {:?}, taxels {:?})", self.names, self.sizes)
    }

    /// A session is not a value: it holds its models and the state of a run (baselines, open
    /// touches), which a copy could not share.
    fn __reduce__(&self) -> PyResult<()> {
        Err(pyo3::exceptions::PyTypeError::new_err(
            "a Session cannot be pickled: it holds its models and the state of a run; pickle its events (Event pickles, and event.to_dict() is the events.jsonl line), or build a new Session from the same run.toml",
        ))
    }
}

/// The session's events collected, and a look for Ctrl-C after each frame: a whole log stops
/// within a frame of it.
struct Collect<'a> {
    events: &'a mut Vec<RustEvent>,
    watch: &'a Watch,
}

impl Sink for Collect<'_> {
    type Error = std::convert::Infallible;

    fn event(&mut self, event: &RustEvent) -> Result<Flow, Self::Error> {
        self.events.push(event.clone());
        Ok(Flow::Continue(()))
    }

    fn frame(&mut self, _: &ProcessedFrame<'_>) -> Result<Flow, Self::Error> {
        Ok(if self.watch.stop() {
            Flow::Break(())
        } else {
            Flow::Continue(())
        })
    }
}

/// The exception a signal handler raised during a whole run, if one did: the run's events are
/// dropped (a run cut short is not returned as if whole) and the session is ended as `by`.
fn interrupted(inner: &mut Inner, watch: &Watch, by: &'static str) -> PyResult<()> {
    match watch.raised() {
        Some(e) => {
            inner.events.clear();
            inner.ended = Some(by);
            Err(e)
        }
        None => Ok(()),
    }
}

/// Warns of what `skin run` says about a new session: layout taxels on no bus (the session's
/// own list of them), what reading its layout did.
fn say_setup(py: Python<'_>, session: &RustSession) -> PyResult<()> {
    let uncovered = session.uncovered();
    if let Some((link, id)) = uncovered.first() {
        errors::warn(
            py,
            &format!(
                "{} layout taxel(s) are on no bus of the bus map (first: taxel {id} of link \"{link}\"): dead, they never read (Session.uncovered lists them)",
                uncovered.len()
            ),
        )?;
    }
    for note in session.layout_notes() {
        errors::warn(py, &note.to_string())?;
    }
    Ok(())
}

impl Session {
    fn wrap(session: RustSession, raised: Raised) -> Session {
        let names: Vec<String> = session.links().iter().map(|l| l.name.clone()).collect();
        let sizes: Vec<usize> = session.links().iter().map(|l| l.taxels.len()).collect();
        Session {
            inner: Mutex::new(Inner {
                session,
                raised,
                cycle: 0,
                readings: sizes.iter().map(|&n| vec![0.0; n]).collect(),
                events: Vec::new(),
                last_us: None,
                ended: None,
            }),
            names,
            sizes,
        }
    }

    /// The session, unless another thread is using it (waiting would hold the GIL it needs).
    fn lock(&self) -> PyResult<std::sync::MutexGuard<'_, Inner>> {
        errors::claim(&self.inner, Kind::Session, "the session")
    }

    fn link_index(&self, link: &Bound<'_, PyAny>) -> PyResult<usize> {
        if let Ok(i) = link.extract::<usize>() {
            if i < self.names.len() {
                return Ok(i);
            }
            return Err(arg(
                "link",
                format!("{i}: the skin has {} links", self.names.len()),
            ));
        }
        let name: String = link
            .extract()
            .map_err(|_| arg("link", "expected a link's name or index"))?;
        self.names.iter().position(|n| *n == name).ok_or_else(|| {
            arg(
                "link",
                format!("{name:?}: the skin has {}", self.names.join(", ")),
            )
        })
    }

    /// Copies one frame's readings into `out`, checking each link's array.
    fn gather(&self, readings: &Bound<'_, PyAny>, out: &mut [Vec<f32>]) -> PyResult<()> {
        let n = self.names.len();
        if let Ok(d) = readings.cast::<PyDict>() {
            if d.len() != n {
                return Err(arg(
                    "readings",
                    format!(
                        "{} links given, the skin has {n} ({})",
                        d.len(),
                        self.names.join(", ")
                    ),
                ));
            }
            for (k, name) in self.names.iter().enumerate() {
                let item = d
                    .get_item(name)?
                    .ok_or_else(|| arg("readings", format!("no readings for link {name:?}")))?;
                self.link_readings(k, &item, &mut out[k])?;
            }
            return Ok(());
        }
        if n == 1 && readings.hasattr("ndim")? && readings.getattr("ndim")?.extract::<usize>()? == 1 {
            return self.link_readings(0, readings, &mut out[0]);
        }
        // A list, the per-frame case: read in place, nothing collected.
        if let Ok(list) = readings.cast::<PyList>()
            && list.len() == n
        {
            for (k, item) in list.iter().enumerate() {
                self.link_readings(k, &item, &mut out[k])?;
            }
            return Ok(());
        }
        let items: Vec<Bound<'_, PyAny>> = readings
            .try_iter()
            .map_err(|_| {
                arg(
                    "readings",
                    "expected a list of arrays, one per link, or a dict by link name",
                )
            })?
            .collect::<PyResult<_>>()?;
        if items.len() != n {
            return Err(arg(
                "readings",
                format!(
                    "{} arrays, the skin has {n} links ({})",
                    items.len(),
                    self.names.join(", ")
                ),
            ));
        }
        for (k, item) in items.iter().enumerate() {
            self.link_readings(k, item, &mut out[k])?;
        }
        Ok(())
    }

    fn link_readings(&self, k: usize, item: &Bound<'_, PyAny>, out: &mut [f32]) -> PyResult<()> {
        // The per-frame case, float32 readings where they lie, costs no more than a copy and a
        // check; anything else goes the long way, which converts and names what is wrong.
        if let Ok(a) = item.cast::<numpy::PyArray1<f32>>()
            && let Ok(ro) = a.try_readonly()
            && let Ok(v) = ro.as_slice()
            && v.len() == out.len()
            && crate::arrays::all_finite(v)
        {
            out.copy_from_slice(v);
            return Ok(());
        }
        let name = format!("readings[{:?}]", self.names[k]);
        let a = array::<f32>(&name, item, "float32", 1)?;
        if a.shape()[0] != out.len() {
            return Err(arg(
                &name,
                format!("{} readings, the link has {} taxels", a.shape()[0], out.len()),
            ));
        }
        let v = slice(&name, &a)?;
        crate::arrays::finite(&name, v, a.shape())?;
        out.copy_from_slice(v);
        Ok(())
    }
}

/// The events the session gave, as Python events; or its error, with a callable's exception
/// put back (`what` names the input).
fn take(
    py: Python<'_>,
    inner: &mut Inner,
    result: Result<(), skin_learn::session::SessionError>,
    what: &str,
) -> PyResult<Vec<Event>> {
    let events: Vec<RustEvent> = std::mem::take(&mut inner.events);
    match result {
        Ok(()) => events.iter().map(|e| Event::of(py, e)).collect(),
        Err(e) => {
            let context = if what.is_empty() {
                errors::message(&e)
            } else {
                format!("{what}: {}", errors::message(&e))
            };
            let err = errors::session(e);
            Err(reraise(&inner.raised, err, &context))
        }
    }
}

/// Whether the session takes a frame stamped `time_us` (`name` names it): not after it ended,
/// not before the last frame.
fn taking(inner: &Inner, name: &str, time_us: u64) -> PyResult<()> {
    if let Some(by) = inner.ended {
        return Err(errors::error(
            Kind::Session,
            format!("the session has ended ({by}): it takes no more frames; make a new Session"),
        ));
    }
    match inner.last_us {
        Some(last) if time_us < last => Err(arg(
            name,
            format!(
                "{:.6} s is before the previous frame's {:.6} s: frames come in time order",
                time_us as f64 * 1e-6,
                last as f64 * 1e-6
            ),
        )),
        _ => Ok(()),
    }
}

/// Whether the session can run a whole input (`what`): only a new one (which the run ends).
fn fresh(inner: &Inner, what: &'static str) -> PyResult<()> {
    if let Some(by) = inner.ended {
        return Err(errors::error(
            Kind::Session,
            format!("the session has ended ({by}): {what} takes a new Session"),
        ));
    }
    if inner.last_us.is_some() {
        return Err(errors::error(
            Kind::Session,
            format!("the session has taken frames already: {what} takes a new Session"),
        ));
    }
    Ok(())
}

fn no_busmap() -> PyErr {
    errors::error(
        Kind::Session,
        "this session has no bus map to read CAN frames with: build it with Session.from_layout(layout, busmap=...) or from a run.toml that names one",
    )
}

/// The latest stamp a frame may have, seconds: microseconds in 64 bits.
const MAX_SECONDS: f64 = 1.8e13;

/// Seconds as whole microseconds.
fn seconds(name: &str, t: f64) -> PyResult<u64> {
    if !(0.0..MAX_SECONDS).contains(&t) {
        return Err(arg(
            name,
            format!(
                "{}: expected seconds from 0 to {MAX_SECONDS:e} (stamps are whole microseconds in 64 bits)",
                crate::arrays::num(t)
            ),
        ));
    }
    Ok((t * 1e6).round() as u64)
}

fn check_callable(name: &str, f: Option<&Bound<'_, PyAny>>) -> PyResult<()> {
    match f {
        Some(f) if !f.is_callable() => Err(arg(name, "not callable: expected a function of the image")),
        _ => Ok(()),
    }
}

/// A gate from {"hand": action, "non_hand": action}.
fn class_gate(g: &std::collections::HashMap<String, String>) -> PyResult<ClassGate> {
    let action = |name: &str| -> PyResult<GateAction> {
        Ok(match name {
            "stop" => GateAction::Stop,
            "comply" => GateAction::Comply,
            "slow" => GateAction::Slow,
            "resume" => GateAction::Resume,
            other => {
                return Err(arg(
                    "gate",
                    format!("{other:?}: expected stop, comply, slow or resume"),
                ));
            }
        })
    };
    let mut gate = ClassGate::default();
    for (class, a) in g {
        match class.as_str() {
            "hand" => gate.hand = Some(action(a)?),
            "non_hand" => gate.non_hand = Some(action(a)?),
            other => {
                return Err(arg(
                    "gate",
                    format!("{other:?}: the classes are hand and non_hand"),
                ));
            }
        }
    }
    Ok(gate)
}
