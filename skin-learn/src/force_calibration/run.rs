//! A link's force calibration from its files: a session over the presses (a candump log or a
//! raw recording), the loaded frames kept, the model fitted. What `skin calibrate-force` and
//! Python's `skin.calibrate_force` both call.

use super::{CollectError, ForceFit, ForceFitError, ForceFitOptions, LoadedFrames, fit_force, link_areas};
use crate::session::{FromConfig as _, Session, SessionConfig, SessionError};
use skin_core::TaxelId;
use skin_core::force::ForceError;
use skin_core::format::force_file::LinkForce;
use skin_core::format::load::LoadFile;
use skin_core::format::recording::RecordingReader;
use skin_core::text::{Gzip, Input};
use std::path::{Path, PathBuf};

/// The presses, as recorded.
#[derive(Debug, Clone, Copy)]
pub enum Presses<'a> {
    /// A candump log (the configuration's bus map assembles it); loads on its clock, seconds
    /// since the epoch.
    Log(&'a Path),
    /// A raw recording (Cyskin's ids line, then index, time, counts); loads on its time column.
    Recording(&'a Path),
}

impl Presses<'_> {
    /// The file.
    pub fn path(&self) -> &Path {
        match self {
            Presses::Log(p) | Presses::Recording(p) => p,
        }
    }
}

/// A link's fitted force model, with what it was fitted for.
#[derive(Debug, Clone)]
pub struct LinkCalibration {
    /// The link's name.
    pub link: String,
    /// Its taxels' ids, layout order (the gains' order).
    pub ids: Vec<TaxelId>,
    /// The model and its report.
    pub fit: ForceFit,
}

impl LinkCalibration {
    /// The link's entry in a force calibration file
    /// ([`ForceCalibration::set_link`](skin_core::format::force_file::ForceCalibration::set_link)
    /// puts it in).
    pub fn entry(&self) -> LinkForce {
        self.fit.link_force(&self.link, &self.ids)
    }
}

/// Why a link could not be calibrated.
#[derive(Debug, thiserror::Error)]
pub enum CalibrateForceError {
    /// The configuration's session could not run the presses.
    #[error(transparent)]
    Session(#[from] SessionError),
    /// The load file or the recording could not be read.
    #[error(transparent)]
    Read(#[from] skin_core::Error),
    /// No link of the layout has the name asked for.
    #[error("link \"{name}\": the layout's links are {}", known.join(", "))]
    UnknownLink {
        /// The name asked for.
        name: String,
        /// The layout's links.
        known: Vec<String>,
    },
    /// The layout has several links and none was named.
    #[error("the layout has {} links ({}): name the one pressed", known.len(), known.join(", "))]
    WhichLink {
        /// The layout's links.
        known: Vec<String>,
    },
    /// The session made no tactile map of the link.
    #[error("the session has no map of link \"{link}\"")]
    NoMap {
        /// The link.
        link: String,
    },
    /// The link's mesh gives a taxel no area.
    #[error("the mesh of link \"{link}\"")]
    Mesh {
        /// The link.
        link: String,
        /// What is wrong with it.
        #[source]
        source: ForceError,
    },
    /// The frames do not go with the load file.
    #[error(transparent)]
    Collect(#[from] CollectError),
    /// The fit refused the presses.
    #[error("{} with {}: cannot calibrate link \"{link}\"", presses.display(), load.display())]
    Fit {
        /// The presses' file.
        presses: PathBuf,
        /// The load file.
        load: PathBuf,
        /// The link.
        link: String,
        /// Why.
        #[source]
        source: ForceFitError,
    },
}

/// Calibrates link `link` (by name; none: the layout's only link) of `config`'s skin from
/// `presses` under the known `loads` (read from `load_path`, which names it in errors).
///
/// Runs the configuration's session over the presses, its first frames learning the baseline
/// unloaded, keeps the link's frames within the loads' times ([`LoadedFrames`]) and fits its
/// model ([`fit_force`]) on the areas of the session's map of the link ([`link_areas`]). The
/// configuration's own `[force]` is not read: the run is in counts (a stale calibration, of
/// another layout, would refuse the session).
pub fn calibrate_link(
    config: &SessionConfig,
    presses: Presses<'_>,
    loads: &LoadFile,
    load_path: &Path,
    link: Option<&str>,
    options: &ForceFitOptions,
) -> Result<LinkCalibration, CalibrateForceError> {
    let mut config = config.clone();
    config.force = None;
    // In counts, no touch has a force to gate on.
    if let Some(gate) = &mut config.gate {
        gate.force_n.clear();
    }
    let mut session = Session::from_config(&config)?;
    let index = pick_link(&session, link)?;
    let frames = match presses {
        Presses::Log(log) => {
            let mut sink = LoadedFrames::new(loads, index, 0.0);
            let reader = skin_can::candump::CandumpReader::new(Input::open(log, Gzip::Read)?, log);
            session.run_log(reader, log, &mut sink, &mut |_, _| {})?;
            sink.finish()?
        }
        Presses::Recording(rec) => {
            // The session's stamps count from the recording's first frame; the loads' are on
            // its time column.
            let first = RecordingReader::open(rec)?.next_frame()?.map_or(0.0, |f| f.time);
            let mut sink = LoadedFrames::new(loads, index, first);
            session.run_recording(RecordingReader::open(rec)?, rec, &mut sink)?;
            sink.finish()?
        }
    };
    let name = session.links()[index].name.clone();
    let map = session
        .pipeline()
        .map(index)
        .ok_or_else(|| CalibrateForceError::NoMap { link: name.clone() })?;
    let areas = link_areas(map).map_err(|source| CalibrateForceError::Mesh {
        link: name.clone(),
        source,
    })?;
    let fit = fit_force(&frames, &areas, options).map_err(|source| CalibrateForceError::Fit {
        presses: presses.path().to_owned(),
        load: load_path.to_owned(),
        link: name.clone(),
        source,
    })?;
    Ok(LinkCalibration {
        link: name,
        ids: map.ids.clone(),
        fit,
    })
}

/// The layout index of the link named `name`, or of the only link.
fn pick_link(session: &Session, name: Option<&str>) -> Result<usize, CalibrateForceError> {
    let known = || session.links().iter().map(|l| l.name.clone()).collect();
    match name {
        Some(n) => {
            session
                .links()
                .iter()
                .position(|l| l.name == n)
                .ok_or_else(|| CalibrateForceError::UnknownLink {
                    name: n.to_owned(),
                    known: known(),
                })
        }
        None if session.links().len() == 1 => Ok(0),
        None => Err(CalibrateForceError::WhichLink { known: known() }),
    }
}
