//! candump logs read as a stream: one frame at a time with bounded memory, as editors and tools
//! leave them (a byte-order mark, gzip, CR line ends), and every kind of input that is no log
//! named in one line, never a panic.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use proptest::prelude::*;
use skin_can::BusMap;
use skin_can::candump::{CanSource, CandumpLog, CandumpReader};
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};

use skin_test_support::long_log;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures")
}

fn session_log() -> String {
    std::fs::read_to_string(fixtures().join("session/session.candump.log")).unwrap()
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

#[test]
fn a_log_with_a_byte_order_mark_reads_as_without() {
    let text = "(1700000000.000000) can0 080#05\n(1700000000.000150) can0 201#E803\n";
    let plain = CandumpLog::parse(text, Path::new("t.log")).unwrap();
    let marked = CandumpLog::parse(&format!("\u{feff}{text}"), Path::new("t.log")).unwrap();
    assert_eq!(marked, plain);
}

#[test]
fn cr_only_crlf_and_mixed_line_ends_read_alike() {
    let text = session_log();
    let plain = CandumpLog::parse(&text, Path::new("t.log")).unwrap();
    for other in [
        text.replace('\n', "\r"),
        text.replace('\n', "\r\n"),
        text.split_inclusive('\n')
            .enumerate()
            .map(|(i, l)| {
                if i % 2 == 0 {
                    l.replace('\n', "\r")
                } else {
                    l.to_string()
                }
            })
            .collect(),
    ] {
        assert_eq!(CandumpLog::parse(&other, Path::new("t.log")).unwrap(), plain);
    }
}

#[test]
fn a_gzip_log_is_read_as_it_is_decompressed() {
    let dir = tempfile::tempdir().unwrap();
    let text = session_log();
    let gz = dir.path().join("session.candump.log.gz");
    std::fs::write(&gz, gzip(text.as_bytes())).unwrap();
    let plain = CandumpLog::parse(&text, Path::new("t.log")).unwrap();
    assert_eq!(CandumpLog::read(&gz).unwrap(), plain);
    // Truncated: named with the line it was cut in.
    let whole = std::fs::read(&gz).unwrap();
    std::fs::write(&gz, &whole[..whole.len() / 2]).unwrap();
    let e = CandumpLog::read(&gz).unwrap_err().to_string();
    assert!(
        e.contains("session.candump.log.gz: line ") && e.contains("ends early"),
        "{e}"
    );
}

#[test]
fn utf16_and_latin1_logs_are_named_with_the_fix() {
    let mut utf16 = vec![0xff, 0xfe];
    for u in "(1.000000) can0 080#05\n".encode_utf16() {
        utf16.extend_from_slice(&u.to_le_bytes());
    }
    let e = CandumpReader::new(&utf16[..], Path::new("w.log"))
        .next_frame()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("w.log: line 1: UTF-16LE text") && e.contains("iconv"),
        "{e}"
    );
    let latin1 = b"(1.000000) can0 080#05\n(1.000150) can\xe9 080#05\n";
    let e = CandumpLog::parse(&String::from_utf8_lossy(latin1), Path::new("x"))
        .map(|_| ())
        .and_then(|()| {
            CandumpReader::new(&latin1[..], Path::new("l.log"))
                .into_log()
                .map(|_| ())
        })
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("l.log: line 2, column 15") && e.contains("iconv -f latin1"),
        "{e}"
    );
}

/// An endless input of zeros, as `/dev/zero`, counting what was read.
struct Zeros(u64);

impl Read for Zeros {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        buf.fill(0);
        self.0 += buf.len() as u64;
        Ok(buf.len())
    }
}

#[test]
fn dev_zero_is_binary_after_a_bounded_read() {
    let mut zeros = BufReader::new(Zeros(0));
    let e = CandumpReader::new(&mut zeros, Path::new("/dev/zero"))
        .next_frame()
        .unwrap_err()
        .to_string();
    assert!(e.contains("/dev/zero: line 1: a NUL byte: binary data"), "{e}");
    assert!(zeros.get_ref().0 <= 1 << 16);
    #[cfg(unix)]
    {
        let e = CandumpReader::open(Path::new("/dev/zero"))
            .unwrap()
            .next_frame()
            .unwrap_err()
            .to_string();
        assert!(e.contains("binary data"), "{e}");
    }
}

#[test]
fn a_log_cut_short_by_a_crash_names_the_lines_to_keep() {
    // A power loss while a log is written leaves NULs after the last line written.
    let mut bytes = session_log().into_bytes()[..10_000].to_vec();
    let end = bytes.iter().rposition(|&b| b == b'\n').unwrap() + 1;
    bytes.truncate(end);
    let lines = bytes.iter().filter(|&&b| b == b'\n').count();
    bytes.extend_from_slice(&[0; 4096]);
    let e = CandumpReader::new(&bytes[..], Path::new("crashed.log"))
        .into_log()
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with(&format!("crashed.log: line {}: a NUL byte", lines + 1)),
        "{e}"
    );
    assert!(
        e.contains(&format!("head -n {lines} 'crashed.log' > 'crashed.head.log'")),
        "{e}"
    );
}

#[test]
fn a_log_copied_while_candump_wrote_it_names_the_lines_to_keep() {
    let log = session_log().into_bytes();
    // Cut inside a frame's data: the last line has no line end and odd hex digits.
    let cut = 10_000 + log[10_000..].iter().position(|&b| b == b'#').unwrap() + 2;
    let lines = log[..cut].iter().filter(|&&b| b == b'\n').count();
    let e = CandumpReader::new(&log[..cut], Path::new("live.log"))
        .into_log()
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&format!("live.log: line {}: ", lines + 1)), "{e}");
    assert!(e.contains("ends in the middle of this line"), "{e}");
    assert!(
        e.contains(&format!("head -n {lines} 'live.log' > 'live.head.log'")),
        "{e}"
    );
    // A whole last line without its line end reads as any other.
    let end = log[..cut].iter().rposition(|&b| b == b'\n').unwrap();
    let read = CandumpReader::new(&log[..end], Path::new("whole.log"))
        .into_log()
        .unwrap();
    assert_eq!(read.frames.len(), lines);
}

#[test]
fn a_long_log_is_read_one_frame_at_a_time() {
    // 40 copies of the session: 220 MB that is never made whole.
    let long = long_log::RepeatedLog::new(&session_log(), 40);
    let (served, len) = (long.served(), long.len());
    let mut log = CandumpReader::new(BufReader::new(long), Path::new("long.log"));
    for _ in 0..100_000 {
        log.next_frame().unwrap().unwrap();
    }
    let taken = served.load(std::sync::atomic::Ordering::Relaxed);
    // 100,000 frames are some 4.6 MB of text: no more than that and a buffer was read.
    assert!(
        taken < 5_000_000,
        "{taken} of {len} bytes read for 100,000 frames"
    );
    assert_eq!(log.interfaces(), ["can0"]);
}

#[test]
fn interfaces_are_named_as_they_appear() {
    let text = "(1.000000) can7 080#05\n(1.000100) can0 080#05\n(1.000200) can7 080#05\n";
    let mut log = CandumpReader::new(text.as_bytes(), Path::new("t.log"));
    log.next_frame().unwrap();
    assert_eq!(log.interfaces(), ["can7"]);
    assert_eq!(log.next_frame().unwrap().unwrap().bus, 1);
    assert_eq!(CanSource::interfaces(&log), ["can7", "can0"]);
    assert_eq!(log.next_frame().unwrap().unwrap().bus, 0);
    assert!(log.next_frame().unwrap().is_none());
}

#[test]
fn a_bus_map_as_editors_leave_it_reads() {
    let text = std::fs::read_to_string(fixtures().join("forearm/busmap.toml")).unwrap();
    let plain = BusMap::parse(&text, Path::new("b.toml")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for (name, bytes) in [
        ("bom.toml", format!("\u{feff}{text}")),
        ("mac.toml", text.replace('\n', "\r")),
        ("dos.toml", text.replace('\n', "\r\n")),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        assert_eq!(BusMap::read(&p).unwrap(), plain, "{name}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any bytes, through buffers of any size: frames or one error, never a panic, and the
    /// frames a whole-text read gives (the error may differ: a binary file is recognised by
    /// what the first read brings).
    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400), cap in 1usize..16) {
        let whole = CandumpReader::new(&bytes[..], Path::new("x")).into_log();
        let small = CandumpReader::new(BufReader::with_capacity(cap, &bytes[..]), Path::new("x")).into_log();
        prop_assert_eq!(whole.ok(), small.ok());
    }

    /// Valid lines with every kind of line end, read through small buffers: the same frames as
    /// with LF ends.
    #[test]
    fn line_ends_and_buffer_sizes_do_not_change_the_frames(
        ends in proptest::collection::vec(0usize..3, 1..40),
        cap in 1usize..9,
    ) {
        let mut text = String::new();
        let mut plain = String::new();
        for (k, e) in ends.iter().enumerate() {
            let line = format!("(1.{k:06}) can{} {:03X}#{:02X}", k % 3, k, k % 256);
            text.push_str(&line);
            text.push_str(["\n", "\r\n", "\r"][*e]);
            plain.push_str(&line);
            plain.push('\n');
        }
        let want = CandumpLog::parse(&plain, Path::new("x")).unwrap();
        let got = CandumpReader::new(BufReader::with_capacity(cap, text.as_bytes()), Path::new("x")).into_log().unwrap();
        prop_assert_eq!(got, want);
    }
}
