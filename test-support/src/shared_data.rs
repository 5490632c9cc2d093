//! Third-party data for tests, read from `../shared/data` beside the project (never copied into
//! it).

use std::path::PathBuf;

/// The path of `rel` under `../shared/data`, or `None` after saying on stderr that the test skips.
///
/// The note goes to stderr directly: libtest captures `eprintln!` of passing tests, and a skip
/// must be visible in the run's output.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(rel);
    if p.exists() {
        Some(p)
    } else {
        use std::io::Write as _;
        let _ = writeln!(
            std::io::stderr(),
            "skipped: {} not found (the shared third-party data is not beside the project)",
            p.display()
        );
        None
    }
}
