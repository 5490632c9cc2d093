//! `calibrate_force`: a link's force model from presses with a known load, by the library call
//! `skin calibrate-force` makes (`skin_learn::force_calibration::calibrate_link`).

use crate::errors::{self, Kind, arg};
use pyo3::prelude::*;
use skin_core::format::force_file::ForceCalibration;
use skin_core::format::load::LoadFile;
use skin_core::output::{Inputs, OutputError};
use skin_learn::force_calibration::{
    CalibrateForceError, ForceFitOptions, MAX_GAIN_SD, Presses, calibrate_link,
};
use skin_learn::session::SessionConfig;
use std::path::PathBuf;

/// Fits a link's force model (counts to newtons) from presses with a known load, as
/// `skin calibrate-force` does: `config` a run configuration (run.toml; its `[force]` is not
/// read), the presses a candump `log` or a raw `recording`, `load` the load file (CSV:
/// `time_s,force_n[,x_m,y_m,z_m]` or `start_s,end_s,mass_kg|force_n`, on the presses' clock),
/// `link` the link pressed (None: the layout's only one). `full_scale` fixes the sensor's full
/// scale in counts; `gain_sd` and `min_frames` default to the command's. Returns the link's
/// entry of the calibration file: `name`, `curve` (`full_scale`, `half_scale_kpa`), `ids`,
/// `gains`, `fit` (the report: `r_squared`, `rms_n`, `presses`, `unloaded_taxels`, ...). With
/// `output`, also writes it there (JSON, skin-force/1, what run.toml's `[force] calibration`
/// names), complete or not at all; another link's entry in an existing calibration stays, and
/// any other file there is refused. The GIL is released while it runs.
#[pyfunction]
#[pyo3(signature = (config, load, *, log = None, recording = None, link = None, full_scale = None,
    gain_sd = None, min_frames = None, output = None))]
#[allow(clippy::too_many_arguments)] // keyword arguments, as the command's options
pub(crate) fn calibrate_force(
    py: Python<'_>,
    config: PathBuf,
    load: PathBuf,
    log: Option<PathBuf>,
    recording: Option<PathBuf>,
    link: Option<String>,
    full_scale: Option<f64>,
    gain_sd: Option<f64>,
    min_frames: Option<&Bound<'_, PyAny>>,
    output: Option<PathBuf>,
) -> PyResult<Py<PyAny>> {
    let presses = match (&log, &recording) {
        (Some(p), None) => Presses::Log(p),
        (None, Some(p)) => Presses::Recording(p),
        _ => {
            return Err(arg(
                "log, recording",
                "give one of them: the presses' candump log or raw recording",
            ));
        }
    };
    let defaults = ForceFitOptions::default();
    let options = ForceFitOptions {
        full_scale: match full_scale {
            Some(v) if v > f64::from(skin_core::format::recording::MAX_READING) => {
                return Err(arg(
                    "full_scale",
                    format!("{}: counts, at most 1e9", crate::arrays::num(v)),
                ));
            }
            v => v.map(|v| positive("full_scale", v)).transpose()?,
        },
        gain_sd: match gain_sd.unwrap_or(defaults.gain_sd) {
            v if v <= MAX_GAIN_SD => positive("gain_sd", v)?,
            v => {
                return Err(arg(
                    "gain_sd",
                    format!("{}: at most {MAX_GAIN_SD}", crate::arrays::num(v)),
                ));
            }
        },
        min_frames: match min_frames {
            Some(v) => match crate::arrays::count("min_frames", v)? {
                0 => return Err(arg("min_frames", "0: at least 1")),
                n => n,
            },
            None => defaults.min_frames,
        },
        ..defaults
    };
    let mut config_file = SessionConfig::read(&config).map_err(errors::config)?;
    config_file.force = None;
    let io = |e: OutputError| errors::raise(Kind::Input, &e);
    let inputs = match &output {
        Some(out) => {
            let mut inputs = Inputs::new([&config, presses.path(), &load]);
            for p in config_file.inputs().map_err(errors::config)? {
                inputs.add(&p);
            }
            inputs.check(out).map_err(io)?;
            skin_core::output::check_replaceable(out, "a force calibration", |p| {
                ForceCalibration::read(p).is_ok()
            })
            .map_err(io)?;
            Some(inputs)
        }
        None => None,
    };
    let loads = LoadFile::read(&load).map_err(errors::core)?;
    let calibrated = py
        .detach(|| calibrate_link(&config_file, presses, &loads, &load, link.as_deref(), &options))
        .map_err(|e| match e {
            CalibrateForceError::Session(e) => errors::session(e),
            e @ (CalibrateForceError::UnknownLink { .. } | CalibrateForceError::WhichLink { .. }) => {
                arg("link", errors::message(&e))
            }
            e => errors::raise(Kind::Input, &e),
        })?;
    let entry = calibrated.entry();
    if let (Some(out), Some(inputs)) = (&output, &inputs) {
        let mut file = match out.exists() {
            true => ForceCalibration::read(out).map_err(errors::core)?,
            false => ForceCalibration::new(Vec::new()),
        };
        file.set_link(entry.clone());
        skin_core::output::write_file(out, file.to_json().as_bytes(), inputs).map_err(io)?;
    }
    let value = serde_json::to_value(&entry).map_err(|e| errors::error(Kind::Other, e))?;
    crate::event::json(py, &value)
}

fn positive(name: &str, v: f64) -> PyResult<f64> {
    match v.is_finite() && v > 0.0 {
        true => Ok(v),
        false => Err(arg(
            name,
            format!("{}: expected a positive number", crate::arrays::num(v)),
        )),
    }
}
