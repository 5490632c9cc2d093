//! What the viewer costs the session: a frame of the thesis' full arm (3,495 taxels on three
//! links, a hand held on the middle one) through `Session::push`, with
//!
//! - `no viewer`: a sink that keeps nothing (the session's own cost);
//! - `viewer, no browser`: the [`ViewSink`](skin_view::ViewSink) of a serving viewer;
//! - `viewer, a browser reading`: a client reading every frame it is sent, on the other core;
//! - `viewer, stalled browser`: a client that stopped reading instead (its socket buffers full,
//!   its thread blocked in a write): the session must not notice.
//!
//! The ratio of the last two to the first is in BENCHMARKS.md ("Live view").

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use skin_learn::synth::arm::{Discard, tracking_session};
use skin_view::{Scene, Viewer};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// Connects to the stream and never reads again once the handshake is answered.
fn stalled_browser(viewer: &Viewer) -> TcpStream {
    let mut s = TcpStream::connect(viewer.addr()).unwrap();
    let host = viewer.addr();
    write!(
        s,
        "GET /stream HTTP/1.1\r\nHost: {host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
    .unwrap();
    let mut head = [0u8; 129];
    s.read_exact(&mut head).unwrap();
    assert!(head.starts_with(b"HTTP/1.1 101"));
    s
}

/// A browser reading everything it is sent, on its own thread, until the flag is cleared.
fn reading_browser(viewer: &Viewer) -> (Arc<AtomicBool>, std::thread::JoinHandle<()>) {
    let url = format!("ws://{}/stream", viewer.addr());
    let stream = TcpStream::connect(viewer.addr()).unwrap();
    let (mut ws, _) = tungstenite::client::client(url, stream).unwrap();
    let reading = Arc::new(AtomicBool::new(true));
    let go = reading.clone();
    let thread = std::thread::spawn(move || {
        while go.load(Ordering::Relaxed) {
            if ws.read().is_err() {
                break;
            }
        }
    });
    (reading, thread)
}

fn bench(c: &mut Criterion) {
    let (mut session, _, held) = tracking_session().unwrap();
    let (mut t, mut cycle) = (1_000_000u64, 100u64);
    let viewer = Viewer::bind(
        "127.0.0.1:0".parse().unwrap(),
        Scene::of_session(&session, "full arm"),
    )
    .unwrap();
    let mut sink = viewer.sink();
    let mut group = c.benchmark_group("live view/full arm frame, hand held");
    // Short enough that the stalled browser is still connected at the end of its bench (a
    // browser that takes nothing for 20 s is dropped).
    group
        .warm_up_time(std::time::Duration::from_secs(1))
        .measurement_time(std::time::Duration::from_secs(4));
    group.bench_function("no viewer", |b| {
        b.iter(|| {
            t += 20_000;
            cycle += 1;
            session.push(t, cycle, &held, &mut Discard).unwrap()
        })
    });
    group.bench_function("viewer, no browser", |b| {
        b.iter(|| {
            t += 20_000;
            cycle += 1;
            session.push(t, cycle, &held, &mut sink).unwrap()
        })
    });
    let (reading, reader) = reading_browser(&viewer);
    group.bench_function("viewer, a browser reading", |b| {
        b.iter(|| {
            t += 20_000;
            cycle += 1;
            session.push(t, cycle, &held, &mut sink).unwrap()
        })
    });
    reading.store(false, Ordering::Relaxed);
    let _ = session.push(t + 20_000, cycle + 1, &held, &mut sink).unwrap();
    reader.join().unwrap();
    let _browser = stalled_browser(&viewer);
    // Fill its socket buffers: from here on its thread is blocked in a write.
    for _ in 0..2_000 {
        t += 20_000;
        cycle += 1;
        let _ = session.push(t, cycle, &held, &mut sink).unwrap();
    }
    group.bench_function("viewer, stalled browser", |b| {
        b.iter(|| {
            t += 20_000;
            cycle += 1;
            session.push(t, cycle, &held, &mut sink).unwrap()
        })
    });
    group.finish();
    let stats = viewer.stats();
    // Still connected: the last figure is the stalled browser's, not one already dropped.
    assert_eq!(
        stats.browsers, 1,
        "the stalled browser was dropped during the bench"
    );
    eprintln!(
        "stalled browser: {} frames sent, {} skipped, {} browser(s) connected",
        stats.frames_sent, stats.frames_skipped, stats.browsers
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
