//! Running the `skin` binary from skin-cli's tests as a user would. Included by each test crate
//! with `#[path = "../../test-support/cli.rs"] mod cli;`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `skin` with `args` and returns what it did.
pub fn skin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run skin: {e}"))
}

/// The workspace root (fixtures are under `fixtures/`).
pub fn root() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    root.canonicalize().unwrap_or(root)
}
