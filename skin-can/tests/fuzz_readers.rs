//! Fuzzing of skin-can's readers, bus maps and candump logs: arbitrary text and hostile edits of
//! valid files (see `skin_test_support::mutate`) give `Ok` or an error, never a panic; a map and a
//! log that are accepted go through the assembler together without a panic, and every frame
//! it delivers has one value per taxel of the map.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use proptest::prelude::*;
use skin_can::candump::CandumpLog;
use skin_can::decode::skin16::{encode_module, encode_sync};
use skin_can::{Assembler, BusMap, WireFormat, decode};
use skin_can::{MAX_BUSES, SLOTS};
use std::collections::HashSet;
use std::path::Path;

mod common;

use mutate::{arbitrary_text, config, mutated};
use skin_test_support::mutate;

/// Three cycles of skin16 traffic for [`common::TWO_BUSES`], with an icub8-looking frame and an
/// error frame among them.
fn log_text() -> String {
    let mut log = CandumpLog {
        interfaces: vec!["can0".into(), "can1".into()],
        ..CandumpLog::default()
    };
    for c in 0..3u64 {
        let t = 1_000_000 + c * 50_000;
        for (bus, modules) in [(0u16, &[0u32, 5][..]), (1, &[1][..])] {
            log.frames.push(encode_sync(c as u8, t, bus));
            for &a in modules {
                let readings: [u16; 12] =
                    std::array::from_fn(|s| (c * 100 + u64::from(a) * 12 + s as u64) as u16);
                log.frames.extend(encode_module(a, &readings, t + 200, bus));
            }
        }
    }
    let mut text = log.to_text();
    text.push_str("(1.000900) can0 20000080#0000000000000000\n(1.000950) can1 35F#0102030405060708\n");
    text
}

fn check_map(map: &BusMap) -> Result<(), TestCaseError> {
    prop_assert!(map.buses.len() <= MAX_BUSES);
    let ids = map.taxel_ids();
    prop_assert_eq!(
        ids.iter().collect::<HashSet<_>>().len(),
        ids.len(),
        "a taxel twice"
    );
    for bus in &map.buses {
        prop_assert!(bus.modules.iter().all(|m| m.taxels.len() == SLOTS));
    }
    Ok(())
}

/// Pushes every frame of `log` through an assembler for `map`, in both wire formats' decoders.
fn assemble(map: &BusMap, log: &CandumpLog) -> Result<(), TestCaseError> {
    let width = map.taxel_ids().len();
    let mut bad = None;
    let mut check = |a: &skin_can::AssembledFrame| {
        if a.values.len() != width {
            bad = Some(a.values.len());
        }
    };
    match map.format {
        WireFormat::Skin16 => {
            let mut asm = Assembler::new(map, &log.interfaces, decode::Skin16);
            for f in &log.frames {
                asm.push(f, &mut check);
            }
            asm.finish(&mut check);
        }
        WireFormat::Icub8 => {
            let mut asm = Assembler::windowed(map, &log.interfaces, decode::Icub8, 10_000);
            for f in &log.frames {
                asm.push(f, &mut check);
            }
            asm.finish(&mut check);
        }
    }
    prop_assert!(bad.is_none(), "a frame of {bad:?} values for {width} taxels");
    Ok(())
}

#[test]
fn the_valid_files_read() {
    let log = CandumpLog::parse(&log_text(), Path::new("x")).unwrap();
    assert_eq!((log.frames.len(), log.error_frames), (3 * (2 + 3 * 3) + 1, 1));
    let map = common::two_buses();
    assert_eq!(map.taxel_ids().len(), 33);
}

#[test]
fn a_log_naming_too_many_interfaces_is_refused_at_the_line() {
    let text: String = (0..=MAX_BUSES)
        .map(|k| format!("(1.0) can{k} 123#00\n"))
        .collect();
    let e = CandumpLog::parse(&text, Path::new("x.log"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&format!("line {}", MAX_BUSES + 1)) && e.contains("256"),
        "{e}"
    );
    let map: String = std::iter::once("format = \"skin16\"\n".to_string())
        .chain((0..=MAX_BUSES).map(|k| format!("[[bus]]\ninterface = \"can{k}\"\n")))
        .collect();
    let e = BusMap::parse(&map, Path::new("map.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("257 buses"), "{e}");
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn bus_maps(text in prop_oneof![
        mutated(common::TWO_BUSES),
        mutated(&common::TWO_BUSES.replace("skin16", "icub8")),
        arbitrary_text(),
    ]) {
        if let Ok(map) = BusMap::parse(&text, Path::new("map.toml")) {
            check_map(&map)?;
            assemble(&map, &CandumpLog::parse(&log_text(), Path::new("x")).unwrap())?;
        }
    }

    #[test]
    fn candump_logs(text in prop_oneof![mutated(&log_text()), arbitrary_text()]) {
        if let Ok(log) = CandumpLog::parse(&text, Path::new("x.log")) {
            prop_assert!(log.frames.iter().all(|f| usize::from(f.bus) < log.interfaces.len() && f.len <= 8));
            assemble(&common::two_buses(), &log)?;
            // What was read is written back in a form that reads the same.
            let back = CandumpLog::parse(&log.to_text(), Path::new("y")).unwrap();
            prop_assert_eq!(back.frames, log.frames);
        }
    }
}
