//! Degraded maps of the robustness study (thesis Ch. 5): the thesis grid reproduced byte for byte
//! per seed, nested decimation, no flipped triangle, blind spots that read zero.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use proptest::prelude::*;
use skin_geom::{BlindSpots, Decimation, FlattenOptions, Grid, Rasterizer, TactileMap, masked_ground_truth};
use std::collections::HashSet;
use std::path::Path;
use std::sync::OnceLock;

fn forearm() -> &'static TactileMap {
    static MAP: OnceLock<TactileMap> = OnceLock::new();
    MAP.get_or_init(|| {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm/layout.json");
        let link = skin_core::format::load_link(&path).unwrap().value;
        TactileMap::flatten(&link, &FlattenOptions::default()).unwrap()
    })
}

/// Test A's 160 maps and Test B's 70, as JSON.
fn thesis_grid() -> (Vec<String>, Vec<String>) {
    let map = forearm();
    let mut a = Vec::new();
    for spots in 1..=4 {
        for r in [10.0, 20.0, 30.0, 40.0] {
            for seed in 0..10 {
                a.push(
                    BlindSpots {
                        spots,
                        radius_mm: r,
                        seed,
                    }
                    .apply(map)
                    .unwrap()
                    .to_json(),
                );
            }
        }
    }
    let mut b = Vec::new();
    for p in 1..=7 {
        for seed in 0..10 {
            b.push(
                Decimation {
                    fraction: f64::from(p) / 10.0,
                    seed,
                }
                .apply(map)
                .unwrap()
                .to_json(),
            );
        }
    }
    (a, b)
}

#[test]
fn the_thesis_grid_is_reproduced_byte_for_byte_per_seed() {
    let (a1, b1) = thesis_grid();
    let (a2, b2) = thesis_grid();
    assert_eq!((a1.len(), b1.len()), (160, 70));
    assert!(a1 == a2 && b1 == b2, "same seeds, different maps");
    // Every pattern differs from every other.
    assert_eq!(a1.iter().collect::<HashSet<_>>().len(), 160);
    assert_eq!(b1.iter().collect::<HashSet<_>>().len(), 70);
    // Read back, a degraded map is the same map.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.json");
    std::fs::write(&path, &a1[37]).unwrap();
    let back = TactileMap::read(&path).unwrap().to_json();
    if back != a1[37] {
        let at = back
            .bytes()
            .zip(a1[37].bytes())
            .position(|(x, y)| x != y)
            .unwrap_or(0);
        panic!(
            "read back differs at byte {at}: {:?} vs {:?}",
            &back[at.saturating_sub(80)..(at + 40).min(back.len())],
            &a1[37][at.saturating_sub(80)..(at + 40).min(a1[37].len())]
        );
    }
}

#[test]
fn blind_spots_read_zero_and_nothing_else_does() {
    let map = forearm();
    let spots = BlindSpots {
        spots: 3,
        radius_mm: 30.0,
        seed: 4,
    }
    .apply(map)
    .unwrap();
    let n = spots.zeroed.len();
    assert!(n > 20 && n < map.points.len() / 2, "{n} zeroed");
    // Same centres, larger radius: a superset.
    let wider = BlindSpots {
        spots: 3,
        radius_mm: 40.0,
        seed: 4,
    }
    .apply(map)
    .unwrap();
    assert!(spots.zeroed.iter().all(|z| wider.zeroed.contains(z)) && wider.zeroed.len() > n);
    // Uniform pressure: pixels of triangles with no zeroed corner show it, those with three show 0.
    let mut r = Rasterizer::new(&spots, Grid::StepMm(1.0)).unwrap();
    let mut image = vec![0.0; r.len()];
    r.render(&vec![1000.0; map.points.len()], &mut image).unwrap();
    let dead: HashSet<usize> = spots.zeroed.iter().copied().collect();
    let (mut live, mut blind) = (0, 0);
    for row in 0..r.rows() {
        for col in 0..r.cols() {
            let Some(b) = r.back_project(row, col) else {
                continue;
            };
            let zeroed = b.taxels.iter().filter(|t| dead.contains(t)).count();
            let v = image[row * r.cols() + col];
            if zeroed == 0 {
                assert!((v - 1000.0).abs() < 0.5, "{v}");
                live += 1;
            } else if zeroed == 3 {
                assert!(v.abs() < 1e-3, "{v}");
                blind += 1;
            }
        }
    }
    assert!(live > 1000 && blind > 100, "{live} {blind}");
}

#[test]
fn decimated_maps_keep_their_skin_and_flip_nothing() {
    let map = forearm();
    for p in 1..=7 {
        for seed in 0..10 {
            let d = Decimation {
                fraction: f64::from(p) / 10.0,
                seed,
            }
            .apply(map)
            .unwrap();
            let removed = map.points.len() - d.points.len();
            assert_eq!(
                removed,
                (f64::from(p) / 10.0 * map.points.len() as f64).round() as usize
            );
            for f in &d.faces {
                let [a, b, c] = f.map(|i| d.points[i]);
                assert!(
                    (b - a).perp(&(c - a)) > 0.0,
                    "flipped or degenerate triangle at {p}0 %, seed {seed}"
                );
            }
            // Same taxels, same places: no re-flattening.
            for (id, q) in d.ids.iter().zip(&d.points) {
                let i = map.ids.iter().position(|x| x == id).unwrap();
                assert_eq!(map.points[i], *q);
            }
            // Still one usable map.
            Rasterizer::new(&d, Grid::StepMm(1.0)).unwrap();
        }
    }
    // The skin area shrinks only a little even with 70 % removed (the border loses some).
    let area = |m: &TactileMap| -> f64 {
        m.faces
            .iter()
            .map(|f| {
                let [a, b, c] = f.map(|i| m.points[i]);
                0.5 * (b - a).perp(&(c - a))
            })
            .sum()
    };
    let d = Decimation {
        fraction: 0.7,
        seed: 1,
    }
    .apply(map)
    .unwrap();
    assert!(area(&d) > 0.8 * area(map) && area(&d) <= area(map) * 1.0001);
}

#[test]
fn bad_fault_settings_are_errors() {
    let map = forearm();
    assert!(
        Decimation {
            fraction: 1.0,
            seed: 0
        }
        .apply(map)
        .is_err()
    );
    assert!(
        Decimation {
            fraction: f64::NAN,
            seed: 0
        }
        .apply(map)
        .is_err()
    );
    assert!(
        BlindSpots {
            spots: 1,
            radius_mm: -1.0,
            seed: 0
        }
        .apply(map)
        .is_err()
    );
    assert!(
        BlindSpots {
            spots: 10_000,
            radius_mm: 10.0,
            seed: 0
        }
        .apply(map)
        .is_err()
    );
}

#[test]
fn the_ground_truth_keeps_what_both_images_show() {
    let image = [0u8, 10, 200, 255, 90];
    let labels = [3u8, 3, 0, 6, 2];
    let (i, l) = masked_ground_truth(&image, &labels, 20).unwrap();
    assert_eq!(i, [0, 0, 0, 255, 90]);
    assert_eq!(l, [0, 0, 0, 6, 2]);
    assert!(masked_ground_truth(&image, &labels[..2], 20).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn decimation_levels_are_nested(seed in any::<u64>(), a in 0.0f64..0.95, b in 0.0f64..0.95, n in 3usize..3000) {
        let (lo, hi) = if a < b { (a, b) } else { (b, a) };
        let fewer = Decimation { fraction: hi, seed }.survivors(n).unwrap();
        let more: HashSet<usize> = Decimation { fraction: lo, seed }.survivors(n).unwrap().into_iter().collect();
        prop_assert!(fewer.iter().all(|i| more.contains(i)));
    }
}

#[test]
fn a_dead_taxel_is_imaged_across_not_as_a_hole() {
    let map = forearm();
    // An interior taxel: the one nearest the map's centre.
    let (lo, hi) = map.bounds();
    let centre = nalgebra::Point2::from((lo.coords + hi.coords) / 2.0);
    let dead = (0..map.points.len())
        .min_by(|&a, &b| {
            (map.points[a] - centre)
                .norm()
                .total_cmp(&(map.points[b] - centre).norm())
        })
        .unwrap();
    let without = skin_geom::DeadTaxels::new(&[dead], map.ids.len())
        .remove_from(map)
        .unwrap();
    assert_eq!(without.ids.len(), map.ids.len() - 1);
    assert!(!without.ids.contains(&map.ids[dead]));
    assert_eq!(without.report.distortion.flipped_faces, 0);
    // The same pressure everywhere: over the map without the dead taxel the image stays that
    // pressure at the dead taxel's place; over the full map, the dead taxel read 0 dips there.
    let pixel_at = |m: &TactileMap, values: &[f32]| {
        let mut r = Rasterizer::new(m, Grid::StepMm(1.0)).unwrap();
        let mut image = vec![0.0f32; r.len()];
        r.render(values, &mut image).unwrap();
        let (row, col) = r.pixel_of(map.points[dead]).unwrap();
        image[row * r.cols() + col]
    };
    let mut holed = vec![100.0f32; map.ids.len()];
    holed[dead] = 0.0;
    assert!(
        pixel_at(map, &holed) < 50.0,
        "the full map shows the dead taxel as a dip"
    );
    let across = pixel_at(&without, &vec![100.0f32; without.ids.len()]);
    assert!((across - 100.0).abs() < 1e-3, "{across}");
    // Nothing dead: the same taxels; indices out of range are ignored.
    assert_eq!(
        skin_geom::DeadTaxels::new(&[usize::MAX], map.ids.len())
            .remove_from(map)
            .unwrap()
            .ids,
        map.ids
    );
    // Bridged in place: every taxel keeps its index, the dead one is in no triangle, and the
    // image over the map, with the dead taxel reading 0, shows no dip.
    let bridged = skin_geom::DeadTaxels::new(&[dead], map.ids.len())
        .bridge_in(map)
        .unwrap();
    assert_eq!((&bridged.ids, &bridged.points), (&map.ids, &map.points));
    assert!(bridged.faces.iter().all(|f| !f.contains(&dead)));
    assert_eq!(bridged.faces.len(), without.faces.len());
    let across = pixel_at(&bridged, &holed);
    assert!((across - 100.0).abs() < 1e-3, "{across}");
}
