//! Your files are safe: every case of the data-safety review, as a user would try it. Each test
//! fails on a `skin` that destroys, replaces or silently drops what the user owns. One file per
//! concern; what several use is here.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

skin_test_support::skin_binary!(); // skin(args) runs this package's binary; root()

fn err(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A copy of a fixture file in `dir`.
fn copy(dir: &Path, fixture: &str) -> PathBuf {
    let to = dir.join(Path::new(fixture).file_name().unwrap());
    std::fs::copy(root().join("fixtures").join(fixture), &to).unwrap();
    to
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Every file under `dir` with its bytes, to compare a folder before and after.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_owned()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

/// The fixture session's configuration and log, and the log repeated `times` times one after
/// the other (a longer run, to interrupt), written in `dir`.
fn session(dir: &Path, times: u64) -> (String, String) {
    use skin_can::candump::{CanFrame, CandumpLog};
    let config = root().join("fixtures/session/run.toml").display().to_string();
    let one = CandumpLog::read(&root().join("fixtures/session/session.candump.log")).unwrap();
    let first = one.frames.first().unwrap().time_us;
    let span = one.frames.last().unwrap().time_us - first + 50_000;
    let mut long = one.clone();
    long.frames = (0..times)
        .flat_map(|k| {
            one.frames.iter().map(move |f| CanFrame {
                time_us: f.time_us + k * span,
                ..*f
            })
        })
        .collect();
    let path = dir.join(format!("session{times}.log"));
    long.write(&path).unwrap();
    (config, path.display().to_string())
}

/// Starts `skin ARGS` and returns it once `ready()` holds (or panics if it ends first).
#[cfg(unix)]
fn start_until(args: &[&str], ready: impl Fn() -> bool) -> std::process::Child {
    use std::time::{Duration, Instant};
    let mut child = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !ready() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("{args:?} ended ({status}) before it was ready");
        }
        assert!(
            start.elapsed() < Duration::from_secs(300),
            "{args:?} never got ready"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    child
}

#[cfg(unix)]
fn signal(child: &std::process::Child, sig: &str) {
    let sent = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
}

mod bad_input;
mod interrupt;
#[cfg(feature = "mcap")]
mod mcap;
mod outputs;
