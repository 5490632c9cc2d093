//! Spatial calibration throughput: the 61-taxel patch with 350 contacts (the thesis' experiment),
//! and a 3,500-taxel arm with 2,000 and with 20,000 contacts, on one thread and on all cores.
//! Writes the datasets and the Rust side's fitted centres to target/bench-data, where
//! bench/calibration_scipy.py fits the same taxels with scipy.optimize.curve_fit.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Point3, Unit, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_learn::calibration::{CalibrationOptions, ProbeDataset, ProbeSimulator, Status, calibrate};
use std::path::Path;

/// 3,500 taxels 8 mm apart on a cylinder: 70 around (radius 89 mm) x 50 along.
fn arm() -> LinkSkin {
    let radius = 70.0 * 0.008 / std::f64::consts::TAU;
    let mut taxels = Vec::new();
    for i in 0..50 {
        for j in 0..70 {
            let phi = std::f64::consts::TAU * f64::from(j) / 70.0;
            let n = Vector3::new(phi.cos(), phi.sin(), 0.0);
            taxels.push(Taxel {
                id: TaxelId(taxels.len() as u32),
                position: Point3::from(n * radius + Vector3::z() * (0.008 * f64::from(i))),
                normal: Unit::new_normalize(n),
            });
        }
    }
    LinkSkin::new("arm", taxels)
}

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = root.join("target/bench-data");
    std::fs::create_dir_all(&out).unwrap();
    let hex = ProbeDataset::read(&root.join("fixtures/hex_patch/probes.csv")).unwrap();
    let arm = arm();
    let cases = [
        ("61 taxels x 350 contacts", "hex", hex),
        (
            "3500 taxels x 2000 contacts",
            "arm_2000",
            ProbeSimulator::default().run(&arm, 2_000, 11),
        ),
        (
            "3500 taxels x 20000 contacts",
            "arm_20000",
            ProbeSimulator::default().run(&arm, 20_000, 12),
        ),
    ];
    let options = CalibrationOptions::default();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let mut group = c.benchmark_group("calibrate");
    group.sample_size(20);
    for (name, file, dataset) in &cases {
        // The CSV as scipy will read it, and what was fitted here, to compare.
        dataset
            .write(&out.join(format!("calibration_{file}.csv")))
            .unwrap();
        let report = calibrate(dataset, &options);
        let fitted = report
            .taxels
            .iter()
            .filter(|t| t.status == Status::Fitted)
            .count();
        std::fs::write(
            out.join(format!("calibration_{file}.fitted")),
            format!("{fitted} of {} taxels fitted\n", report.taxels.len()),
        )
        .unwrap();
        group.bench_function(format!("{name}/1 thread"), |b| {
            b.iter(|| one.install(|| calibrate(dataset, &options)))
        });
        group.bench_function(format!("{name}/2 threads"), |b| {
            b.iter(|| calibrate(dataset, &options))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
