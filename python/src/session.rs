//! The session from Python: `Session.from_config` (a `run.toml`) or `Session.from_layout` (from
//! code); frames in (`push`, `push_can`, `run_log`, `run_recording`), `Event`s out, the contacts
//! of the last frame. The classifier and segmenter may be Python callables ([`crate::models`]).

use crate::arrays::{array, slice};
use crate::errors::{self, Kind, arg};
use crate::event::{Contact, Event};
use crate::geometry::Layout;
use crate::interrupt::Watch;
use crate::models::{Callable, reraised};
use crate::recordings::{BusMap, CanFrame, open_log, open_recording};
use crate::settings::{build_error, keyword_settings, settings_dict};
use numpy::{PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use skin_control::hri::GateAction;
use skin_core::LinkSkin;
use skin_core::image::ImageSize;
use skin_learn::model::{HandClassifier, PartSegmenter};
use skin_learn::session::{
    Event as RustEvent, Flow, FromConfig, InputError, OwnModels, ProcessedFrame, Session as RustSession,
    SessionConfig, SessionError, Sink,
};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// What the Python session holds.
struct Inner {
    session: RustSession,
    /// Frames pushed so far (the next frame's number).
    cycle: u64,
    /// The frame's readings, per link (reused).
    readings: Vec<Vec<f32>>,
    events: Vec<RustEvent>,
    /// The last frame's stamp, µs: frames come in time order.
    last_us: Option<u64>,
    /// What ended the session (`finish()`, a whole log or recording): it takes no more frames.
    ended: Option<&'static str>,
    /// The robot's joint states, from the first `joint_states()` call on.
    feed: Option<skin_learn::session::PostureFeed>,
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

/// The models a Python caller brings: callables, and the names of a callable classifier's
/// scores.
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

    /// The callables as the session's own models, taking images of `size`; their classes are
    /// skin-learn's to name ([`OwnModels::classes`]).
    fn own(self, size: ImageSize) -> OwnModels {
        let callable = |f: Bound<'_, PyAny>, what| Callable::new(f.unbind(), size, what);
        OwnModels {
            classifier: self
                .classifier
                .map(|f| Box::new(callable(f, "classifier")) as Box<dyn HandClassifier>),
            classes: self.classes,
            hand: self.hand,
            segmenter: self
                .segmenter
                .map(|f| Box::new(callable(f, "segmenter")) as Box<dyn PartSegmenter>),
        }
    }
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
        let session = if choice.is_builtin() {
            py.detach(|| RustSession::from_config(&config))
                .map_err(errors::session)?
        } else {
            let size = config.settings().map_err(errors::config)?.image_size;
            RustSession::from_config_with_own(&config, choice.own(size)).map_err(errors::session)?
        };
        say_setup(py, &session)?;
        Ok(Session::wrap(session))
    }

    /// A session from code: the links of `layout` (a `Layout`), flattened with the default
    /// options; `busmap` to push CAN frames or run logs; `classifier` / `segmenter` callables
    /// (none: touches are tracked, not decided); the settings of `run.toml`'s `[touch]`,
    /// `[baseline]` and `[gate]` (`gate={"hand": "comply", "non_hand": "stop"}`, by the
    /// classifier's class names). A keyword left out (or None) takes run.toml's default
    /// (`read_session_settings()` lists them); `Session.settings` shows what it runs with.
    #[staticmethod]
    #[pyo3(signature = (layout, *, busmap = None, classifier = None, segmenter = None, classes = None, hand = None,
        image_size = None, baseline_frames = None, polarity = None, threshold = None, min_taxels = None,
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
        polarity: Option<&str>,
        threshold: Option<&Bound<'_, PyAny>>,
        min_taxels: Option<&Bound<'_, PyAny>>,
        decide_frames: Option<&Bound<'_, PyAny>>,
        release_frames: Option<&Bound<'_, PyAny>>,
        gate: Option<std::collections::HashMap<String, String>>,
    ) -> PyResult<Session> {
        let choice = ModelChoice::new(classifier, segmenter, classes, hand)?;
        let numbers = [
            ("baseline_frames", baseline_frames),
            ("threshold", threshold),
            ("min_taxels", min_taxels),
            ("decide_frames", decide_frames),
            ("release_frames", release_frames),
        ];
        let settings = keyword_settings(image_size, numbers, polarity, gate)?;
        let models = choice
            .own(settings.image_size)
            .into_models()
            .map_err(errors::session)?;
        let links: Vec<LinkSkin> = layout.links.clone();
        let mut session = py
            .detach(|| RustSession::from_links(links, models, &settings))
            .map_err(build_error)?;
        if let Some(b) = busmap {
            session = session.with_can(&b.inner).map_err(errors::session)?;
        }
        say_setup(py, &session)?;
        Ok(Session::wrap(session))
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
        let (out, refs) = crate::recordings::bus_values(busmap, values, &missing)?;
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
                force_n: c.force_n,
            })
            .collect())
    }

    /// What the last frame's contacts press `link` with, in its frame: force (N) and torque
    /// about its origin (N m) as arrays of 3, and the centre of pressure (m; None without
    /// contact); None on a link without a force calibration.
    fn wrench<'py>(&self, py: Python<'py>, link: &Bound<'_, PyAny>) -> PyResult<Option<WrenchArrays<'py>>> {
        let k = self.link_index(link)?;
        let Some((w, _)) = self.lock()?.session.wrench(k) else {
            return Ok(None);
        };
        let vector = |v: [f64; 3]| crate::arrays::out(py, v.to_vec(), &[3]).map(Bound::into_any);
        let cop = w.cop.map(|p| vector([p.x, p.y, p.z])).transpose()?;
        Ok(Some((
            vector([w.force.x, w.force.y, w.force.z])?,
            vector([w.torque.x, w.torque.y, w.torque.z])?,
            cop,
        )))
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

    /// The settings it runs with, as run.toml's sections and keys: `image_size`, `baseline`,
    /// `touch` and `gate` (a session of a run.toml has its settings, one from keywords run.toml's
    /// defaults for the keywords left out; `read_session_settings` reads a file's).
    #[getter]
    fn settings(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let guard = self.lock()?;
        match guard.session.settings() {
            Some(s) => settings_dict(py, s),
            None => Ok(py.None()),
        }
    }

    /// Tares the skin: the baseline is learned again over the next `baseline.frames` frames
    /// (which read no pressure), as after the rest level moved. Refused with the reason
    /// (`SessionError`) while a touch is on the skin unless `force` (the touches open are then
    /// released first: their "released" events come before the "tare" event of the next
    /// frame), and even forced while the gate stops the arm for a touch or the baseline is
    /// being learned. Returns what will happen.
    #[pyo3(signature = (*, force = false))]
    fn tare(&self, force: bool) -> PyResult<String> {
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        if let Some(by) = inner.ended {
            return Err(errors::error(
                Kind::Session,
                format!("tare(): the session was ended by {by}"),
            ));
        }
        inner
            .session
            .tare(force)
            .map(|started| started.to_string())
            .map_err(|e| errors::error(Kind::Session, format!("tare(): {e}")))
    }

    /// The robot's joint angles at `time` (s, the frames' clock), as a `sensor_msgs/JointState`
    /// gives them: joint `names` (any order, other joints ignored) and their `positions` (rad or
    /// m). Needs `[stitch] urdf` in the configuration. Each frame then takes the posture of its
    /// time: the stitched links are stitched there, and every touch is also given in the chain's
    /// base frame (`centroid_base`). A joint missing, NaN, a message out of order or of another
    /// robot, or a posture older than `max_age_s` is a `joint_states` event at the next frame
    /// (the last good posture holds), as `skin run --joint-states` reports it.
    fn joint_states(&self, time: f64, names: Vec<String>, positions: Vec<f64>) -> PyResult<()> {
        let stamp_us = seconds("time", time)?;
        if positions.len() != names.len() {
            return Err(arg(
                "positions",
                format!("{} positions for {} joint names", positions.len(), names.len()),
            ));
        }
        let mut guard = self.lock()?;
        let inner = &mut *guard;
        if inner.feed.is_none() {
            let feed = inner
                .session
                .joint_state_feed(None, false)
                .map_err(errors::session)?;
            inner.feed = Some(feed);
        }
        if let Some(feed) = &inner.feed {
            feed.push(
                i128::from(stamp_us) * 1000,
                names.iter().map(String::as_str),
                &positions,
            );
        }
        Ok(())
    }

    /// What the skin is, as `skin_msgs/TactileLayout` publishes it: a dict with "simulated",
    /// "source", "touch_threshold_counts" and "links", each link a dict of its "name", "ids",
    /// "positions" and "normals" ((N, 3), m, link frame), "areas" (N,) m², "modules", "units"
    /// ("counts" or "N"), "calibration_id" and "dead" (taxel indices).
    fn describe<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = self.lock()?.session.describe();
        let out = PyDict::new(py);
        out.set_item("simulated", d.simulated)?;
        out.set_item("source", &d.source)?;
        out.set_item("touch_threshold_counts", d.touch_threshold_counts)?;
        let mut links = Vec::new();
        for l in &d.links {
            let link = PyDict::new(py);
            link.set_item("name", &l.name)?;
            link.set_item("ids", numpy::PyArray1::from_slice(py, &l.ids))?;
            let rows = |v: &[[f64; 3]]| {
                numpy::PyArray2::from_vec2(py, &v.iter().map(|p| p.to_vec()).collect::<Vec<_>>())
            };
            link.set_item(
                "positions",
                rows(&l.positions).map_err(|e| errors::error(Kind::Other, e))?,
            )?;
            link.set_item(
                "normals",
                rows(&l.normals).map_err(|e| errors::error(Kind::Other, e))?,
            )?;
            link.set_item("areas", numpy::PyArray1::from_slice(py, &l.areas_m2))?;
            link.set_item("modules", numpy::PyArray1::from_slice(py, &l.modules))?;
            link.set_item("units", l.units.name())?;
            link.set_item("calibration_id", &l.calibration_id)?;
            link.set_item("dead", l.dead.clone())?;
            links.push(link);
        }
        out.set_item("links", links)?;
        Ok(out)
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
    fn wrap(session: RustSession) -> Session {
        let names: Vec<String> = session.links().iter().map(|l| l.name.clone()).collect();
        let sizes: Vec<usize> = session.links().iter().map(|l| l.taxels.len()).collect();
        Session {
            inner: Mutex::new(Inner {
                session,
                cycle: 0,
                readings: sizes.iter().map(|&n| vec![0.0; n]).collect(),
                events: Vec::new(),
                last_us: None,
                ended: None,
                feed: None,
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
            Err(reraised(&e, &context).unwrap_or_else(|| errors::session(e)))
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
pub(crate) fn seconds(name: &str, t: f64) -> PyResult<u64> {
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

/// A wrench as Python gets it: force and torque arrays, and the centre of pressure.
type WrenchArrays<'py> = (Bound<'py, PyAny>, Bound<'py, PyAny>, Option<Bound<'py, PyAny>>);
