//! icub8 traffic (no sync, free-running boards) assembled by time window: exact values when every
//! board sends once per window, and honest duplicate / missing reports when a board drifts.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use proptest::prelude::*;
use skin_can::candump::{CanFrame, CandumpLog};
use skin_can::decode::Icub8;
use skin_can::decode::icub8::encode_triangle;
use skin_can::{AssembledFrame, Assembler, AssemblyStats, BusMap, ModuleRef};
use std::path::Path;

const PERIOD: u64 = 50_000;

/// Two buses: triangles 0x10, 0x11 (board 1) on can0 and 0x23 (board 2) on can1.
const MAP: &str = r#"
format = "icub8"
[[bus]]
interface = "can0"
[[bus.module]]
address = 0x10
taxels = [16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27]
[[bus.module]]
address = 0x11
taxels = [32, 33, 34, 35, 36, 37, 38, 39, 40, 41, -1, -1]
[[bus]]
interface = "can1"
[[bus.module]]
address = 0x23
taxels = [48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59]
"#;

const TRIANGLES: [(u16, u32, u64); 3] = [(0, 0x10, 3_000), (0, 0x11, 17_000), (1, 0x23, 41_000)];

fn reading(window: u64, bus: u16, address: u32, slot: usize) -> u8 {
    (255 - ((window * 7 + u64::from(bus) * 3 + u64::from(address) + slot as u64) % 200)) as u8
}

/// Every triangle once per window, at its own phase (boards are not synchronised).
fn traffic(windows: u64) -> Vec<CanFrame> {
    let mut frames = Vec::new();
    for w in 0..windows {
        for &(bus, address, phase) in &TRIANGLES {
            let readings = std::array::from_fn(|s| reading(w, bus, address, s));
            let t = 5_000_000 + w * PERIOD + phase;
            let [a, b] = encode_triangle(address, &readings, 0, 0, t, bus);
            frames.push(a);
            frames.push(CanFrame {
                time_us: t + 150,
                ..b
            });
        }
    }
    frames.sort_by_key(|f| f.time_us);
    frames
}

fn assemble(frames: &[CanFrame]) -> (Vec<AssembledFrame>, AssemblyStats) {
    let map = BusMap::parse(MAP, Path::new("icub.toml")).unwrap();
    let interfaces = vec!["can0".to_string(), "can1".to_string()];
    let mut asm = Assembler::windowed(&map, &interfaces, Icub8, PERIOD);
    let mut out = Vec::new();
    for f in frames {
        asm.push(f, &mut |a| out.push(a.clone()));
    }
    asm.finish(&mut |a| out.push(a.clone()));
    (out, asm.stats().clone())
}

fn expected(window: u64) -> Vec<Option<u16>> {
    let mut v = Vec::new();
    for &(bus, address, _) in &TRIANGLES {
        let used = if address == 0x11 { 10 } else { 12 };
        v.extend((0..used).map(|s| Some(u16::from(reading(window, bus, address, s)))));
    }
    v
}

#[test]
fn one_message_per_board_and_window_gives_exactly_the_values_written() {
    let frames = traffic(40);
    let log = CandumpLog {
        interfaces: vec!["can0".into(), "can1".into()],
        frames,
        error_frames: 0,
    };
    let log = CandumpLog::parse(&log.to_text(), Path::new("icub.log")).unwrap();
    let (out, stats) = assemble(&log.frames);
    assert_eq!(out.len(), 40);
    for (w, f) in out.iter().enumerate() {
        assert!(f.is_complete(), "window {w}: {:?}", f.missing);
        assert!(f.duplicated.is_empty());
        assert_eq!(f.cycle, w as u64);
        // Windows start at the first frame, every period.
        assert_eq!(f.time_us, 5_003_000 + w as u64 * PERIOD);
        assert_eq!(f.values, expected(w as u64), "window {w}");
    }
    assert_eq!(
        (stats.frames, stats.complete, stats.late, stats.skipped),
        (40, 40, 0, 0)
    );
}

#[test]
fn frames_of_two_buses_out_of_time_order_still_land_in_their_window() {
    // can1's frames keep their timestamps but reach the log up to 20 ms after can0's, as from a
    // slower reader thread.
    let frames = traffic(20);
    let (can0, can1): (Vec<CanFrame>, Vec<CanFrame>) = frames.iter().partition(|f| f.bus == 0);
    let mut merged = Vec::new();
    let (mut i, mut j) = (0, 0);
    while i < can0.len() || j < can1.len() {
        if j >= can1.len() || (i < can0.len() && can0[i].time_us < can1[j].time_us + 20_000) {
            merged.push(can0[i]);
            i += 1;
        } else {
            merged.push(can1[j]);
            j += 1;
        }
    }
    let (out, stats) = assemble(&merged);
    assert_eq!(stats.late, 0);
    assert_eq!(out.len(), 20);
    for (w, f) in out.iter().enumerate() {
        assert_eq!(f.values, expected(w as u64), "window {w}");
    }
}

#[test]
fn a_board_slower_than_the_window_is_reported_missing_and_a_faster_one_duplicated() {
    let map = BusMap::parse(MAP, Path::new("icub.toml")).unwrap();
    let interfaces = vec!["can0".to_string(), "can1".to_string()];
    let mut asm = Assembler::windowed(&map, &interfaces, Icub8, PERIOD);
    let mut out = Vec::new();
    let mut frames = Vec::new();
    let readings = [200u8; 12];
    // Over 2 s: 0x10 on time, 0x11 every 40 ms (faster), 0x23 every 60 ms (slower).
    for (bus, address, every, phase) in [
        (0u16, 0x10, 50_000, 0),
        (0, 0x11, 40_000, 1),
        (1, 0x23, 60_000, 2),
    ] {
        for t in (phase..2_000_000).step_by(every) {
            frames.extend(encode_triangle(address, &readings, 0, 0, 1_000_000 + t, bus));
        }
    }
    frames.sort_by_key(|f| f.time_us);
    for f in &frames {
        asm.push(f, &mut |a| out.push(a.clone()));
    }
    asm.finish(&mut |a| out.push(a.clone()));
    let fast = ModuleRef {
        bus: 0,
        address: 0x11,
    };
    let slow = ModuleRef {
        bus: 1,
        address: 0x23,
    };
    let on_time = ModuleRef {
        bus: 0,
        address: 0x10,
    };
    // The fast board sends 50 messages in 40 windows, the slow one 34.
    assert_eq!(out.len(), 40);
    let duplicated = out.iter().filter(|f| f.duplicated.contains(&fast)).count();
    let missing = out.iter().filter(|f| f.missing.contains(&slow)).count();
    assert!((8..=11).contains(&duplicated), "{duplicated}");
    assert!((5..=8).contains(&missing), "{missing}");
    assert!(
        out.iter()
            .all(|f| !f.missing.contains(&on_time) && !f.duplicated.contains(&on_time))
    );
    // The first copy is kept: values never go missing for a duplicated module.
    for f in out.iter().filter(|f| f.duplicated.contains(&fast)) {
        assert!(f.values[12..22].iter().all(|v| *v == Some(200)));
    }
}

#[test]
fn a_silent_gap_is_counted_and_a_late_frame_is_not_put_in_a_delivered_window() {
    let mut frames = traffic(10);
    frames.retain(|f| !(f.time_us >= 5_150_000 && f.time_us < 5_250_000)); // windows 3 and 4 lost
    let stale = frames[0];
    frames.push(CanFrame {
        time_us: stale.time_us,
        ..stale
    }); // window 0 again, at the end
    let (out, stats) = assemble(&frames);
    assert_eq!(
        out.iter().map(|f| f.cycle).collect::<Vec<_>>(),
        [0, 1, 2, 5, 6, 7, 8, 9]
    );
    assert_eq!(stats.skipped, 2);
    assert_eq!(stats.late, 1);
}

#[test]
fn sync_less_windows_ignore_skin16_syncs_and_other_protocols() {
    let mut frames = traffic(3);
    frames.insert(1, skin_can::decode::skin16::encode_sync(1, frames[0].time_us, 0));
    let (out, stats) = assemble(&frames);
    assert_eq!(out.len(), 3);
    assert!(out.iter().all(AssembledFrame::is_complete));
    assert_eq!(stats.ignored, 1);
}

proptest! {
    #[test]
    fn arbitrary_timestamps_never_panic_and_windows_come_in_order(
        times in proptest::collection::vec(0u64..10_000_000, 0..300),
        addresses in proptest::collection::vec(0u32..0x30, 300),
        period in 0u64..200_000,
    ) {
        let map = BusMap::parse(MAP, Path::new("icub.toml")).unwrap();
        let interfaces = vec!["can0".to_string(), "can1".to_string()];
        let mut asm = Assembler::windowed(&map, &interfaces, Icub8, period);
        let mut cycles = Vec::new();
        for (k, &t) in times.iter().enumerate() {
            let [a, b] = encode_triangle(addresses[k], &[9; 12], 0, 0, t, (k % 2) as u16);
            asm.push(&a, &mut |f| cycles.push(f.cycle));
            asm.push(&b, &mut |f| cycles.push(f.cycle));
        }
        asm.finish(&mut |f| cycles.push(f.cycle));
        prop_assert!(cycles.windows(2).all(|w| w[0] < w[1]));
    }
}
