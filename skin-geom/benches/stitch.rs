//! One stitching update (Eq. 6.6 per joint, warm-started), for a 2-link and a 7-link chain of
//! covers over 108 degrees of a cylinder (radius 80 mm, 8 mm pitch) joined by roll joints: about
//! 40 boundary edges per joint. Each measured cycle moves every joint by 0.5 degree, as between
//! two control cycles.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::{Deadline, FlattenOptions, JointMode, StitchOptions, Stitcher, TactileMap};
use std::hint::black_box;

const R: f64 = 0.08;
const LENGTH: f64 = 0.1;

fn link(k: usize) -> TactileMap {
    let mut taxels = Vec::new();
    for i in 0..=(LENGTH / 0.008).round() as usize {
        for c in 0..=32 {
            let s = (c as f64 + 0.5 * (i % 2) as f64) * 0.008;
            if s > 0.6 * std::f64::consts::PI * R {
                continue;
            }
            let a = s / R;
            taxels.push(Taxel {
                id: TaxelId((k * 10_000 + taxels.len()) as u32),
                position: Point3::new(R * a.cos(), 0.008 * i as f64, R * a.sin()),
                normal: Unit::new_normalize(Vector3::new(a.cos(), 0.0, a.sin())),
            });
        }
    }
    TactileMap::flatten(
        &LinkSkin::new(format!("link{k}"), taxels),
        &FlattenOptions::default(),
    )
    .unwrap()
}

/// Link k sits (LENGTH + 1 cm) further along y, rolled by `rolls[0] + ... + rolls[k - 1]`.
fn poses(rolls: &[f64]) -> Vec<Isometry3<f64>> {
    let mut out = vec![Isometry3::identity()];
    let mut roll = 0.0;
    for (k, r) in rolls.iter().enumerate() {
        roll += r;
        out.push(Isometry3::from_parts(
            Translation3::new(0.0, (k + 1) as f64 * (LENGTH + 0.01), 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), roll),
        ));
    }
    out
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("stitch");
    for links in [2usize, 7] {
        let maps: Vec<TactileMap> = (0..links).map(link).collect();
        let options = StitchOptions {
            boundary_distance: 0.02,
            ..StitchOptions::default()
        };
        let mut rolls = vec![0.0; links - 1];
        let mut st = Stitcher::new(maps, &poses(&rolls), options).unwrap();
        let first = st.update(&poses(&rolls), Deadline::Iterations(100)).unwrap();
        let edges: Vec<usize> = first.joints.iter().map(|j| j.edges).collect();
        for (j, s) in first.joints.iter().enumerate() {
            st.set_mode(
                j,
                JointMode::TranslationOnly {
                    angle: s.placement.angle,
                },
            );
        }
        println!("{links} links: edges per joint {edges:?}");
        let mut step = 0.5f64.to_radians();
        group.bench_function(format!("{links} links, warm start, translation only"), |b| {
            b.iter(|| {
                // Sweep back and forth within +-0.6 rad.
                if rolls[0].abs() > 0.6 {
                    step = -step;
                }
                for r in &mut rolls {
                    *r += step;
                }
                let report = st.update(&poses(&rolls), Deadline::Iterations(10)).unwrap();
                assert!(report.joints.iter().all(|j| j.converged && !j.kept_last));
                black_box(report)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
