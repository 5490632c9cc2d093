//! A browser that stops reading costs the session no memory: on its own in this file, so that
//! the process's resident memory is this test's alone (the other server tests run in parallel
//! in theirs).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]
#![cfg(target_os = "linux")] // resident memory is read from /proc

mod common;
use common::{browser, next_frame};

use skin_learn::session::Session;
use skin_learn::synth::arm::tracking_session;
use skin_view::{Scene, ViewSink, Viewer};
use std::io::Write;
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// Resident memory of this process, kB.
fn resident_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
        .unwrap()
}

fn push_many(session: &mut Session, sink: &mut ViewSink, frames: &[Vec<f32>], from: u64, n: u64) {
    for k in from..from + n {
        let _ = session.push(30_000_000 + k * 20_000, k, frames, sink).unwrap();
    }
}

#[test]
fn a_browser_that_stops_reading_costs_no_memory_and_others_keep_up() {
    let (mut session, _, held) = tracking_session().unwrap();
    let viewer = Viewer::bind("127.0.0.1:0".parse().unwrap(), Scene::of_session(&session, "arm")).unwrap();
    let mut sink = viewer.sink();
    // Connected, handshake answered, then never read again.
    let mut stalled = TcpStream::connect(viewer.addr()).unwrap();
    let host = viewer.addr();
    write!(
        stalled,
        "GET /stream HTTP/1.1\r\nHost: {host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
    .unwrap();
    let mut live = browser(&viewer);
    push_many(&mut session, &mut sink, &held, 0, 2_000);
    let before = resident_kb();
    push_many(&mut session, &mut sink, &held, 2_000, 20_000);
    let after = resident_kb();
    eprintln!("resident memory: {before} kB after 2,000 frames, {after} kB after 22,000 (a browser stalled)");
    // 20,000 frames of 14 KB (280 MB) went by the stalled browser: the viewer kept none.
    assert!(
        after.saturating_sub(before) < 8 * 1024,
        "resident memory grew from {before} kB to {after} kB"
    );
    // The other browser gets the newest frame, having skipped what it could not take.
    let last = 21_999;
    let mut f = next_frame(&mut live);
    let deadline = Instant::now() + Duration::from_secs(20);
    while f.head.cycle != last && Instant::now() < deadline {
        f = next_frame(&mut live);
    }
    assert_eq!(f.head.cycle, last);
    assert!(f.skipped > 0, "the reading browser was told of no skipped frame");
    drop(stalled);
    let stats = viewer.stats();
    assert!(stats.frames_skipped > 0, "{stats:?}");
}
