//! Tactile image models run by tract: the MATLAB-exported HandsNet of ../shared/data, the
//! project's HandsNet and hand-part segmenters (fixtures/models); one image at a time on one
//! and two threads, and batches of 32; the segmenters also one image averaged over its mirror
//! images (`Segmenter::with_mirror_averaging`). bench/classify_onnxruntime.py times
//! onnxruntime on the same models in the same run.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use skin_learn::classify::{Classifier, InputScale};
use skin_learn::segment::Segmenter;
use std::hint::black_box;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    // A palm-sized blob.
    let image: Vec<u8> = (0..68 * 100)
        .map(|i| {
            let (r, col) = ((i / 100) as f64, (i % 100) as f64);
            if (r - 34.0).hypot(col - 50.0) < 18.0 {
                200
            } else {
                0
            }
        })
        .collect();
    let batch: Vec<&[u8]> = (0..32).map(|_| image.as_slice()).collect();
    let models = [
        (
            "handsnet",
            root.join("../shared/data/cyskin/HandsNet_handles_finetuned.onnx"),
            InputScale::Bytes,
        ),
        (
            "handsnet-ours",
            root.join("fixtures/models/handsnet.onnx"),
            InputScale::Unit,
        ),
        (
            "handseg",
            root.join("fixtures/models/handseg.onnx"),
            InputScale::Unit,
        ),
        (
            "handseg-wide",
            root.join("fixtures/models/handseg_wide.onnx"),
            InputScale::Unit,
        ),
    ];
    for (name, model, scale) in models {
        if !model.exists() {
            eprintln!("skipped {name}: {} not found", model.display());
            continue;
        }
        let mut group = c.benchmark_group(name);
        for threads in [1usize, 2] {
            if name.starts_with("handseg") {
                let mut net = Segmenter::load(&model, scale)
                    .unwrap()
                    .with_threads(threads)
                    .unwrap();
                group.throughput(Throughput::Elements(1));
                group.bench_function(format!("batch 1, {threads} thread(s)"), |b| {
                    b.iter(|| black_box(net.segment(black_box(&image)).unwrap()))
                });
                net.segment_batch(&batch).unwrap();
                group.throughput(Throughput::Elements(32));
                group.bench_function(format!("batch 32, {threads} thread(s)"), |b| {
                    b.iter(|| black_box(net.segment_batch(black_box(&batch)).unwrap()))
                });
                let mut net = net.with_mirror_averaging(true);
                group.throughput(Throughput::Elements(1));
                group.bench_function(format!("batch 1 over mirrors, {threads} thread(s)"), |b| {
                    b.iter(|| black_box(net.segment(black_box(&image)).unwrap()))
                });
            } else {
                let mut net = Classifier::load(&model, scale)
                    .unwrap()
                    .with_threads(threads)
                    .unwrap();
                group.throughput(Throughput::Elements(1));
                group.bench_function(format!("batch 1, {threads} thread(s)"), |b| {
                    b.iter(|| black_box(net.classify(black_box(&image)).unwrap()))
                });
                net.classify_batch(&batch).unwrap();
                group.throughput(Throughput::Elements(32));
                group.bench_function(format!("batch 32, {threads} thread(s)"), |b| {
                    b.iter(|| black_box(net.classify_batch(black_box(&batch)).unwrap()))
                });
            }
        }
        group.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
