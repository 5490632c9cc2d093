//! One frame of the thesis' full arm (3,495 taxels on three links, 1,165 each) through
//! `Session::push`, the readings already in layout order: the baseline applied, contacts searched
//! on every link, touches tracked, events handed to a sink that keeps nothing. No model runs
//! (tracking only), so the figure is the session's own per-frame cost: the yardstick for a
//! binding's overhead on the same call.
//!
//! - `no contact`: an untouched arm;
//! - `hand held`: a whole hand resting on the middle link (contacts found every frame, the
//!   touch tracked, no new event).
//!
//! It also writes the arm's layout and the two frames to `target/bench-data/full_arm.json` and
//! `full_arm_frames.bin` (f32, little-endian: the idle frame then the held one, links in layout
//! order), so that `python/bench/session_push.py` pushes the same frames through the Python
//! package's `Session.push` (see BENCHMARKS.md).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use skin_core::{LinkSkin, SkinLayout};
use skin_learn::session::Session;
use skin_learn::synth::arm::{Discard, tracking_session};
use std::io::Write as _;
use std::path::PathBuf;

fn dump(links: &[LinkSkin], idle: &[Vec<f32>], held: &[Vec<f32>]) {
    let dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"))
        .join("bench-data");
    std::fs::create_dir_all(&dir).unwrap();
    let layout = SkinLayout {
        links: links.to_vec(),
    };
    skin_core::format::native::write_layout(&dir.join("full_arm.json"), &layout).unwrap();
    let mut f = std::fs::File::create(dir.join("full_arm_frames.bin")).unwrap();
    for v in idle.iter().chain(held).flatten() {
        f.write_all(&v.to_le_bytes()).unwrap();
    }
}

fn bench(c: &mut Criterion) {
    // Tracking only, the settings of `Session.from_layout`'s defaults (and of the fixture
    // session's run.toml), the baseline learned.
    let (mut session, idle, held) = tracking_session().unwrap();
    dump(session.links(), &idle, &held);
    let (mut t, mut cycle) = (1_000_000u64, 100u64);
    let mut push = |session: &mut Session, frame: &[Vec<f32>]| {
        t += 50_000;
        cycle += 1;
        session.push(t, cycle, frame, &mut Discard).unwrap()
    };
    let mut group = c.benchmark_group("session_push");
    group.bench_function("no contact", |b| b.iter(|| push(&mut session, &idle)));
    let _ = push(&mut session, &held);
    group.bench_function("hand held", |b| b.iter(|| push(&mut session, &held)));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
