//! The per-frame tactile image path on a 3,500-taxel link whose map is about 247 x 362 mm (the
//! thesis' forearm size): interpolation + 8-bit quantisation, the same plus erosion/dilation, and
//! a 68 x 100 px grid, each on one core.
//!
//! `cargo bench -p skin-geom --bench tactile_image` also writes the per-pixel taxel triples,
//! weights and a frame to `target/bench-data/raster_*.bin` so that `bench/image_numpy.py` times
//! numpy (sparse weights @ pressures) + OpenCV morphology on the same work, and the link's layout
//! to `target/bench-data/arm3465.json` so that `python/bench/image.py` times the Python package
//! imaging the same link (see BENCHMARKS.md).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test or bench

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Point3, Unit, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::{FlattenOptions, Grid, Normalisation, Rasterizer, TactileImager, TactileMap};
use std::io::Write as _;
use std::path::PathBuf;

/// About 3,500 taxels on a half cylinder of circumference ~247 mm and length ~362 mm.
fn arm() -> LinkSkin {
    let radius = 0.247 / std::f64::consts::PI;
    let pitch = 0.00543;
    let row_step = pitch * 3f64.sqrt() / 2.0;
    let rows = (0.362 / row_step).round() as usize;
    let cols = (0.247 / pitch).round() as usize;
    let mut taxels = Vec::with_capacity(rows * cols);
    for r in 0..rows {
        for c in 0..cols {
            let s = (c as f64 + 0.5 * (r % 2) as f64 + 0.25) * pitch - 0.247 / 2.0;
            let phi = s / radius;
            let n = Vector3::new(phi.sin(), 0.0, phi.cos());
            taxels.push(Taxel {
                id: TaxelId((r * cols + c) as u32),
                position: Point3::new(radius * n.x, r as f64 * row_step, radius * n.z),
                normal: Unit::new_normalize(n),
            });
        }
    }
    LinkSkin::new("arm", taxels)
}

fn frame(map: &TactileMap) -> Vec<f32> {
    // A palm-sized press with a soft edge, plus two fingertips.
    let centres = [(0.10, 0.12, 0.04), (0.20, 0.05, 0.008), (0.25, 0.15, 0.008)];
    map.points
        .iter()
        .map(|p| {
            centres
                .iter()
                .map(|&(u, v, r)| {
                    let d = ((p.x - u).powi(2) + (p.y - v).powi(2)).sqrt();
                    (2000.0 * (1.0 - (d - r).max(0.0) / 0.005).clamp(0.0, 1.0)) as f32
                })
                .fold(0.0, f32::max)
        })
        .collect()
}

fn bench_data() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target"))
        .join("bench-data")
}

/// The arm's layout, for `python/bench/image.py` (the Python package imaging the same link).
fn dump_layout(link: &LinkSkin) {
    let dir = bench_data();
    let _ = std::fs::create_dir_all(&dir);
    let layout = skin_core::SkinLayout {
        links: vec![link.clone()],
    };
    let _ = skin_core::format::native::write_layout(&dir.join("arm3465.json"), &layout);
}

fn dump(raster: &Rasterizer, pressures: &[f32]) {
    let dir = bench_data();
    let _ = std::fs::create_dir_all(&dir);
    let (rows, cols) = (raster.rows(), raster.cols());
    // Per pixel: three taxel indices (u32) and three weights (f32); 0 weights outside the map.
    let mut idx = Vec::with_capacity(rows * cols * 3);
    let mut w = Vec::with_capacity(rows * cols * 3);
    for r in 0..rows {
        for c in 0..cols {
            match raster.back_project(r, c) {
                Some(bp) => {
                    idx.extend(bp.taxels.map(|t| t as u32));
                    w.extend(bp.weights.map(|x| x as f32));
                }
                None => {
                    idx.extend([0u32; 3]);
                    w.extend([0f32; 3]);
                }
            }
        }
    }
    let name = format!("raster_{rows}x{cols}");
    let Ok(mut f) = std::fs::File::create(dir.join(format!("{name}.bin"))) else {
        return;
    };
    for v in [rows as u32, cols as u32, pressures.len() as u32] {
        let _ = f.write_all(&v.to_le_bytes());
    }
    for v in &idx {
        let _ = f.write_all(&v.to_le_bytes());
    }
    for v in w.iter().chain(pressures) {
        let _ = f.write_all(&v.to_le_bytes());
    }
}

/// Frames of the batch bench.
const BATCH: usize = 1000;

fn tactile_image(c: &mut Criterion) {
    let link = arm();
    dump_layout(&link);
    let map = TactileMap::flatten(&link, &FlattenOptions::default()).expect("bench layout flattens");
    let pressures = frame(&map);
    let mut raster = Rasterizer::new(&map, Grid::StepMm(1.0)).expect("grid");
    dump(&raster, &pressures);
    let mut small = Rasterizer::new(&map, Grid::Size { rows: 68, cols: 100 }).expect("grid");
    dump(&small, &pressures);
    let label = format!(
        "{} taxels, {} x {} px",
        map.ids.len(),
        raster.rows(),
        raster.cols()
    );

    let mut k = vec![0.0f32; raster.len()];
    let mut grey = vec![0u8; raster.len()];
    c.bench_function(&format!("image/interpolate+quantise ({label})"), |b| {
        b.iter(|| {
            raster
                .render_grey(&pressures, Normalisation::ContactMax, &mut k, &mut grey)
                .expect("sizes match");
            grey[grey.len() / 2]
        })
    });
    // A batch: 1,000 frames (each scaled differently) into one caller's buffer of 1,000 images,
    // the work of the Python package's `Imager.images(frames, out=...)`: each image goes to its
    // own place in 87 MB, not to one buffer that stays in cache.
    let frames: Vec<f32> = (0..BATCH)
        .flat_map(|t| {
            pressures
                .iter()
                .map(move |&p| p * (1.0 + t as f32 / BATCH as f32))
        })
        .collect();
    let mut batch_imager =
        TactileImager::new(raster.clone(), Normalisation::ContactMax, false, None).expect("imager");
    let mut images = vec![0u8; BATCH * raster.len()];
    let mut group = c.benchmark_group("image batch");
    group.sample_size(10);
    group.bench_function(format!("{BATCH} frames into one buffer ({label})"), |b| {
        b.iter(|| {
            for (f, out) in frames
                .chunks_exact(pressures.len())
                .zip(images.chunks_exact_mut(raster.len()))
            {
                batch_imager.process_into(f, out).expect("sizes match");
            }
            images[images.len() / 2]
        })
    });
    group.finish();
    let mut imager =
        TactileImager::new(raster.clone(), Normalisation::ContactMax, true, None).expect("imager");
    c.bench_function(
        &format!("image/interpolate+quantise+erode+dilate ({label})"),
        |b| b.iter(|| imager.process(&pressures).map(|g| g[g.len() / 2])),
    );
    let mut k = vec![0.0f32; small.len()];
    let mut grey = vec![0u8; small.len()];
    c.bench_function(
        &format!(
            "image/interpolate+quantise ({} taxels, 68 x 100 px)",
            map.ids.len()
        ),
        |b| {
            b.iter(|| {
                small
                    .render_grey(&pressures, Normalisation::ContactMax, &mut k, &mut grey)
                    .expect("sizes match");
                grey[grey.len() / 2]
            })
        },
    );
}

criterion_group!(benches, tactile_image);
criterion_main!(benches);
