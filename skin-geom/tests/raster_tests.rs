//! Tactile images: barycentric interpolation (thesis Sec. 3.3), grey levels (eq. 3.1),
//! morphology and resizing against independent implementations, and back-projection.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test or bench

use nalgebra::{Point2, Point3, Unit, Vector3};
use proptest::prelude::*;
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::to_grey;
use skin_geom::{FlattenOptions, Grid, Normalisation, Rasterizer, Resizer, TactileImager, TactileMap};

/// A half-cylinder link of radius 60 mm with ~8 mm pitch.
fn arm() -> TactileMap {
    let mut taxels = Vec::new();
    for r in 0..16 {
        for c in 0..22 {
            let phi = -1.5 + 3.0 * (c as f64 + 0.5 * (r % 2) as f64) / 22.0;
            let n = Vector3::new(phi.sin(), 0.0, phi.cos());
            taxels.push(Taxel {
                id: TaxelId(r * 22 + c),
                position: Point3::new(0.06 * n.x, 0.008 * r as f64, 0.06 * n.z),
                normal: Unit::new_normalize(n),
            });
        }
    }
    TactileMap::flatten(&LinkSkin::new("arm", taxels), &FlattenOptions::default()).unwrap()
}

#[test]
fn constant_pressure_gives_a_constant_image_inside_and_zero_outside() {
    let map = arm();
    let mut raster = Rasterizer::new(&map, Grid::StepMm(1.0)).unwrap();
    let mut k = vec![f32::NAN; raster.len()];
    raster.render(&vec![250.0; map.ids.len()], &mut k).unwrap();
    let inside = k.iter().filter(|&&v| v != 0.0).count();
    assert_eq!(inside, raster.covered());
    assert!(k.iter().all(|&v| v == 0.0 || (v - 250.0).abs() < 1e-3));
    // The map covers most of its bounding box (it is rotated onto its principal axes).
    assert!(raster.covered() as f64 > 0.8 * raster.len() as f64);
    // A pixel is inside exactly when its centre is in a map triangle.
    for r in (0..raster.rows()).step_by(7) {
        for c in (0..raster.cols()).step_by(5) {
            let x = raster.pixel_centre(r, c);
            let inside = map.faces.iter().any(|f| {
                let p = f.map(|t| map.points[t]);
                let s = |a: Point2<f64>, b: Point2<f64>| (b - a).perp(&(x - a));
                s(p[0], p[1]) > 1e-12 && s(p[1], p[2]) > 1e-12 && s(p[2], p[0]) > 1e-12
            });
            if inside {
                assert!(
                    k[r * raster.cols() + c] != 0.0,
                    "pixel ({r}, {c}) is inside the map"
                );
            }
        }
    }
}

#[test]
fn a_linear_pressure_field_is_reproduced_exactly() {
    let map = arm();
    let mut raster = Rasterizer::new(&map, Grid::StepMm(0.7)).unwrap();
    let field = |p: Point2<f64>| 100.0 + 2000.0 * p.x - 1500.0 * p.y;
    let pressures: Vec<f32> = map.points.iter().map(|&p| field(p) as f32).collect();
    let mut k = vec![0.0; raster.len()];
    raster.render(&pressures, &mut k).unwrap();
    let mut checked = 0;
    for r in 0..raster.rows() {
        for c in 0..raster.cols() {
            let v = k[r * raster.cols() + c];
            if raster.back_project(r, c).is_some() {
                let expect = field(raster.pixel_centre(r, c));
                assert!(
                    (f64::from(v) - expect).abs() < 1e-3 * expect.abs().max(1.0),
                    "({r}, {c}): {v} vs {expect}"
                );
                checked += 1;
            } else {
                assert_eq!(v, 0.0);
            }
        }
    }
    assert!(checked > 1000);
}

#[test]
fn weights_are_the_thesis_sub_triangle_area_ratios() {
    // K = (A_kj p_h + A_hj p_k + A_hk p_j) / A, with the areas computed directly.
    let map = arm();
    let raster = Rasterizer::new(&map, Grid::StepMm(1.0)).unwrap();
    let area = |a: Point2<f64>, b: Point2<f64>, c: Point2<f64>| 0.5 * ((b - a).perp(&(c - a))).abs();
    let mut seen = 0;
    for (r, c) in [(10, 10), (40, 100), (80, 50), (100, 200), (20, 150)] {
        let Some(bp) = raster.back_project(r, c) else {
            continue;
        };
        let [j, k, h] = bp.taxels.map(|t| map.points[t]);
        let x = raster.pixel_centre(r, c);
        let a = area(j, k, h);
        let expect = [area(k, h, x) / a, area(h, j, x) / a, area(j, k, x) / a];
        for (w, e) in bp.weights.iter().zip(expect) {
            assert!((w - e).abs() < 1e-6, "{:?} vs {expect:?}", bp.weights);
        }
        seen += 1;
    }
    assert!(seen >= 3);
}

#[test]
fn back_projection_lands_on_the_mesh() {
    let map = arm();
    let raster = Rasterizer::new(&map, Grid::StepMm(2.0)).unwrap();
    let mut n = 0;
    for r in 0..raster.rows() {
        for c in 0..raster.cols() {
            let Some(bp) = raster.back_project(r, c) else {
                continue;
            };
            let x = bp.point.unwrap();
            let [a, b, d] = bp.taxels.map(|t| map.positions[t]);
            // On the triangle's plane...
            let normal = (b - a).cross(&(d - a)).normalize();
            assert!((x - a).dot(&normal).abs() < 1e-12);
            // ...and inside it: the weights are its barycentric coordinates.
            assert!(bp.weights.iter().all(|&w| (-1e-7..=1.0 + 1e-7).contains(&w)));
            assert!((bp.weights.iter().sum::<f64>() - 1.0).abs() < 1e-6);
            // The point is on the cylinder of radius 60 mm up to the chord sag.
            let radial = (x.x * x.x + x.z * x.z).sqrt();
            assert!(radial <= 0.06 + 1e-9 && radial > 0.0595, "{radial}");
            n += 1;
        }
    }
    assert!(n > 100);
    assert!(raster.back_project(raster.rows(), 0).is_none());
}

#[test]
fn the_fused_grey_path_matches_render_then_to_grey() {
    let map = arm();
    let mut raster = Rasterizer::new(&map, Grid::StepMm(1.0)).unwrap();
    let pressures: Vec<f32> = map
        .points
        .iter()
        .map(|p| (1000.0 * (p.x * 40.0).sin().abs() * (p.y * 25.0).cos().abs()) as f32)
        .collect();
    let mut k = vec![0.0; raster.len()];
    let mut k2 = vec![0.0; raster.len()];
    let mut g = vec![0u8; raster.len()];
    let mut g2 = vec![0u8; raster.len()];
    raster.render(&pressures, &mut k).unwrap();
    to_grey(&k, Normalisation::FullScale(1000.0), &mut g);
    raster
        .render_grey(&pressures, Normalisation::FullScale(1000.0), &mut k2, &mut g2)
        .unwrap();
    assert!(k == k2, "the fused pass computes other pressures");
    assert!(g == g2, "the fused pass computes other grey levels");
    // Contact maximum: the largest taxel reading maps to 255.
    let peak = pressures.iter().copied().fold(0.0f32, f32::max);
    raster
        .render_grey(&pressures, Normalisation::ContactMax, &mut k2, &mut g2)
        .unwrap();
    to_grey(&k, Normalisation::FullScale(peak), &mut g);
    assert!(g == g2, "contact maximum is not the largest taxel reading");
}

#[test]
fn grey_levels_follow_eq_3_1() {
    let k = [0.0f32, 99.0, 100.0, 50.0, 200.0, -5.0, 0.3921];
    let mut g = [0u8; 7];
    to_grey(&k, Normalisation::FullScale(100.0), &mut g);
    assert_eq!(g, [0, 252, 255, 127, 255, 0, 0]);
    to_grey(&k, Normalisation::ContactMax, &mut g);
    assert_eq!(g, [0, 126, 127, 63, 255, 0, 0]);
    to_grey(&[0.0; 7], Normalisation::ContactMax, &mut g);
    assert_eq!(g, [0; 7]);
}

fn disk(radius: u8) -> imageproc::morphology::Mask {
    let r = i32::from(radius);
    let side = 2 * radius as u32 + 1;
    let img = image::GrayImage::from_fn(side, side, |x, y| {
        let (dx, dy) = (x as i32 - r, y as i32 - r);
        image::Luma([if dx * dx + dy * dy <= r * r { 255 } else { 0 }])
    });
    imageproc::morphology::Mask::from_image(&img, radius, radius)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn erosion_and_dilation_match_imageproc(rows in 1usize..30, cols in 1usize..30, seed in any::<u64>(), radius in 1usize..5) {
        let mut s = seed | 1;
        let src: Vec<u8> = (0..rows * cols).map(|_| { s ^= s << 13; s ^= s >> 7; s ^= s << 17; (s >> 56) as u8 }).collect();
        let img = image::GrayImage::from_raw(cols as u32, rows as u32, src.clone()).unwrap();
        let mask = disk(radius as u8);
        let eroded = imageproc::morphology::grayscale_erode(&img, &mask);
        let dilated = imageproc::morphology::grayscale_dilate(&img, &mask);
        prop_assert_eq!(skin_geom::erode_disk(&src, rows, cols, radius), eroded.into_raw());
        prop_assert_eq!(skin_geom::dilate_disk(&src, rows, cols, radius), dilated.into_raw());
    }

    #[test]
    fn resizing_matches_the_image_crate_triangle_filter(rows in 8usize..120, cols in 8usize..120, out_r in 4usize..70, out_c in 4usize..70, seed in any::<u64>()) {
        let mut s = seed | 1;
        let src: Vec<u8> = (0..rows * cols).map(|_| { s ^= s << 13; s ^= s >> 7; s ^= s << 17; (s >> 60) as u8 * 16 }).collect();
        let img = image::GrayImage::from_raw(cols as u32, rows as u32, src.clone()).unwrap();
        let reference = image::imageops::resize(&img, out_c as u32, out_r as u32, image::imageops::FilterType::Triangle);
        let mut ours = vec![0u8; out_r * out_c];
        Resizer::new(rows, cols, out_r, out_c).unwrap().resize(&src, &mut ours);
        let worst = ours.iter().zip(reference.as_raw()).map(|(&a, &b)| (i16::from(a) - i16::from(b)).abs()).max().unwrap_or(0);
        prop_assert!(worst <= 1, "differs by {} grey levels", worst);
    }

    #[test]
    fn rendering_never_panics_and_rejects_wrong_lengths(n in 0usize..400, len in 0usize..100) {
        let map = arm();
        let mut raster = Rasterizer::new(&map, Grid::Size { rows: 10, cols: 12 }).unwrap();
        let ok = n == map.ids.len() && len == raster.len();
        let mut img = vec![0.0; len];
        prop_assert_eq!(raster.render(&vec![1.0; n], &mut img).is_ok(), ok);
    }
}

#[test]
fn a_grid_of_given_size_has_that_size_and_covers_the_map() {
    let map = arm();
    let raster = Rasterizer::new(&map, Grid::Size { rows: 68, cols: 100 }).unwrap();
    assert_eq!((raster.rows(), raster.cols()), (68, 100));
    let (w, h) = map.extent();
    assert!(raster.step() * 100.0 >= w - 1e-12 && raster.step() * 68.0 >= h - 1e-12);
    assert!(Rasterizer::new(&map, Grid::Size { rows: 0, cols: 3 }).is_err());
    assert!(Rasterizer::new(&map, Grid::StepMm(-1.0)).is_err());
}

#[test]
fn the_imager_runs_the_whole_path_and_a_touch_stays_where_it_was() {
    let map = arm();
    let raster = Rasterizer::new(&map, Grid::StepMm(1.0)).unwrap();
    let (rows, cols) = (raster.rows(), raster.cols());
    let size = skin_core::image::ImageSize::MODEL_DEFAULT;
    let mut imager = TactileImager::new(raster, Normalisation::ContactMax, true, Some(size)).unwrap();
    assert_eq!((imager.output_size().rows, imager.output_size().cols), (68, 100));
    // Press the taxels near one end of the arm.
    let pressures: Vec<f32> = map
        .positions
        .iter()
        .map(|p| {
            if p.y < 0.02 && p.x.abs() < 0.02 {
                900.0
            } else {
                0.0
            }
        })
        .collect();
    let out = imager.process(&pressures).unwrap().to_vec();
    assert_eq!(out.len(), 68 * 100);
    assert!(out.iter().any(|&g| g > 200));
    let k = imager.pressure_image();
    assert_eq!(k.len(), rows * cols);
    let peak = k.iter().copied().fold(0.0f32, f32::max);
    assert!((peak - 900.0).abs() < 1e-2);
    // The bright pixels of the small image are where the pressure is in the big one.
    let (mut r_small, mut n_small) = (0.0, 0.0);
    for (i, &g) in out.iter().enumerate() {
        if g > 128 {
            r_small += (i / 100) as f64 / 68.0 + 0.5 / 68.0;
            n_small += 1.0;
        }
    }
    let (mut r_big, mut n_big) = (0.0, 0.0);
    for (i, &v) in k.iter().enumerate() {
        if v > 450.0 {
            r_big += (i / cols) as f64 / rows as f64 + 0.5 / rows as f64;
            n_big += 1.0;
        }
    }
    assert!((r_small / n_small - r_big / n_big).abs() < 0.1);
}

#[test]
fn process_into_writes_what_process_returns_for_every_option() {
    let map = arm();
    let pressures: Vec<f32> = map
        .points
        .iter()
        .map(|p| {
            (2000.0 * (1.0 - ((p.x - 0.05).powi(2) + (p.y - 0.06).powi(2)).sqrt() / 0.03)).max(0.0) as f32
        })
        .collect();
    for morph in [false, true] {
        for size in [None, Some(skin_core::image::ImageSize::MODEL_DEFAULT)] {
            for norm in [Normalisation::ContactMax, Normalisation::FullScale(3000.0)] {
                let raster = Rasterizer::new(&map, Grid::StepMm(1.0)).unwrap();
                let mut a = TactileImager::new(raster.clone(), norm, morph, size).unwrap();
                let mut b = TactileImager::new(raster, norm, morph, size).unwrap();
                let expected = a.process(&pressures).unwrap().to_vec();
                assert!(expected.iter().any(|&g| g > 0));
                // Garbage in the caller's buffer is overwritten everywhere.
                let mut out = vec![77u8; b.output_size().pixels()];
                b.process_into(&pressures, &mut out).unwrap();
                assert_eq!(out, expected, "morph {morph}, size {size:?}, norm {norm:?}");
                assert_eq!(b.pressure_image(), a.pressure_image());
                let mut short = vec![0u8; out.len() - 1];
                assert!(b.process_into(&pressures, &mut short).is_err());
            }
        }
    }
}

#[test]
fn a_normalisation_kind_is_read_by_name_and_a_wrong_one_lists_the_names() {
    use skin_geom::NormKind;
    for kind in [NormKind::ContactMax, NormKind::FullScale] {
        assert_eq!(kind.name().parse::<NormKind>(), Ok(kind));
        assert_eq!(kind.to_string(), kind.name());
    }
    assert_eq!(Normalisation::FullScale(4095.0).kind(), NormKind::FullScale);
    assert_eq!(Normalisation::ContactMax.kind(), NormKind::ContactMax);
    let e = "contact-max".parse::<NormKind>().unwrap_err().to_string();
    assert_eq!(e, "\"contact-max\": expected \"contact_max\" or \"full_scale\"");
}
