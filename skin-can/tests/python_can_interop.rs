//! Interoperability with python-can: logs written by its `CanutilsLogWriter` (4 buses, 10 s,
//! 64 modules, skin16 and icub8, clean and with dropped, duplicated and reordered frames) decode
//! to exactly what was written, with the right missing / duplicated reports, and read-then-write
//! reproduces them byte for byte.
//!
//! The traffic and its ground truth come from `skin-can/interop/python_can_logs.py`. This test
//! runs it with `$SKIN_PYTHON` (which must then have python-can: `.ci/run` sets it to a venv it
//! installs) or else with `python3` when that has python-can; otherwise it says why it is skipped.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use serde::Deserialize;
use skin_can::candump::CandumpLog;
use skin_can::{AssembledFrame, Assembler, BusMap, DEFAULT_WINDOW_US, ModuleRef};
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(Deserialize)]
struct Truth {
    frames: Vec<TruthFrame>,
}

#[derive(Deserialize)]
struct TruthFrame {
    cycle: u64,
    t_us: u64,
    complete: bool,
    values: Vec<Option<u16>>,
    missing: Vec<(u16, u32)>,
    duplicated: Vec<(u16, u32)>,
}

/// A python with python-can, or None (and why) when there is none to use.
fn python() -> Result<PathBuf, String> {
    let (python, required) = match std::env::var_os("SKIN_PYTHON") {
        Some(p) => (PathBuf::from(p), true),
        None => (PathBuf::from("python3"), false),
    };
    let ok = Command::new(&python)
        .args(["-c", "import can"])
        .output()
        .is_ok_and(|o| o.status.success());
    match (ok, required) {
        (true, _) => Ok(python),
        (false, true) => panic!("SKIN_PYTHON={} cannot import python-can", python.display()),
        (false, false) => Err(format!(
            "{} has no python-can (pip install python-can==4.6.1, or set SKIN_PYTHON)",
            python.display()
        )),
    }
}

/// The python to run the script with, or None after saying why the test skips.
fn python_or_skip() -> Option<PathBuf> {
    python().map_err(|why| eprintln!("skipped: {why}")).ok()
}

fn refs(list: &[ModuleRef]) -> Vec<(u16, u32)> {
    list.iter().map(|m| (m.bus, m.address)).collect()
}

fn check(dir: &Path, format: &str, name: &str) {
    let path = dir.join(format!("{name}.log"));
    let text = std::fs::read_to_string(&path).unwrap();
    let log = CandumpLog::parse(&text, &path).unwrap();
    assert_eq!(
        log.to_text(),
        text,
        "{name}: read then write is not byte-identical"
    );
    assert_eq!(log.interfaces, ["can0", "can1", "can2", "can3"]);
    let map = BusMap::read(&dir.join(format!("busmap_{format}.toml"))).unwrap();
    let truth: Truth =
        serde_json::from_str(&std::fs::read_to_string(dir.join(format!("{name}.json"))).unwrap()).unwrap();
    let mut asm = Assembler::for_map(&map, &log.interfaces, DEFAULT_WINDOW_US);
    let mut out: Vec<AssembledFrame> = Vec::new();
    for f in &log.frames {
        asm.push(f, &mut |a| out.push(a.clone()));
    }
    asm.finish(&mut |a| out.push(a.clone()));
    assert_eq!(out.len(), truth.frames.len(), "{name}: frame count");
    assert_eq!(out.len(), 200, "{name}: 10 s at 20 Hz");
    for (ours, want) in out.iter().zip(&truth.frames) {
        let at = format!("{name}, cycle {}", want.cycle);
        assert_eq!(ours.cycle, want.cycle, "{at}");
        assert_eq!(ours.time_us, want.t_us, "{at}");
        assert_eq!(ours.values, want.values, "{at}: values");
        assert_eq!(refs(&ours.missing), want.missing, "{at}: missing modules");
        assert_eq!(
            refs(&ours.duplicated),
            want.duplicated,
            "{at}: duplicated modules"
        );
        assert_eq!(ours.is_complete(), want.complete, "{at}");
    }
    let s = asm.stats();
    assert_eq!(
        (s.late, s.unknown_module, s.before_first_sync, s.skipped),
        (0, 0, 0, 0),
        "{name}"
    );
    assert!(s.malformed.is_empty(), "{name}");
    if name.ends_with("damaged") {
        let partial = truth.frames.iter().filter(|f| !f.complete).count();
        let duplicated = truth.frames.iter().filter(|f| !f.duplicated.is_empty()).count();
        assert!(
            partial > 20 && duplicated > 20,
            "{name}: the damage should touch many cycles"
        );
    }
}

#[test]
fn python_can_logs_decode_to_exactly_what_was_written() {
    let Some(python) = python_or_skip() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("interop/python_can_logs.py");
    let o = Command::new(&python)
        .arg(&script)
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for format in ["skin16", "icub8"] {
        check(dir.path(), format, format);
        check(dir.path(), format, &format!("{format}_damaged"));
    }
}

#[test]
fn python_can_writes_the_fixture_traffic_frame_for_frame_as_the_project_writer_does() {
    let Some(python) = python_or_skip() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let fixtures = root.join("../fixtures/forearm");
    let o = Command::new(&python)
        .arg(root.join("interop/python_can_logs.py"))
        .arg("--fixture")
        .arg(&fixtures)
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let theirs = CandumpLog::read(&dir.path().join("touches.python-can.log")).unwrap();
    let ours = CandumpLog::read(&fixtures.join("touches.candump.log")).unwrap();
    assert_eq!(theirs.interfaces, ours.interfaces);
    assert_eq!(theirs.frames.len(), ours.frames.len());
    for (k, (a, b)) in theirs.frames.iter().zip(&ours.frames).enumerate() {
        assert_eq!(
            a.direction,
            Some(skin_can::candump::Direction::Received),
            "line {}",
            k + 1
        );
        let a = skin_can::candump::CanFrame {
            direction: None,
            ..*a
        };
        assert_eq!(&a, b, "line {}", k + 1);
    }
}
