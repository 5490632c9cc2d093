//! The command line's side of the output rules (`skin_core::output` holds the rules): what
//! Ctrl-C and SIGTERM do, and the `--force` hint.

pub use skin_core::output::{Inputs, OutputDir, OutputError, OutputFile, write_file};

use std::io::Read as _;

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set by Ctrl-C / SIGTERM for commands that stop by themselves (`live`, `record`, `run --can`).
static STOP: AtomicBool = AtomicBool::new(false);
/// Whether the running command stops by itself on an interrupt (else the handler ends it).
static GRACEFUL: AtomicBool = AtomicBool::new(false);
/// Set once the command's files are in place (what remains is the network's).
static WRITTEN: AtomicBool = AtomicBool::new(false);

/// Catches Ctrl-C, SIGTERM and SIGHUP for the whole process: a command that stops by itself is
/// told so (see [`stop_flag`]); any other is ended at once with status 130, after its half-built
/// outputs are removed (the previous outputs stay as they were). Outputs being moved into
/// place, or whose frames were all processed (see [`skin_core::output::writing`]), are finished
/// first and kept.
pub fn install_interrupt_handler() {
    // Without a handler an interrupt still ends the program; temporary names then stay hidden.
    let _ = ctrlc::set_handler(|| {
        if GRACEFUL.load(Ordering::SeqCst) && !STOP.swap(true, Ordering::SeqCst) {
            return; // the command finishes its outputs and stops; a second interrupt ends it
        }
        let abandoned = skin_core::output::abandon_unfinished();
        if WRITTEN.load(Ordering::SeqCst) && abandoned == 0 {
            eprintln!(
                "interrupted: the outputs were written; what was still queued for the network is not sent"
            );
        } else {
            eprintln!("interrupted: nothing was written");
        }
        std::process::exit(130);
    });
}

/// Says that the command's files are in place, for the interrupt handler's last line.
pub fn outputs_written() {
    WRITTEN.store(true, Ordering::SeqCst);
}

/// Marks the running command as one that stops by itself on Ctrl-C (it polls [`stop_flag`]).
pub fn stop_gracefully() {
    GRACEFUL.store(true, Ordering::SeqCst);
}

/// Set once Ctrl-C or SIGTERM asked a graceful command to stop.
pub fn stop_flag() -> &'static AtomicBool {
    &STOP
}

/// The command's output folder ([`OutputDir::create`]), with the flag that overrides a refusal.
pub fn open_dir(dir: &Path, command: &str, force: bool, inputs: &Inputs) -> anyhow::Result<OutputDir> {
    OutputDir::create(dir, command, force, inputs).map_err(force_hint)
}

/// Refuses the output folder before any work, as [`open_dir`] would.
pub fn precheck_dir(dir: &Path, command: &str, force: bool) -> anyhow::Result<()> {
    OutputDir::precheck(dir, command, force).map_err(force_hint)
}

fn force_hint(e: OutputError) -> anyhow::Error {
    match e {
        OutputError::NotOurs { .. } => anyhow::anyhow!("{e} with --force"),
        e => e.into(),
    }
}

/// `e` with the folder being built named as the user's folder: a message never names a
/// temporary path (a library writer only knows the path it was given).
pub fn user_error(out: &OutputDir, e: anyhow::Error) -> anyhow::Error {
    let text = format!("{e:#}");
    let staging = out.path().display().to_string();
    anyhow::anyhow!("{}", text.replace(&staging, &out.dir().display().to_string()))
}

/// What a single-file output holds. An existing file at the path is replaced only if it holds
/// the same kind, so that running a command again works and a user's other file is never lost.
#[derive(Debug, Clone, Copy)]
pub enum Kind {
    /// A tactile map (the project's JSON or Cyskin's).
    Map,
    /// A skin layout (any file `skin flatten` reads).
    Layout,
    /// A bus map.
    BusMap,
    /// A probe dataset (CSV).
    Probes,
    /// An SVG drawing.
    Svg,
    /// A candump log.
    CandumpLog,
    /// A force calibration (`skin-force/1`).
    ForceCalibration,
    /// A text table whose first line starts with this header.
    Table(&'static str),
}

impl Kind {
    fn name(self) -> String {
        match self {
            Kind::Map => "a tactile map".into(),
            Kind::Layout => "a skin layout".into(),
            Kind::BusMap => "a bus map".into(),
            Kind::Probes => "a probe dataset".into(),
            Kind::Svg => "an SVG drawing".into(),
            Kind::CandumpLog => "a candump log".into(),
            Kind::ForceCalibration => "a force calibration".into(),
            Kind::Table(header) => format!("a table starting \"{header}\""),
        }
    }

    /// Whether the file at `path` is of this kind. Only the start of a log or a table is read.
    fn holds(self, path: &Path) -> bool {
        let head = || {
            let mut text = String::new();
            std::fs::File::open(path)
                .and_then(|f| f.take(64 * 1024).read_to_string(&mut text))
                .map(|_| text)
                .unwrap_or_default()
        };
        match self {
            Kind::Map => skin_geom::TactileMap::read(path).is_ok(),
            Kind::Layout => skin_core::format::load_link(path).is_ok(),
            Kind::BusMap => skin_can::BusMap::read(path).is_ok(),
            Kind::Probes => skin_learn::calibration::ProbeDataset::read(path).is_ok(),
            Kind::Svg => head().contains("<svg"),
            Kind::CandumpLog => {
                let text = head();
                let first = text.lines().find(|l| !l.trim().is_empty()).unwrap_or_default();
                skin_can::candump::CandumpLog::parse(first, path)
                    .is_ok_and(|l| l.frames.len() + l.error_frames == 1)
            }
            Kind::ForceCalibration => skin_core::format::force_file::ForceCalibration::read(path).is_ok(),
            Kind::Table(header) => head().starts_with(header),
        }
    }
}

/// Refuses, before any work, an output `path` that is one of the `inputs`, or an existing file
/// there that is not of `kind` ([`skin_core::output::check_replaceable`]).
pub fn replaceable(inputs: &Inputs, path: Option<&Path>, kind: Kind) -> anyhow::Result<()> {
    let Some(p) = path else {
        return Ok(());
    };
    inputs.check(p)?;
    Ok(skin_core::output::check_replaceable(p, &kind.name(), |p| {
        kind.holds(p)
    })?)
}
