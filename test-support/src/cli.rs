//! Running the `skin` binary from skin-cli's tests as a user would. Cargo names the binary only
//! to the test crates of its own package (`CARGO_BIN_EXE_skin`), so a test crate says
//! `skin_test_support::skin_binary!();` and gets `skin(args)` and `root()`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the binary at `binary` with `args` and returns what it did.
pub fn run(binary: &str, args: &[&str]) -> Output {
    Command::new(binary)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run skin: {e}"))
}

/// The workspace root (fixtures are under `fixtures/`).
pub fn root() -> PathBuf {
    // This crate sits one folder below the root, as every crate of the workspace does.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    root.canonicalize().unwrap_or(root)
}

/// Defines `skin(args: &[&str]) -> Output`, which runs this package's `skin` binary, and brings
/// [`root`] into scope. Expanded in the test crate, where Cargo sets `CARGO_BIN_EXE_skin`.
#[macro_export]
macro_rules! skin_binary {
    () => {
        #[allow(unused_imports)]
        use $crate::cli::root;

        /// Runs `skin` with `args` and returns what it did.
        #[allow(dead_code)]
        fn skin(args: &[&str]) -> ::std::process::Output {
            $crate::cli::run(env!("CARGO_BIN_EXE_skin"), args)
        }
    };
}

/// The names in `dir`, sorted: what a run left there.
pub fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// A loopback port nothing listens on now, for a test's own Zenoh peer.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}
