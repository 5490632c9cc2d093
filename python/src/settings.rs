//! A session's settings from Python: `Session.from_layout`'s keywords converted into
//! skin-learn's [`SessionSettings`] (whose defaults and bounds they are; nothing is checked
//! here that skin-learn checks), `read_session_settings` and `read_sim_config` reading a
//! run.toml's, and their errors named by the keyword that gave them.

use crate::errors::{self, Kind, arg};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use skin_control::hri::{ClassGate, GateAction};
use skin_core::image::ImageSize;
use skin_learn::session::{SessionConfig, SessionError, SessionSettings, SettingError, SimConfig};
use std::path::PathBuf;

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

/// `Session.from_layout`'s keywords that set a run.toml key by value, and the key.
const KEYWORDS: [(&str, &str); 6] = [
    ("image_size", "image_size"),
    ("baseline_frames", "[baseline] frames"),
    ("threshold", "[touch] threshold"),
    ("min_taxels", "[touch] min_taxels"),
    ("decide_frames", "[touch] decide_frames"),
    ("release_frames", "[touch] release_frames"),
];

/// The run.toml key a keyword sets.
fn key_of(keyword: &str) -> &'static str {
    KEYWORDS
        .iter()
        .find(|(k, _)| *k == keyword)
        .map_or("", |&(_, field)| field)
}

/// A setting's error as the keyword that gave it: `threshold: -1: expected counts from 0 to 1e9`.
fn setting_error(e: &SettingError) -> PyErr {
    match e {
        SettingError::Value {
            field,
            value,
            expected,
        } => match KEYWORDS.iter().find(|(_, f)| f == field) {
            Some((keyword, _)) => arg(keyword, format!("{value}: expected {expected}")),
            None => errors::error(Kind::Array, e),
        },
        SettingError::ForceLimit {
            class,
            value,
            expected,
        } => arg(
            "gate",
            format!(
                "force_n[{class:?}] = {}: expected {expected}",
                crate::arrays::num(*value)
            ),
        ),
        SettingError::GateClass { class, classes } => arg(
            "gate",
            format!("{class:?} is none of the classes ({})", classes.join(", ")),
        ),
    }
}

/// A session builder's error: a setting's as its keyword's, the others as they are.
pub(crate) fn build_error(e: SessionError) -> PyErr {
    match &e {
        SessionError::Setting(s) => setting_error(s),
        _ => errors::session(e),
    }
}

/// `Session.from_layout`'s keywords as the session's settings: run.toml's defaults, the values
/// given converted as a file's would be (skin-learn checks them).
pub(crate) fn keyword_settings(
    image_size: Option<&Bound<'_, PyAny>>,
    numbers: [(&str, Option<&Bound<'_, PyAny>>); 5],
    polarity: Option<&str>,
    gate: Option<std::collections::HashMap<String, String>>,
) -> PyResult<SessionSettings> {
    let mut settings = SessionSettings::default();
    if let Some(size) = image_size {
        let (rows, cols) = crate::arrays::pair("image_size", size)?;
        settings.image_size = ImageSize::new(rows, cols).map_err(|e| arg("image_size", e))?;
    }
    for (keyword, value) in numbers {
        let Some(value) = value else { continue };
        let field = key_of(keyword);
        let value = match toml_value(value, 0) {
            Some(v) => v,
            None => {
                return Err(setting_error(&SettingError::value(
                    field,
                    &value.repr()?.to_string(),
                )));
            }
        };
        settings.set(field, value).map_err(|e| setting_error(&e))?;
    }
    if let Some(p) = polarity {
        settings.baseline.polarity = p.parse().map_err(|e| arg("polarity", e))?;
    }
    if let Some(g) = gate {
        let actions = g
            .into_iter()
            .map(|(class, action)| Ok((class, action.parse::<GateAction>().map_err(|e| arg("gate", e))?)))
            .collect::<PyResult<Vec<_>>>()?;
        settings.gate = Some(ClassGate::new(actions));
    }
    // Refused before the maps are made: a bad argument costs no flattening.
    settings.check().map_err(|e| setting_error(&e))?;
    Ok(settings)
}

/// A session's settings as the dict `Session.settings` gives: run.toml's sections and keys.
pub(crate) fn settings_dict(py: Python<'_>, settings: &SessionSettings) -> PyResult<Py<PyAny>> {
    let text = serde_json::to_string(&settings.filled()).map_err(|e| errors::error(Kind::Session, e))?;
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

/// A run configuration's session settings (`image_size`, `[baseline]`, `[touch]`, `[gate]`),
/// checked, with the defaults filled in (all of them with no file), as the dict
/// `Session.settings` gives: what a session built from it runs with.
#[pyfunction]
#[pyo3(signature = (path = None))]
pub(crate) fn read_session_settings(py: Python<'_>, path: Option<PathBuf>) -> PyResult<Py<PyAny>> {
    let settings = match path {
        Some(path) => SessionConfig::read(&path)
            .map_err(errors::config)?
            .settings()
            .map_err(errors::config)?,
        None => SessionSettings::default(),
    };
    settings_dict(py, &settings)
}
