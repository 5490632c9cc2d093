//! The Python that runs the interoperability checks: `$SKIN_PYTHON` (then it must have the
//! packages, `.ci/run` sets it to its venv), else `python3` if it has them, else the test skips
//! and says why. The scripts sit in the `tests/` folder of the crate that runs them: a test crate
//! says `skin_test_support::python_checks!();` and gets a module `python` with
//! [`python_with`] and a `run(python, script, args)` that finds them there.

use std::path::{Path, PathBuf};
use std::process::Command;

/// A Python that imports `modules`, or None after saying on stderr why the test skips.
pub fn python_with(modules: &str) -> Option<PathBuf> {
    let (python, required) = match std::env::var_os("SKIN_PYTHON") {
        Some(p) => (PathBuf::from(p), true),
        None => (PathBuf::from("python3"), false),
    };
    let ok = Command::new(&python)
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success());
    match (ok, required) {
        (true, _) => Some(python),
        (false, true) => panic!("SKIN_PYTHON={} cannot import {modules}", python.display()),
        (false, false) => {
            use std::io::Write as _;
            let _ = writeln!(
                std::io::stderr(),
                "skipped: {} cannot import {modules} (pip install -r skin-ros/tests/requirements.txt, or set SKIN_PYTHON)",
                python.display()
            );
            None
        }
    }
}

/// Runs `script` (a path under `tests`) with `args`; panics with its output unless it succeeds.
/// Returns its stdout.
pub fn run_in(tests: &Path, python: &PathBuf, script: &str, args: &[&std::ffi::OsStr]) -> String {
    let path = tests.join(script);
    let out = Command::new(python)
        .arg(&path)
        .args(args)
        .output()
        .expect("python runs");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{script} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Defines a module `python` with [`python_with`] and `run(python, script, args)`, which runs
/// `script` from the calling crate's `tests/` folder. Expanded in the test crate, where
/// `CARGO_MANIFEST_DIR` names that crate.
#[macro_export]
macro_rules! python_checks {
    () => {
        mod python {
            #[allow(unused_imports)]
            pub use $crate::python::python_with;

            /// Runs `script` (under this crate's `tests/`) with `args`; panics with its output
            /// unless it succeeds. Returns its stdout.
            #[allow(dead_code)]
            pub fn run(python: &::std::path::PathBuf, script: &str, args: &[&::std::ffi::OsStr]) -> String {
                let tests = ::std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
                $crate::python::run_in(&tests, python, script, args)
            }
        }
    };
}
