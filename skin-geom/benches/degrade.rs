//! Test B's taxel removal (`skin degrade --remove`) on maps of 10,000 to 100,000 taxels: one
//! Delaunay of the survivors and a point-in-skin test per new triangle, near-linear.
//!
//! `cargo bench -p skin-geom --bench degrade`

#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used)] // a bench's set-up may stop it

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::Point2;
use skin_core::TaxelId;
use skin_geom::{Decimation, TactileMap};

/// A flat map of about `n` taxels on a 4 mm jittered grid, with a hole in the middle and a
/// concave notch, so that the on-skin test has something to reject.
fn map(n: usize) -> TactileMap {
    let cols = ((n as f64 * 1.5).sqrt()) as usize;
    let rows = n / cols;
    let mut points = Vec::with_capacity(rows * cols);
    for j in 0..rows {
        for i in 0..cols {
            let jitter = 0.0008 * ((i * 7 + j * 13) as f64).sin();
            points.push(Point2::new(0.004 * i as f64 + jitter, 0.004 * j as f64 - jitter));
        }
    }
    let hole = |i: usize, j: usize| {
        let (ci, cj) = (cols / 2, rows / 2);
        i.abs_diff(ci) < cols / 8 && j.abs_diff(cj) < rows / 8 || (i < cols / 4 && j > rows * 3 / 4)
    };
    let mut faces = Vec::with_capacity(2 * rows * cols);
    for j in 0..rows - 1 {
        for i in 0..cols - 1 {
            if hole(i, j) {
                continue;
            }
            let k = j * cols + i;
            faces.push([k, k + 1, k + cols + 1]);
            faces.push([k, k + cols + 1, k + cols]);
        }
    }
    TactileMap {
        name: "grid".into(),
        ids: (0..points.len() as u32).map(TaxelId).collect(),
        positions: Vec::new(),
        points,
        faces,
        report: Default::default(),
        zeroed: Vec::new(),
    }
}

fn degrade(c: &mut Criterion) {
    let mut group = c.benchmark_group("degrade");
    group.sample_size(10);
    for n in [10_000, 40_000, 100_000] {
        let m = map(n);
        let remove = Decimation {
            fraction: 0.5,
            seed: 1,
        };
        group.bench_with_input(BenchmarkId::new("remove 0.5", n), &n, |b, _| {
            b.iter(|| remove.apply(&m).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, degrade);
criterion_main!(benches);
