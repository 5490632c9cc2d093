//! skin16 decoding and snapshot assembly: exact values, and honest reports of what went wrong.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use proptest::prelude::*;
use skin_can::candump::{CanFrame, CandumpLog};
use skin_can::decode::Skin16;
use skin_can::decode::skin16::{encode_module, encode_sync};
use skin_can::{AssembledFrame, Assembler, BusMap, ModuleRef};
use std::path::Path;

mod common;

fn map() -> BusMap {
    common::two_buses()
}

/// The reading of slot `slot` of module (bus, address) in cycle `cycle`.
fn reading(cycle: u64, bus: u16, address: u32, slot: usize) -> u16 {
    (cycle * 1000 + u64::from(bus) * 100 + u64::from(address) * 12 + slot as u64) as u16
}

/// `cycles` cycles of traffic on both buses, 50 ms apart, counters starting at `start`.
fn traffic(cycles: u64, start: u8) -> Vec<CanFrame> {
    let mut frames = Vec::new();
    for c in 0..cycles {
        let t = 1_000_000 + c * 50_000;
        for (bus, modules) in [(0u16, &[0u32, 5][..]), (1, &[1][..])] {
            frames.push(encode_sync(start.wrapping_add(c as u8), t, bus));
            for &a in modules {
                let readings: [u16; 12] = std::array::from_fn(|s| reading(c, bus, a, s));
                frames.extend(encode_module(a, &readings, t + 200, bus));
            }
        }
    }
    frames
}

fn assemble(frames: &[CanFrame]) -> (Vec<AssembledFrame>, skin_can::AssemblyStats) {
    let interfaces = vec!["can0".to_string(), "can1".to_string()];
    let mut asm = Assembler::new(&map(), &interfaces, Skin16);
    let mut out = Vec::new();
    for f in frames {
        asm.push(f, &mut |a| out.push(a.clone()));
    }
    asm.finish(&mut |a| out.push(a.clone()));
    (out, asm.stats().clone())
}

fn expected_values(cycle: u64) -> Vec<Option<u16>> {
    let mut v = Vec::new();
    for (bus, a) in [(0u16, 0u32), (0, 5), (1, 1)] {
        v.extend((0..11).map(|s| Some(reading(cycle, bus, a, s))));
    }
    v
}

#[test]
fn a_clean_log_decodes_to_exactly_the_values_written() {
    let frames = traffic(10, 0);
    // Through the candump text form, as a recording would be.
    let log = CandumpLog {
        interfaces: vec!["can0".into(), "can1".into()],
        frames,
        error_frames: 0,
    };
    let back = CandumpLog::parse(&log.to_text(), Path::new("x.log")).unwrap();
    let (out, stats) = assemble(&back.frames);
    assert_eq!(out.len(), 10);
    assert_eq!((stats.frames, stats.complete), (10, 10));
    for (c, f) in out.iter().enumerate() {
        assert_eq!(f.cycle, c as u64);
        assert_eq!(f.time_us, 1_000_000 + c as u64 * 50_000);
        assert!(f.is_complete() && f.duplicated.is_empty());
        assert_eq!(f.values, expected_values(c as u64));
    }
    assert_eq!(map().taxel_ids().len(), 33);
}

#[test]
fn a_frame_with_a_missing_module_is_reported_not_dropped() {
    let mut frames = traffic(6, 0);
    // Drop chunk 1 of module 1 on bus 1 in cycle 3.
    let victim = frames
        .iter()
        .position(|f| f.bus == 1 && f.id == 0x200 | (1 << 2) | 1 && f.time_us == 1_000_000 + 3 * 50_000 + 200)
        .unwrap();
    frames.remove(victim);
    let (out, stats) = assemble(&frames);
    assert_eq!(out.len(), 6);
    assert_eq!((stats.frames, stats.complete), (6, 5));
    let f = &out[3];
    assert_eq!(f.missing, vec![ModuleRef { bus: 1, address: 1 }]);
    let mut expect = expected_values(3);
    for v in &mut expect[22 + 4..22 + 8] {
        *v = None;
    }
    assert_eq!(f.values, expect);
    for (c, f) in out.iter().enumerate().filter(|(c, _)| *c != 3) {
        assert_eq!(f.values, expected_values(c as u64));
    }
}

#[test]
fn duplicated_and_reordered_frames_keep_the_values_and_are_reported() {
    let mut frames = traffic(5, 0);
    // Reverse the data frames of cycle 2 on bus 0 (sync stays first), and send one twice.
    let start = frames
        .iter()
        .position(|f| f.bus == 0 && f.id == 0x080 && f.bytes[0] == 2)
        .unwrap();
    frames[start + 1..start + 7].reverse();
    let copy = frames[start + 3];
    frames.insert(start + 4, copy);
    let (out, _) = assemble(&frames);
    assert_eq!(out.len(), 5);
    assert!(out.iter().all(|f| f.is_complete()));
    for (c, f) in out.iter().enumerate() {
        assert_eq!(f.values, expected_values(c as u64));
    }
    assert_eq!(out[2].duplicated.len(), 1);
    assert!(
        out.iter()
            .enumerate()
            .all(|(c, f)| c == 2 || f.duplicated.is_empty())
    );
}

#[test]
fn the_cycle_counter_wraps_past_255_and_cycles_keep_increasing() {
    let (out, _) = assemble(&traffic(8, 252));
    let cycles: Vec<u64> = out.iter().map(|f| f.cycle).collect();
    assert_eq!(cycles, (252..260).collect::<Vec<u64>>());
    assert!(out.iter().all(|f| f.is_complete()));
}

#[test]
fn a_silent_bus_leaves_its_modules_missing_in_every_frame() {
    let frames: Vec<CanFrame> = traffic(4, 0).into_iter().filter(|f| f.bus == 0).collect();
    let (out, _) = assemble(&frames);
    assert_eq!(out.len(), 4);
    assert!(
        out.iter()
            .all(|f| f.missing == vec![ModuleRef { bus: 1, address: 1 }])
    );
}

#[test]
fn bad_bus_maps_name_the_module_and_slot() {
    let dup = common::TWO_BUSES.replace("[48,", "[16,");
    let e = BusMap::parse(&dup, Path::new("m.toml")).unwrap_err().to_string();
    assert!(
        e.contains("taxel 16 is also in bus \"can0\" module 0") && !e.contains("line 0"),
        "{e}"
    );
    let short = common::TWO_BUSES.replacen("26, -1]", "26]", 1);
    let e = BusMap::parse(&short, Path::new("m.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("11 taxel slots, expected 12"), "{e}");
    let e = BusMap::parse("format = \"skin17\"\n", Path::new("m.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("m.toml: line 1:"), "{e}");
    let big = common::TWO_BUSES.replacen("address = 5", "address = 200", 1);
    assert!(
        BusMap::parse(&big, Path::new("m.toml"))
            .unwrap_err()
            .to_string()
            .contains("0..127")
    );
}

#[test]
fn a_huge_bad_field_is_quoted_by_its_first_characters_only() {
    let long = "x".repeat(1_000_000);
    let log = format!("(1.000000) can0 201#0102\n(1.000100) can0 {long}#01\n");
    let e = skin_can::candump::CandumpLog::parse(&log, Path::new("s.log"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("line 2") && e.len() < 300,
        "{}",
        &e[..e.len().min(400)]
    );
    let map = common::TWO_BUSES.replace("\"can1\"", &format!("\"{long}\""))
        + &format!("[[bus]]\ninterface = \"{long}\"\n");
    let e = BusMap::parse(&map, Path::new("m.toml")).unwrap_err().to_string();
    assert!(
        e.contains("appears on two buses") && e.len() < 300,
        "{}",
        &e[..e.len().min(400)]
    );
}

proptest! {
    #[test]
    fn arbitrary_traffic_never_panics_and_every_cycle_is_delivered(
        raw in prop::collection::vec((0u16..3, 0u32..0x400, prop::collection::vec(any::<u8>(), 0..=8)), 0..300)
    ) {
        let frames: Vec<CanFrame> = raw
            .iter()
            .enumerate()
            .map(|(k, (bus, id, data))| {
                let mut bytes = [0u8; 8];
                bytes[..data.len()].copy_from_slice(data);
                CanFrame { time_us: k as u64, bus: *bus, id: *id, extended: false, remote: false, len: data.len() as u8, bytes, direction: None }
            })
            .collect();
        let interfaces = vec!["can0".to_string(), "can1".to_string(), "vcan9".to_string()];
        let mut asm = Assembler::new(&map(), &interfaces, Skin16);
        let mut cycles = Vec::new();
        for f in &frames {
            asm.push(f, &mut |a| cycles.push(a.cycle));
        }
        asm.finish(&mut |a| cycles.push(a.cycle));
        prop_assert!(cycles.windows(2).all(|w| w[0] < w[1]));
    }
}

#[test]
fn icub8_triangles_decode_to_their_readings_and_status() {
    use skin_can::decode::icub8::{encode_triangle, status};
    use skin_can::decode::{Decoded, Decoder, Icub8};
    let readings: [u8; 12] = std::array::from_fn(|k| 255 - 10 * k as u8);
    let [a, b] = encode_triangle(0x3A, &readings, 0b1000_0000_0101, 0b10, 7, 0);
    assert_eq!(a.id, 0x43A);
    let mut dec = Icub8;
    let Decoded::Values {
        address,
        first_slot,
        count,
        values,
    } = dec.decode(&a)
    else {
        panic!()
    };
    assert_eq!((address, first_slot, count), (0x3A, 0, 7));
    assert_eq!(
        values[..7].iter().map(|&v| v as u8).collect::<Vec<_>>(),
        readings[..7]
    );
    let Decoded::Values {
        first_slot,
        count,
        values,
        ..
    } = dec.decode(&b)
    else {
        panic!()
    };
    assert_eq!((first_slot, count), (7, 5));
    assert_eq!(
        values[..5].iter().map(|&v| v as u8).collect::<Vec<_>>(),
        readings[7..]
    );
    assert_eq!(status(&b), Some((0b1000_0000_0101, 0b10)));
    // Legacy class 3 is accepted; other classes and a bad first byte are not skin data.
    let mut legacy = a;
    legacy.id = 0x33A;
    assert!(matches!(dec.decode(&legacy), Decoded::Values { .. }));
    let mut other = a;
    other.id = 0x53A;
    assert_eq!(dec.decode(&other), Decoded::Ignored);
    let mut bad = a;
    bad.bytes[0] = 0x41;
    assert!(matches!(dec.decode(&bad), Decoded::Malformed(_)));
}

/// `frames` moved later by `us` microseconds.
fn later(frames: Vec<CanFrame>, us: u64) -> Vec<CanFrame> {
    frames
        .into_iter()
        .map(|mut f| {
            f.time_us += us;
            f
        })
        .collect()
}

#[test]
fn a_restarted_sync_counter_keeps_every_cycle_and_is_reported() {
    // Two recordings joined: counters 0..9, then 0..9 again, time going on at 50 ms.
    let mut frames = traffic(10, 0);
    frames.extend(later(traffic(10, 0), 10 * 50_000));
    let (out, stats) = assemble(&frames);
    assert_eq!(out.len(), 20, "every cycle of both recordings is delivered");
    assert!(out.iter().all(AssembledFrame::is_complete));
    let cycles: Vec<u64> = out.iter().map(|f| f.cycle).collect();
    assert!(cycles.windows(2).all(|w| w[1] == w[0] + 1), "{cycles:?}");
    assert_eq!(
        out[10].values,
        expected_values(0),
        "the second recording's own readings"
    );
    assert_eq!(
        (stats.counter_resets, stats.late, stats.skipped),
        (2, 0, 0),
        "one restart per bus"
    );
    let r = stats.last_reset.unwrap();
    assert_eq!((r.from, r.to, r.cycle), (9, 0, 10));
}

#[test]
fn a_counter_jumping_faster_than_time_is_a_restart_and_lost_syncs_are_not() {
    // The counter jumps from 4 to 100 in one period: a restart, numbered on by time.
    let mut frames = traffic(5, 0);
    frames.extend(later(traffic(5, 100), 5 * 50_000));
    let (out, stats) = assemble(&frames);
    assert_eq!(out.len(), 10);
    assert_eq!(out.last().unwrap().cycle, 9);
    assert_eq!(stats.counter_resets, 2);
    // Cycles 5 to 7 never sent: the counter moves by 4 in four periods, which is loss, not a
    // restart, and the lost cycles are counted as skipped.
    let mut frames = traffic(5, 0);
    frames.extend(
        traffic(10, 0)
            .into_iter()
            .filter(|f| f.time_us >= 1_000_000 + 8 * 50_000),
    );
    let (out, stats) = assemble(&frames);
    let cycles: Vec<u64> = out.iter().map(|f| f.cycle).collect();
    assert_eq!(cycles, [0, 1, 2, 3, 4, 8, 9]);
    assert_eq!((stats.counter_resets, stats.skipped), (0, 3));
}

#[test]
fn timestamps_that_go_back_are_counted_and_the_frames_kept() {
    let mut frames = traffic(3, 0);
    frames[2].time_us = 10; // a data frame of cycle 0, stamped long before the sync before it
    let (out, stats) = assemble(&frames);
    assert_eq!(stats.time_backwards, 1);
    assert_eq!(out.len(), 3);
    assert!(
        out.iter().all(AssembledFrame::is_complete),
        "the frame was kept in its cycle"
    );
    assert_eq!(out[0].values, expected_values(0));
}

#[test]
fn module_slots_cover_the_frame_in_order() {
    // Each module's slots follow the last one's, as the assembled frame's columns do; a module
    // with unused slots takes only the used ones.
    let map = map();
    let ids = map.taxel_ids();
    let mut next = 0;
    for (b, m, slots) in map.module_slots() {
        assert_eq!(slots.start, next, "{}:{}", map.buses[b].interface, m.address);
        let used: Vec<u32> = m.taxels.iter().filter(|&&t| t >= 0).map(|&t| t as u32).collect();
        assert_eq!(ids[slots.clone()].iter().map(|t| t.0).collect::<Vec<_>>(), used);
        next = slots.end;
    }
    assert_eq!(next, ids.len());
    assert_eq!(map.slot_count(), ids.len());
}
