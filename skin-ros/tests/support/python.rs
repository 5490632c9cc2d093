//! The Python that runs the interoperability checks: `$SKIN_PYTHON` (then it must have the
//! packages, `.ci/run` sets it to its venv), else `python3` if it has them, else the test skips
//! and says why.

use std::path::PathBuf;
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

/// Runs `script` with `args`; panics with its output unless it succeeds. Returns its stdout.
pub fn run(python: &PathBuf, script: &str, args: &[&std::ffi::OsStr]) -> String {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join(script);
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
