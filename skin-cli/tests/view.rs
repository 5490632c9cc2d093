//! The viewer from the command line: `skin view` and `skin run --view`, as a user runs them: a
//! damaged MCAP file is named before it is served, a bad speed is one clear line, and an output
//! that is refused is refused before the viewer starts.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

skin_test_support::skin_binary!(); // skin(args) runs this package's binary; root()

fn session(name: &str) -> String {
    root().join("fixtures/session").join(name).display().to_string()
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The fixture session written as an MCAP file by `skin run --mcap`.
fn session_mcap(dir: &Path) -> PathBuf {
    let mcap = dir.join("session.mcap");
    let out = dir.join("out");
    let o = skin(&[
        "run",
        &session("run.toml"),
        "--log",
        &session("session.candump.log"),
        "-o",
        out.to_str().unwrap(),
        "-q",
        "--mcap",
        mcap.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    mcap
}

/// What `skin view FILE --view 0` says until it serves (then it is stopped).
fn said_before_serving(file: &Path) -> Vec<String> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_skin"))
        .args(["view", file.to_str().unwrap(), "--view", "0"])
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = Vec::new();
    for line in BufReader::new(child.stderr.take().unwrap()).lines() {
        let line = line.unwrap();
        let serving = line.starts_with("replaying ");
        lines.push(line);
        if serving {
            break;
        }
    }
    child.kill().unwrap();
    child.wait().unwrap();
    lines
}

#[test]
fn a_damaged_mcap_is_named_chunk_by_chunk_and_an_intact_one_as_before() {
    let dir = tempfile::tempdir().unwrap();
    let mcap = session_mcap(dir.path());
    let intact = said_before_serving(&mcap);
    assert!(intact.iter().all(|l| !l.contains("warning")), "{intact:#?}");
    assert!(intact.last().unwrap().starts_with("replaying "), "{intact:#?}");
    // Bytes flipped in the middle of the data section: chunks fail their CRC.
    let mut bytes = std::fs::read(&mcap).unwrap();
    let mid = bytes.len() / 2;
    for k in 0..50 {
        bytes[mid - 25_000 + k * 1000] ^= 0x10;
    }
    let bad = dir.path().join("bad.mcap");
    std::fs::write(&bad, &bytes).unwrap();
    let said = said_before_serving(&bad);
    let warning = said
        .iter()
        .position(|l| {
            l.starts_with("warning: ") && l.contains("bad.mcap") && l.contains("chunks are damaged")
        })
        .unwrap_or_else(|| panic!("no warning: {said:#?}"));
    assert!(said[warning].contains("cannot be trusted"), "{}", said[warning]);
    let named: Vec<&String> = said
        .iter()
        .filter(|l| l.trim_start().starts_with("chunk "))
        .collect();
    assert!(!named.is_empty(), "{said:#?}");
    assert!(
        named.iter().all(|l| l.contains(" s to ") && l.contains("bytes ")),
        "{named:#?}"
    );
    // Said before the page is served.
    let served = said
        .iter()
        .position(|l| l.starts_with("view the skin at"))
        .unwrap();
    assert!(warning < served, "{said:#?}");
}

#[test]
fn a_speed_out_of_range_is_one_clear_line() {
    let dir = tempfile::tempdir().unwrap();
    let view = skin(&["view", "x.mcap", "--speed", "-1"]);
    let run = skin(&[
        "run",
        &session("run.toml"),
        "--log",
        &session("session.candump.log"),
        "-o",
        dir.path().join("out").to_str().unwrap(),
        "--view",
        "0",
        "--speed",
        "-1",
    ]);
    for (name, o) in [("view", view), ("run", run)] {
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        assert!(
            e.contains("'-1'") && e.contains("--speed") && e.contains("from 0.01 to 100"),
            "{name}: {e}"
        );
        assert!(!e.contains("tip"), "{name}: a misleading tip: {e}");
    }
    assert!(!dir.path().join("out").exists());
}

#[test]
fn an_output_that_is_a_file_is_refused_before_the_viewer_starts() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("afile");
    std::fs::write(&file, "the user's").unwrap();
    let o = skin(&[
        "run",
        &session("run.toml"),
        "--log",
        &session("session.candump.log"),
        "-o",
        file.to_str().unwrap(),
        "--view",
        "0",
    ]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(e.contains("not a folder"), "{e}");
    assert!(!e.contains("view the skin"), "the viewer started first: {e}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "the user's");
}
