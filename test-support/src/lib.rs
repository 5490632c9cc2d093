//! What the skin crates' tests and benches share, as a dev-dependency
//! (`skin-test-support = { path = "../test-support", features = [...] }`):
//!
//! - [`shared_data`]: third-party data read from `../shared/data` beside the project, or a skip
//!   that says so;
//! - [`long_log`]: a long candump log made as it is read;
//! - [`python`] and [`python_checks!`]: the Python that runs the interoperability checks;
//! - [`cli`] and [`skin_binary!`]: running the `skin` binary as a user would;
//! - `mutate` (feature `fuzz`): hostile edits of valid files, for the readers' fuzz tests;
//! - `recordings` (feature `recordings`): recordings made partial.
//!
//! What needs the test crate's own environment (its `skin` binary, its `tests/` folder) comes as
//! a macro, expanded in the test crate where Cargo sets that environment.

// A test's set-up that fails must stop the test: panics are how this crate reports.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod cli;
pub mod long_log;
#[cfg(feature = "fuzz")]
pub mod mutate;
pub mod python;
#[cfg(feature = "recordings")]
pub mod recordings;
pub mod shared_data;
