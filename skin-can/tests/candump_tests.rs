//! candump logs: byte-for-byte round trips, the forms can-utils and python-can write, bad lines.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use proptest::prelude::*;
use skin_can::candump::{CanFrame, CandumpLog, Direction};
use std::path::Path;

fn parse(text: &str) -> CandumpLog {
    CandumpLog::parse(text, Path::new("t.log")).unwrap()
}

#[test]
fn the_forms_can_utils_and_python_can_write_are_read() {
    let text = "(1700000000.000000) can0 080#05\n\
                \n\
                (1700000000.000150) can1 12345678#0102 R\n\
                (1700000000.000300) can0 7FF#R\n\
                (1700000000.000450) can0 123# T\n";
    let log = parse(text);
    assert_eq!(log.interfaces, ["can0", "can1"]);
    assert_eq!(log.frames.len(), 4);
    let f = log.frames[1];
    assert_eq!(
        (f.bus, f.id, f.extended, f.data()),
        (1, 0x1234_5678, true, &[1u8, 2][..])
    );
    assert_eq!(f.direction, Some(Direction::Received));
    assert_eq!(f.time_us, 1_700_000_000_000_150);
    assert!(log.frames[2].remote && log.frames[2].data().is_empty());
    assert_eq!(log.frames[3].len, 0);
    // Everything but the blank line comes back byte for byte.
    assert_eq!(log.to_text(), text.replace("\n\n", "\n"));
}

#[test]
fn bad_lines_are_errors_naming_the_line() {
    let cases = [
        ("(1.0) can0 123#0\n", "data \"0\""),
        ("(1.0) can0 1234#00\n", "4 hex digits"),
        ("(1.0) can0 800#00\n", "out of range"),
        ("(x) can0 123#00\n", "timestamp"),
        ("1.0 can0 123#00\n", "timestamp"),
        ("(1.0) can0 123#0011223344556677FF\n", "0 to 8 bytes"),
        ("(1.0) can0 123##1000\n", "CAN FD"),
        ("(1.0) can0 123#00 X\n", "only R or T"),
        ("(1.0) can0\n", "no ID#DATA"),
        ("(1.0) can0 12G#00\n", "not hexadecimal"),
    ];
    for (line, expect) in cases {
        let text = format!("(0.000000) can0 080#01\n{line}");
        let e = CandumpLog::parse(&text, Path::new("bad.log"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("bad.log: line 2: ") && e.contains(expect),
            "{line:?} -> {e}"
        );
    }
}

fn frame() -> impl Strategy<Value = CanFrame> {
    (
        0u64..4_000_000_000_000_000,
        0u16..4,
        any::<bool>(),
        any::<u32>(),
        prop::option::of(any::<bool>()),
        any::<bool>(),
        prop::collection::vec(any::<u8>(), 0..=8),
    )
        .prop_map(|(time_us, bus, extended, id, dir, remote, data)| {
            let mut bytes = [0u8; 8];
            bytes[..data.len()].copy_from_slice(&data);
            CanFrame {
                time_us,
                bus,
                id: if extended { id & 0x1FFF_FFFF } else { id & 0x7FF },
                extended,
                remote,
                len: if remote { 0 } else { data.len() as u8 },
                bytes: if remote { [0; 8] } else { bytes },
                direction: dir.map(|r| {
                    if r {
                        Direction::Received
                    } else {
                        Direction::Transmitted
                    }
                }),
            }
        })
}

proptest! {
    #[test]
    fn written_logs_read_back_identically_and_rewrite_byte_for_byte(frames in prop::collection::vec(frame(), 0..50)) {
        let log = CandumpLog {
            interfaces: vec!["can0".into(), "can1".into(), "can2".into(), "can3".into()],
            frames,
            error_frames: 0,
        };
        let text = log.to_text();
        let back = CandumpLog::parse(&text, Path::new("x")).unwrap();
        prop_assert_eq!(back.to_text(), text);
        prop_assert_eq!(back.frames.len(), log.frames.len());
        for (a, b) in back.frames.iter().zip(&log.frames) {
            prop_assert_eq!((a.time_us, a.id, a.extended, a.remote, a.data(), a.direction), (b.time_us, b.id, b.extended, b.remote, b.data(), b.direction));
            prop_assert_eq!(&back.interfaces[usize::from(a.bus)], &log.interfaces[usize::from(b.bus)]);
        }
    }

    #[test]
    fn arbitrary_lines_never_panic(text in "\\PC{0,120}", bytes in prop::collection::vec(any::<u8>(), 0..200)) {
        let _ = CandumpLog::parse(&text, Path::new("x"));
        let _ = CandumpLog::parse(&String::from_utf8_lossy(&bytes), Path::new("x"));
        let _ = CandumpLog::parse(&format!("({text}) can0 123#{text}"), Path::new("x"));
    }
}

proptest! {
    #[test]
    fn a_bad_line_anywhere_is_named_by_its_number(
        good in 0usize..40,
        // A CR ends a line too (as classic Mac files have it): garbage within one line has none.
        garbage in "[^\r\n]{1,40}",
    ) {
        let mut text = String::new();
        for k in 0..good {
            text.push_str(&format!("({}.000100) can0 201#0102\n", 1_700_000_000 + k));
        }
        let bad = format!("(1.0) can0 123#{garbage}");
        prop_assume!(CandumpLog::parse(&bad, Path::new("x")).is_err());
        text.push_str(&bad);
        text.push_str("\n(2.000000) can1 080#01\n");
        let err = CandumpLog::parse(&text, Path::new("session.log")).unwrap_err().to_string();
        let want = format!("session.log: line {}: ", good + 1);
        prop_assert!(err.starts_with(&want), "{}", err);
    }

    /// Arbitrary frames, as a faulty node or a foreign protocol could put on the bus, through both
    /// decoders and both kinds of assembly: never a panic, and frames stay in cycle order.
    #[test]
    fn arbitrary_can_frames_never_panic_a_decoder_or_an_assembler(
        raw in prop::collection::vec((any::<u64>(), 0u16..3, any::<u32>(), any::<bool>(), any::<bool>(), 0u8..=15, any::<[u8; 8]>()), 0..200),
    ) {
        use skin_can::{Assembler, BusMap};
        use skin_can::decode::{Decoder, Icub8, Skin16};
        let frames: Vec<CanFrame> = raw
            .iter()
            .map(|&(time_us, bus, id, extended, remote, len, bytes)| CanFrame {
                time_us,
                bus,
                id: if extended { id & 0x1FFF_FFFF } else { id & 0x7FF },
                extended,
                remote,
                len,
                bytes,
                direction: None,
            })
            .collect();
        let interfaces = vec!["can0".to_string(), "can1".to_string(), "can2".to_string()];
        for format in ["skin16", "icub8"] {
            let map = BusMap::parse(
                &format!("format = \"{format}\"\n[[bus]]\ninterface = \"can0\"\n[[bus.module]]\naddress = 1\ntaxels = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, -1]\n"),
                Path::new("m.toml"),
            )
            .unwrap();
            let mut asm = Assembler::for_map(&map, &interfaces, 50_000);
            let mut cycles = Vec::new();
            for f in &frames {
                let _ = Skin16.decode(f);
                let _ = Icub8.decode(f);
                asm.push(f, &mut |a| cycles.push(a.cycle));
            }
            asm.finish(&mut |a| cycles.push(a.cycle));
            prop_assert!(cycles.windows(2).all(|w| w[0] < w[1]));
        }
    }
}
