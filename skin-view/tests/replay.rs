//! Replaying an MCAP file skin wrote (feature `mcap`): a damaged file is named chunk by chunk
//! and the page is told which stretch cannot be trusted, an intact one plays as before; the
//! page's controls are shared, and one with a value out of range is refused with a message
//! while the stream goes on.

#![cfg(feature = "mcap")]
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use skin_core::output::Inputs;
use skin_learn::synth::arm::tracking_session;
use skin_ros::{McapOutlet, RosOptions, RosSink};
use skin_view::Viewer;
use skin_view::replay::Replay;
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use tungstenite::{Message, WebSocket};

/// Frames written: the full arm's (three links, about 210 kB of messages a frame), so that the
/// file is written in several chunks.
const FRAMES: u64 = 40;

/// An MCAP file of the full arm's session (idle, a hand held, idle again) written by skin-ros, as
/// `skin run --mcap` writes one.
fn session_mcap(dir: &Path) -> PathBuf {
    let path = dir.join("session.mcap");
    let (mut session, idle, held) = tracking_session().unwrap();
    let topics = RosOptions::default().topics(session.links()).unwrap();
    let outlet = McapOutlet::create(&path, &topics, &Inputs::default()).unwrap();
    let mut sink = RosSink::new(session.links(), topics, outlet);
    for k in 0..FRAMES {
        let frame = if (10..25).contains(&k) { &held } else { &idle };
        let _ = session
            .push(1_000_000 + k * 20_000, 100 + k, frame, &mut sink)
            .unwrap();
    }
    sink.into_outlet().finish().unwrap();
    path
}

/// Where each chunk's data lies in `bytes` (from the file's own index).
fn chunk_data(bytes: &[u8]) -> Vec<std::ops::Range<usize>> {
    let summary = mcap::Summary::read(bytes).unwrap().unwrap();
    let mut chunks: Vec<_> = summary.chunk_indexes.iter().collect();
    chunks.sort_by_key(|c| c.chunk_start_offset);
    chunks
        .iter()
        .map(|c| {
            let start = usize::try_from(c.compressed_data_offset().unwrap()).unwrap();
            start..start + usize::try_from(c.compressed_size).unwrap()
        })
        .collect()
}

#[test]
fn an_intact_file_has_no_damage() {
    let dir = tempfile::tempdir().unwrap();
    let replay = Replay::open(&session_mcap(dir.path()), 5.0).unwrap();
    assert!(
        replay.chunks() > 2,
        "{} chunks: the test needs several",
        replay.chunks()
    );
    assert!(replay.damaged().is_empty(), "{:?}", replay.damaged());
    let info = replay.scene().replay.as_ref().unwrap();
    assert!(info.damaged.is_empty());
    // From the session's start (its first event's time 0) to the last frame, 1.78 s.
    assert!((replay.duration() - 1.78).abs() < 0.05, "{}", replay.duration());
}

#[test]
fn a_chunk_whose_bytes_fail_their_crc_is_named_with_its_time_span() {
    let dir = tempfile::tempdir().unwrap();
    let path = session_mcap(dir.path());
    let mut bytes = std::fs::read(&path).unwrap();
    let chunks = chunk_data(&bytes);
    // One byte in the middle of the second chunk's data: inside a pressure cloud's floats, so
    // the chunk's records still read and only its CRC tells.
    let at = (chunks[1].start + chunks[1].end) / 2;
    bytes[at] ^= 0x40;
    let bad = dir.path().join("bad.mcap");
    std::fs::write(&bad, &bytes).unwrap();
    let replay = Replay::open(&bad, 5.0).unwrap();
    let damaged = replay.damaged();
    assert_eq!(damaged.len(), 1, "{damaged:?}");
    let d = &damaged[0];
    assert_eq!(d.number, 2);
    assert!(d.readable, "{d}");
    assert!(d.why.contains("CRC"), "{d}");
    assert!(
        d.from >= 0.0 && d.to >= d.from && d.to <= replay.duration() + 1e-9,
        "{d}"
    );
    // The page is told the same stretch.
    let info = replay.scene().replay.as_ref().unwrap();
    assert_eq!(info.damaged.len(), 1);
    assert_eq!(info.damaged[0].chunks, vec![2]);
    assert!(!info.damaged[0].left_out);
    assert_eq!((info.damaged[0].from, info.damaged[0].to), (d.from, d.to));
    // Said in words that name the chunk, where it is and when.
    let text = d.to_string();
    assert!(text.starts_with("chunk 2 (bytes "), "{text}");
    assert!(text.contains("cannot be trusted"), "{text}");
}

#[test]
fn a_chunk_whose_records_cannot_be_read_is_left_out_and_the_rest_plays() {
    let dir = tempfile::tempdir().unwrap();
    let path = session_mcap(dir.path());
    let mut bytes = std::fs::read(&path).unwrap();
    let chunks = chunk_data(&bytes);
    // The first record's length in the third chunk: its records no longer line up.
    bytes[chunks[2].start + 5] ^= 0x7f;
    let bad = dir.path().join("bad.mcap");
    std::fs::write(&bad, &bytes).unwrap();
    let replay = Replay::open(&bad, 5.0).unwrap();
    let damaged = replay.damaged();
    assert_eq!(damaged.len(), 1, "{damaged:?}");
    assert_eq!(damaged[0].number, 3);
    assert!(!damaged[0].readable, "{}", damaged[0]);
    assert!(damaged[0].to_string().contains("left out"), "{}", damaged[0]);
    let info = replay.scene().replay.as_ref().unwrap();
    assert!(info.damaged[0].left_out);
    // The others are played through to the end; the left-out chunk's frames are not.
    let (sent, skipped) = play_to_the_end(replay);
    assert!(
        sent > 0 && sent + skipped < FRAMES,
        "{sent} frames sent, {skipped} skipped"
    );
}

#[test]
fn bytes_flipped_anywhere_are_named_or_refused_never_played_in_silence() {
    let dir = tempfile::tempdir().unwrap();
    let path = session_mcap(dir.path());
    let intact = std::fs::read(&path).unwrap();
    let chunks = chunk_data(&intact);
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |n: usize| {
        // xorshift: a fixed sequence, the same every run.
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        usize::try_from(state % n as u64).unwrap()
    };
    for round in 0..6 {
        let mut bytes = intact.clone();
        for _ in 0..200 {
            let at = next(bytes.len());
            bytes[at] ^= 1 << next(8);
        }
        let bad = dir.path().join(format!("bad{round}.mcap"));
        std::fs::write(&bad, &bytes).unwrap();
        let touched = chunks
            .iter()
            .filter(|c| bytes[(*c).clone()] != intact[(*c).clone()])
            .count();
        match Replay::open(&bad, 5.0) {
            Ok(replay) => assert!(
                replay.damaged().len() >= touched,
                "round {round}: {touched} chunks changed, {} named",
                replay.damaged().len()
            ),
            // The header or the summary was hit: refused, naming the file.
            Err(e) => assert!(e.to_string().contains("bad"), "round {round}: {e}"),
        }
    }
}

/// A browser on the replay's stream.
fn browser(viewer: &Viewer) -> WebSocket<TcpStream> {
    common::browser(viewer)
}

/// The next text message that has `key`.
fn next_with(ws: &mut WebSocket<TcpStream>, key: &str) -> serde_json::Value {
    loop {
        if let Message::Text(t) = ws.read().unwrap() {
            let v: serde_json::Value = serde_json::from_str(t.as_str()).unwrap();
            if v.get(key).is_some() {
                return v;
            }
        }
    }
}

/// Plays `replay` to its end at 100 times real time; the frames a browser was sent, and those
/// it skipped (a newer one was ready by the time it could take one).
fn play_to_the_end(mut replay: Replay) -> (u64, u64) {
    replay.set_speed(100.0).unwrap();
    let viewer = Viewer::bind("127.0.0.1:0".parse().unwrap(), replay.scene().clone()).unwrap();
    let controls = viewer.controls();
    let stop = AtomicBool::new(false);
    let mut ws = browser(&viewer);
    std::thread::scope(|s| {
        let (r, v, st) = (&mut replay, &viewer, &stop);
        let player = s.spawn(move || r.play(v, &controls, st));
        // Paused by the replay itself at its end (not by a browser).
        loop {
            let v = next_with(&mut ws, "status");
            if v["status"]["paused"] == true {
                assert!(v["status"]["by"].is_null(), "{v}");
                break;
            }
        }
        stop.store(true, Ordering::Relaxed);
        player.join().unwrap().unwrap();
    });
    (viewer.stats().frames_sent, viewer.stats().frames_skipped)
}

#[test]
fn a_seek_out_of_range_is_refused_with_a_message_and_the_controls_are_shared() {
    let dir = tempfile::tempdir().unwrap();
    let mut replay = Replay::open(&session_mcap(dir.path()), 5.0).unwrap();
    let viewer = Viewer::bind("127.0.0.1:0".parse().unwrap(), replay.scene().clone()).unwrap();
    let controls = viewer.controls();
    let stop = AtomicBool::new(false);
    let mut one = browser(&viewer);
    let mut two = browser(&viewer);
    let me = next_with(&mut one, "you")["you"].as_u64().unwrap();
    let other = next_with(&mut two, "you")["you"].as_u64().unwrap();
    assert_ne!(me, other);
    std::thread::scope(|s| {
        let (r, v, st) = (&mut replay, &viewer, &stop);
        let player = s.spawn(move || r.play(v, &controls, st));
        for bad in [r#"{"cmd":"seek","time":-1}"#, r#"{"cmd":"speed","value":1000}"#] {
            one.send(Message::Text(bad.into())).unwrap();
            let why = next_with(&mut one, "refused");
            let why = why["refused"].as_str().unwrap();
            assert!(why.contains("got -1") || why.contains("got 1000"), "{why}");
        }
        // The stream goes on: a good control is taken, and every browser is told who sent it.
        one.send(Message::Text(r#"{"cmd":"pause"}"#.into())).unwrap();
        for ws in [&mut one, &mut two] {
            loop {
                let v = next_with(ws, "status");
                if v["status"]["paused"] == true {
                    assert_eq!(v["status"]["by"].as_u64(), Some(me), "{v}");
                    break;
                }
            }
        }
        stop.store(true, Ordering::Relaxed);
        player.join().unwrap().unwrap();
    });
    assert_eq!(viewer.stats().dropped, 0, "{:?}", viewer.stats());
    // The library takes the speeds the page does, and refuses others.
    assert!(replay.set_speed(0.0).is_err() && replay.set_speed(f64::NAN).is_err());
    replay.set_speed(*skin_view::SPEEDS.end()).unwrap();
}
