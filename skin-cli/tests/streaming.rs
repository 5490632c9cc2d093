//! Inputs read as streams by `skin run`, `skin replay` and `skin convert`: logs of any length
//! (gzip-compressed too), and what a careless user feeds (`/dev/zero`, one endless line, an empty
//! file, a folder, UTF-16, Latin-1) named in one line, never a panic, nothing written.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use std::io::Write;
use std::path::{Path, PathBuf};

skin_test_support::skin_binary!(); // skin(args) runs this package's binary; root()

fn fixture(name: &str) -> PathBuf {
    root().join("fixtures").join(name)
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A configuration of the fixture forearm (no models); `busmap` false leaves the bus map out.
fn config(dir: &Path, busmap: bool) -> PathBuf {
    let mut text = format!("layout = {:?}\n", fixture("forearm/layout.json"));
    if busmap {
        text.push_str(&format!("busmap = {:?}\n", fixture("forearm/busmap.toml")));
    }
    text.push_str("cache = \"cache\"\n");
    let p = dir.join("run.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// The command fails with one line on standard error that contains every one of `want`.
fn fails_with(o: &std::process::Output, want: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    for w in want {
        assert!(err.contains(w), "{w:?} not in {err}");
    }
    err
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

#[cfg(unix)]
#[test]
fn replay_of_dev_zero_is_binary_data_after_a_bounded_read() {
    let o = skin(&[
        "replay",
        "/dev/zero",
        "--busmap",
        s(&fixture("forearm/busmap.toml")),
    ]);
    fails_with(&o, &["/dev/zero: line 1", "binary data"]);
}

#[test]
fn replay_of_one_endless_line_is_refused_at_the_bound() {
    let dir = tempfile::tempdir().unwrap();
    let line = dir.path().join("line.log");
    std::fs::write(&line, vec![b'7'; 3 << 20]).unwrap();
    let csv = dir.path().join("frames.csv");
    let o = skin(&[
        "replay",
        s(&line),
        "--busmap",
        s(&fixture("forearm/busmap.toml")),
        "-o",
        s(&csv),
    ]);
    fails_with(&o, &["line.log: line 1: more than 1.0 MiB without a line end"]);
    assert!(!csv.exists());
}

#[test]
fn replay_writes_the_csv_of_a_gzip_log_as_of_the_plain_one() {
    let dir = tempfile::tempdir().unwrap();
    let gz = dir.path().join("touches.candump.log.gz");
    std::fs::write(
        &gz,
        gzip(&std::fs::read(fixture("forearm/touches.candump.log")).unwrap()),
    )
    .unwrap();
    let busmap = fixture("forearm/busmap.toml");
    let (a, b) = (dir.path().join("a.csv"), dir.path().join("b.csv"));
    let plain = skin(&[
        "replay",
        s(&fixture("forearm/touches.candump.log")),
        "--busmap",
        s(&busmap),
        "-o",
        s(&a),
    ]);
    let zipped = skin(&["replay", s(&gz), "--busmap", s(&busmap), "-o", s(&b)]);
    assert!(plain.status.success() && zipped.status.success());
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}

#[test]
fn replay_of_a_log_of_other_buses_writes_no_csv() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(fixture("forearm/touches.candump.log"))
        .unwrap()
        .replace(" can0 ", " can5 ");
    let log = dir.path().join("other.log");
    std::fs::write(&log, text).unwrap();
    let csv = dir.path().join("frames.csv");
    let o = skin(&[
        "replay",
        s(&log),
        "--busmap",
        s(&fixture("forearm/busmap.toml")),
        "-o",
        s(&csv),
    ]);
    fails_with(
        &o,
        &["other.log: none of the bus map's interfaces (can0) is in the log (it has can5)"],
    );
    assert!(!csv.exists());
}

#[test]
fn run_on_an_empty_log_names_the_log() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.log");
    std::fs::write(&empty, "").unwrap();
    for busmap in [true, false] {
        let cfg = config(dir.path(), busmap);
        let out = dir.path().join("out");
        let o = skin(&["run", s(&cfg), "--log", s(&empty), "-o", s(&out), "-q"]);
        let err = fails_with(&o, &["empty.log: no CAN frames in it (an empty log)"]);
        assert!(!err.contains("Session::"), "{err}");
        assert!(!out.exists());
    }
}

#[test]
fn run_on_a_log_without_a_bus_map_names_the_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), false);
    let out = dir.path().join("out");
    let log = fixture("session/session.candump.log");
    let o = skin(&["run", s(&cfg), "--log", s(&log), "-o", s(&out), "-q"]);
    let err = fails_with(
        &o,
        &["a candump log needs a bus map", "run.toml names none: add busmap"],
    );
    assert!(!err.contains("Session::"), "{err}");
}

#[test]
fn run_reads_a_gzip_log_as_the_plain_one() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), true);
    let log = fixture("session/session.candump.log");
    let gz = dir.path().join("session.candump.log.gz");
    std::fs::write(&gz, gzip(&std::fs::read(&log).unwrap())).unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    for (input, out) in [(&log, &a), (&gz, &b)] {
        let o = skin(&["run", s(&cfg), "--log", s(input), "-o", s(out), "-q"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    assert_eq!(
        std::fs::read(a.join("events.jsonl")).unwrap(),
        std::fs::read(b.join("events.jsonl")).unwrap()
    );
}

#[test]
fn run_on_a_folder_or_a_text_that_is_no_utf8_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), true);
    let out = dir.path().join("out");
    let o = skin(&["run", s(&cfg), "--log", s(dir.path()), "-o", s(&out), "-q"]);
    fails_with(&o, &["a folder, not a file"]);
    let latin1 = dir.path().join("latin1.log");
    std::fs::write(&latin1, b"(1.000000) can0 080#05\n(1.000150) can\xe9 080#05\n").unwrap();
    let o = skin(&["run", s(&cfg), "--log", s(&latin1), "-o", s(&out), "-q"]);
    fails_with(&o, &["latin1.log: line 2, column 15", "iconv -f latin1 -t utf-8"]);
    assert!(!out.exists());
}

#[test]
fn convert_names_an_empty_file_and_a_utf16_one() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), true);
    let mcap = dir.path().join("x.mcap");
    let empty = dir.path().join("empty.log");
    std::fs::write(&empty, "\n").unwrap();
    let o = skin(&["convert", s(&empty), "--config", s(&cfg), "--mcap", s(&mcap)]);
    fails_with(
        &o,
        &["empty.log: empty file: neither a candump log nor a raw recording"],
    );
    let mut utf16 = vec![0xff, 0xfe];
    for u in "16 17\n0 0.0 1 2\n".encode_utf16() {
        utf16.extend_from_slice(&u.to_le_bytes());
    }
    let wide = dir.path().join("wide.txt");
    std::fs::write(&wide, utf16).unwrap();
    let o = skin(&["convert", s(&wide), "--config", s(&cfg), "--mcap", s(&mcap)]);
    fails_with(&o, &["wide.txt: line 1: UTF-16LE text", "iconv -f UTF-16LE"]);
    assert!(!mcap.exists());
}

#[test]
fn convert_reads_a_gzip_recording() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = config(dir.path(), false);
    let gz = dir.path().join("touches.txt.gz");
    std::fs::write(&gz, gzip(&std::fs::read(fixture("forearm/touches.txt")).unwrap())).unwrap();
    let mcap = dir.path().join("t.mcap");
    let o = skin(&["convert", s(&gz), "--config", s(&cfg), "--mcap", s(&mcap)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(mcap.is_file());
}
