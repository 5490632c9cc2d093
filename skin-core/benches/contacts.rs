//! Contact search on a frame the size of the thesis' full arm (3,500 taxels, 8 mm apart) with a
//! hand on it (palm and four fingertips side by side): each connected patch one contact, against
//! patches split between pressure peaks (`Separation::FINGERS`).
//!
//! `cargo bench -p skin-core --bench contacts`

#![allow(clippy::unwrap_used, clippy::expect_used)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::Point3;
use skin_core::{ContactFinder, Separation};
use std::hint::black_box;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let (cols, rows, pitch) = (70usize, 50usize, 0.008);
    let positions: Vec<Point3<f64>> = (0..rows * cols)
        .map(|i| Point3::new((i % cols) as f64 * pitch, (i / cols) as f64 * pitch, 0.0))
        .collect();
    let mut faces = Vec::new();
    for r in 0..rows - 1 {
        for k in 0..cols - 1 {
            let a = r * cols + k;
            faces.push([a, a + 1, a + cols + 1]);
            faces.push([a, a + cols + 1, a + cols]);
        }
    }
    // A palm (sigma 25 mm) and four fingertips 18 mm apart (sigma 6 mm) beyond it.
    let presses = [
        (0.28, 0.16, 800.0f32, 0.025),
        (0.226, 0.23, 1000.0, 0.006),
        (0.244, 0.235, 1000.0, 0.006),
        (0.262, 0.237, 1000.0, 0.006),
        (0.280, 0.233, 1000.0, 0.006),
    ];
    let frame: Vec<f32> = positions
        .iter()
        .map(|q| {
            presses
                .iter()
                .map(|&(x, y, peak, s)| {
                    peak * (-((q.x - x).powi(2) + (q.y - y).powi(2)) / (2.0 * s * s)).exp() as f32
                })
                .sum()
        })
        .collect();
    let mut group = c.benchmark_group(format!("contact search ({} taxels, a hand)", positions.len()));
    for (name, separation) in [
        ("connected patches", Separation::Connected),
        ("split between peaks", Separation::FINGERS),
    ] {
        let mut finder = ContactFinder::new(&positions, &[], &faces, Path::new("grid"))
            .unwrap()
            .with_separation(separation);
        let found = finder.find(&frame, 20.0, 2).unwrap().len();
        group.bench_function(format!("{name} ({found} contacts)"), |b| {
            b.iter(|| black_box(finder.find(black_box(&frame), 20.0, 2).unwrap().len()))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
