//! The command line's side of the output rules (`skin_core::output` holds the rules): what
//! Ctrl-C and SIGTERM do, and the `--force` hint.

pub use skin_core::output::{Inputs, OutputDir, OutputError, OutputFile, write_file};

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set by Ctrl-C / SIGTERM for commands that stop by themselves (`live`, `record`, `run --can`).
static STOP: AtomicBool = AtomicBool::new(false);
/// Whether the running command stops by itself on an interrupt (else the handler ends it).
static GRACEFUL: AtomicBool = AtomicBool::new(false);

/// Catches Ctrl-C, SIGTERM and SIGHUP for the whole process: a command that stops by itself is
/// told so (see [`stop_flag`]); any other is ended at once with status 130, after its half-built
/// outputs are removed (the previous outputs stay as they were).
pub fn install_interrupt_handler() {
    // Without a handler an interrupt still ends the program; temporary names then stay hidden.
    let _ = ctrlc::set_handler(|| {
        if GRACEFUL.load(Ordering::SeqCst) && !STOP.swap(true, Ordering::SeqCst) {
            return; // the command finishes its outputs and stops; a second interrupt ends it
        }
        skin_core::output::abandon_unfinished();
        eprintln!("interrupted: nothing was written");
        std::process::exit(130);
    });
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
