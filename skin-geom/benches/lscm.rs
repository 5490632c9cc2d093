//! LSCM flattening of meshes of about 700, 3,500, 20,000 and 100,000 vertices.
//!
//! `cargo bench -p skin-geom --bench lscm` also writes each mesh to `target/bench-data/lscm_N.obj`
//! with its two pinned vertices in `lscm_N.pins`, so that `bench/lscm_libigl.py` times libigl's
//! `igl.lscm` on exactly the same problems (see BENCHMARKS.md).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test or bench

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{Point2, Point3};
use skin_geom::Lscm;
use std::fmt::Write as _;
use std::path::PathBuf;

/// A wavy (not developable) patch: `rows x cols` vertices 8 mm apart, split into triangles.
fn wavy_patch(rows: usize, cols: usize) -> (Vec<Point3<f64>>, Vec<[usize; 3]>) {
    let mut v = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            let jitter = ((r * 7919 + c * 104_729) % 1000) as f64 / 1000.0 - 0.5;
            let (x, y) = (
                (c as f64 + 0.2 * jitter) * 0.008,
                (r as f64 - 0.2 * jitter) * 0.008,
            );
            v.push(Point3::new(x, y, 0.03 * (x / 0.05).sin() * (y / 0.07).cos()));
        }
    }
    let mut f = Vec::with_capacity(2 * (rows - 1) * (cols - 1));
    for r in 0..rows - 1 {
        for c in 0..cols - 1 {
            let i = r * cols + c;
            if (r + c) % 2 == 0 {
                f.push([i, i + 1, i + cols + 1]);
                f.push([i, i + cols + 1, i + cols]);
            } else {
                f.push([i, i + 1, i + cols]);
                f.push([i + 1, i + cols + 1, i + cols]);
            }
        }
    }
    (v, f)
}

fn bench_data_dir() -> PathBuf {
    let dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"))
        .join("bench-data");
    let _ = std::fs::create_dir_all(&dir);
    dir
}

fn write_obj(path: &PathBuf, v: &[Point3<f64>], f: &[[usize; 3]]) {
    let mut s = String::with_capacity(v.len() * 40 + f.len() * 24);
    for p in v {
        let _ = writeln!(s, "v {:.17e} {:.17e} {:.17e}", p.x, p.y, p.z);
    }
    for t in f {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    let _ = std::fs::write(path, s);
}

fn lscm(c: &mut Criterion) {
    let dir = bench_data_dir();
    let mut group = c.benchmark_group("lscm");
    group.sample_size(10);
    for (rows, cols) in [(26, 27), (59, 60), (141, 142), (316, 317)] {
        let (v, f) = wavy_patch(rows, cols);
        let n = v.len();
        // Opposite corners of the grid: the two boundary vertices farthest apart.
        let pins = [0, n - 1];
        let d = (v[pins[0]] - v[pins[1]]).norm();
        let pin_uv = [Point2::origin(), Point2::new(d, 0.0)];
        write_obj(&dir.join(format!("lscm_{n}.obj")), &v, &f);
        let _ = std::fs::write(
            dir.join(format!("lscm_{n}.pins")),
            format!("{} {} {d:.17e}\n", pins[0], pins[1]),
        );
        group.bench_with_input(BenchmarkId::new("full", n), &n, |b, _| {
            b.iter(|| {
                Lscm::new(n, &f, pins)
                    .and_then(|l| l.solve(&v, pin_uv))
                    .map(|uv| uv.len())
            })
        });
        let prepared = Lscm::new(n, &f, pins).expect("bench mesh is valid");
        group.bench_with_input(BenchmarkId::new("cached_symbolic", n), &n, |b, _| {
            b.iter(|| prepared.solve(&v, pin_uv).expect("LSCM solves").len())
        });
    }
    group.finish();
}

criterion_group!(benches, lscm);
criterion_main!(benches);
