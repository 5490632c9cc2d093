//! What a dataset costs a session, per frame of the thesis' full arm (3,495 taxels on three
//! links): the session alone (events collected), and the session writing an episode (every
//! frame's raw readings, its events and contacts, Parquet a row group at a time). One hour at
//! 50 Hz is 180,000 frames: the second figure times 180,000 is an hour's export on one core
//! (BENCHMARKS.md, "Datasets at scale"; `examples/export_hour.rs` runs the whole hour).
//!
//!     cargo bench -p skin-dataset --bench export

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use skin_dataset::{Dataset, DatasetOptions};
use skin_learn::session::Event;
use skin_learn::synth::arm;
use std::hint::black_box;

/// The arm's frame `k`: untouched with ±1 count of noise, a hand held one second in four.
fn frame(k: u64, idle: &arm::Readings, held: &arm::Readings, out: &mut arm::Readings, state: &mut u64) {
    let source = if (k / 50) % 4 == 3 { held } else { idle };
    for (dst, src) in out.iter_mut().zip(source) {
        for (d, s) in dst.iter_mut().zip(src) {
            *state ^= *state << 13;
            *state ^= *state >> 7;
            *state ^= *state << 17;
            *d = s + (*state % 3) as f32 - 1.0;
        }
    }
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("export per frame, full arm (3495 taxels)");
    group.sample_size(20);
    group.measurement_time(std::time::Duration::from_secs(4));

    let (mut session, idle, held) = arm::tracking_session().expect("the arm");
    let mut readings = idle.clone();
    let (mut k, mut state) = (0u64, 0x9e37_79b9_7f4a_7c15_u64);
    let mut events: Vec<Event> = Vec::new();
    group.bench_function("session alone", |b| {
        b.iter(|| {
            frame(k, &idle, &held, &mut readings, &mut state);
            events.clear();
            let _ = session
                .push(k * 20_000, k, &readings, &mut events)
                .expect("frame");
            k += 1;
            black_box(events.len())
        });
    });

    let tmp = tempfile::tempdir().expect("tmp");
    let (mut session, idle, held) = arm::tracking_session().expect("the arm");
    let mut dataset = Dataset::create(
        &tmp.path().join("ds"),
        DatasetOptions::default(),
        &skin_core::output::Inputs::new::<&std::path::Path>([]),
    )
    .expect("dataset");
    let mut episode = dataset
        .episode(&session, "bench".as_ref(), "-", "synthetic")
        .expect("episode");
    let (mut k, mut state) = (0u64, 0x9e37_79b9_7f4a_7c15_u64);
    group.bench_function("session + dataset episode", |b| {
        b.iter(|| {
            frame(k, &idle, &held, &mut readings, &mut state);
            let _ = session
                .push(k * 20_000, k, &readings, &mut episode)
                .expect("frame");
            k += 1;
        });
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
