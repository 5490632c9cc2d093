//! Sessions as datasets (`export`, `export_bytes`): skin-dataset's writer, as `skin export`
//! runs it; the GIL released while the inputs run.

use crate::errors::{self, Kind};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use skin_dataset::{DatasetError, DatasetOptions, DatasetSummary, Source, export_files, export_source};
use skin_learn::session::{FromConfig, Session, SessionConfig};
use std::path::PathBuf;

/// Every fault of an export is of a file: an input, or the dataset's folder (`InputError`).
fn raise(e: &DatasetError) -> PyErr {
    errors::raise(Kind::Input, e)
}

/// The options; `task` defaults to `skin export`'s ("skin session").
fn options(
    task: Option<String>,
    robot_type: Option<String>,
    fps: Option<u32>,
    append: bool,
) -> PyResult<DatasetOptions> {
    if fps == Some(0) {
        return Err(errors::arg("fps", "0: at least 1 frame a second"));
    }
    Ok(DatasetOptions {
        task: task.unwrap_or_else(|| DatasetOptions::default().task),
        robot_type,
        fps,
        append,
    })
}

/// The summary as a dict: `root`, `episodes`, `frames`, `fps`, and `added`, one dict per
/// episode this export added (`episode`, `source`, `sha256`, `frames`, `incomplete`, `events`,
/// `contacts`, `data_file`).
fn summary_dict<'py>(py: Python<'py>, s: &DatasetSummary) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("root", s.root.display().to_string())?;
    d.set_item("episodes", s.episodes)?;
    d.set_item("frames", s.frames)?;
    d.set_item("fps", s.fps)?;
    let added = PyList::empty(py);
    for e in &s.added {
        let r = PyDict::new(py);
        r.set_item("episode", e.episode)?;
        r.set_item("source", e.source.display().to_string())?;
        r.set_item("sha256", &e.sha256)?;
        r.set_item("frames", e.frames)?;
        r.set_item("incomplete", e.incomplete)?;
        r.set_item("events", e.events)?;
        r.set_item("contacts", e.contacts)?;
        r.set_item("data_file", &e.data_file)?;
        added.append(r)?;
    }
    d.set_item("added", added)?;
    Ok(d)
}

/// Candump logs or raw recordings as a dataset in the LeRobot v3 layout, as `skin export`
/// writes it: an episode per input, each through a session of `config` (run.toml). Returns
/// the summary (a dict; `failed` lists `(path, message)` of the inputs left out, each also
/// a `SkinWarning`). Raises
/// `InputError` when the folder is refused (a dataset already there without `append`) or when
/// no input could be exported (naming each).
#[pyfunction]
#[pyo3(signature = (inputs, config, out, *, task = None, robot_type = None, fps = None, append = false))]
#[allow(clippy::too_many_arguments)] // keyword arguments, as `skin export` has options
pub(crate) fn export<'py>(
    py: Python<'py>,
    inputs: Vec<PathBuf>,
    config: PathBuf,
    out: PathBuf,
    task: Option<String>,
    robot_type: Option<String>,
    fps: Option<u32>,
    append: bool,
) -> PyResult<Bound<'py, PyDict>> {
    if inputs.is_empty() {
        return Err(errors::arg("inputs", "empty: at least one log or recording"));
    }
    let options = options(task, robot_type, fps, append)?;
    let config = SessionConfig::read(&config).map_err(errors::config)?;
    let export = py
        .detach(|| export_files(&inputs, &mut || Session::from_config(&config), &out, options))
        .map_err(|e| raise(&e))?;
    let failed: Vec<(String, String)> = export
        .failed
        .iter()
        .map(|(p, e)| (p.display().to_string(), errors::message(e)))
        .collect();
    let Some(summary) = &export.summary else {
        let lines: Vec<String> = failed.iter().map(|(_, m)| m.clone()).collect();
        return Err(errors::error(
            Kind::Input,
            format!("no input could be exported:\n{}", lines.join("\n")),
        ));
    };
    for (_, message) in &failed {
        errors::warn(py, &format!("left out: {message}"))?;
    }
    let d = summary_dict(py, summary)?;
    d.set_item("failed", failed)?;
    Ok(d)
}

/// One input held in memory (`data`: a candump log or raw recording, gzip or not, as
/// `ray.data.read_binary_files` gives it; `name` names it) as a new dataset at `out` (one
/// episode). Returns the summary as `export` does; raises `InputError` naming `name` when it
/// cannot be exported, leaving nothing at `out`.
#[pyfunction]
#[pyo3(signature = (name, data, config, out, *, task = None, robot_type = None, fps = None))]
#[allow(clippy::too_many_arguments)] // keyword arguments, as `export`
pub(crate) fn export_bytes<'py>(
    py: Python<'py>,
    name: PathBuf,
    data: Vec<u8>,
    config: PathBuf,
    out: PathBuf,
    task: Option<String>,
    robot_type: Option<String>,
    fps: Option<u32>,
) -> PyResult<Bound<'py, PyDict>> {
    let options = options(task, robot_type, fps, false)?;
    let config = SessionConfig::read(&config).map_err(errors::config)?;
    let summary = py
        .detach(|| {
            let inputs = skin_core::output::Inputs::new([&config.path]);
            let mut dataset = skin_dataset::Dataset::create(&out, options, &inputs)?;
            let source = Source::from_bytes(&name, data)?;
            let mut session = Session::from_config(&config).map_err(|error| DatasetError::Session {
                input: name.clone(),
                error: Box::new(error),
            })?;
            export_source(&mut dataset, &mut session, source)?;
            dataset.finish()
        })
        .map_err(|e| raise(&e))?;
    let d = summary_dict(py, &summary)?;
    d.set_item("failed", PyList::empty(py))?;
    Ok(d)
}
