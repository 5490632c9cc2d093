//! Stitching a chain of link maps (thesis Ch. 6): boundary edges keep their 3D length, the
//! warm-started solver converges in a few iterations on pre-aligned maps, a one-iteration budget
//! still improves the start, and bad input gives errors.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Isometry3, Point3, Translation3, Unit, UnitQuaternion, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::{Deadline, FlattenOptions, JointMode, StitchOptions, Stitcher, TactileMap};

const R: f64 = 0.08;

/// Taxels on a half cylinder of radius R around the y axis, 8 mm apart, y in [0, length].
fn half_cylinder(name: &str, length: f64, first_id: u32) -> LinkSkin {
    let cols = (std::f64::consts::PI * R / 0.008).round() as usize;
    let rows = (length / 0.008).round() as usize + 1;
    let mut taxels = Vec::new();
    for i in 0..rows {
        for k in 0..=cols {
            // Staggered rows: a triangular lattice.
            let s = (k as f64 + 0.5 * (i % 2) as f64) * 0.008;
            if s > std::f64::consts::PI * R {
                continue;
            }
            let a = s / R;
            let n = Vector3::new(a.cos(), 0.0, a.sin());
            taxels.push(Taxel {
                id: TaxelId(first_id + taxels.len() as u32),
                position: Point3::new(R * a.cos(), 0.008 * i as f64, R * a.sin()),
                normal: Unit::new_normalize(n),
            });
        }
    }
    LinkSkin::new(name, taxels)
}

fn maps() -> Vec<TactileMap> {
    let forearm = half_cylinder("forearm", 0.2, 0);
    let wrist = half_cylinder("wrist", 0.12, 10_000);
    vec![
        TactileMap::flatten(&forearm, &FlattenOptions::default()).unwrap(),
        TactileMap::flatten(&wrist, &FlattenOptions::default()).unwrap(),
    ]
}

/// Forearm at the origin; wrist 1 cm past its end, rolled by `angle` about the common axis.
fn poses(angle: f64) -> Vec<Isometry3<f64>> {
    vec![
        Isometry3::identity(),
        Isometry3::from_parts(
            Translation3::new(0.0, 0.21, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), angle),
        ),
    ]
}

/// The worst relative error between the 3D length of a cross-boundary pair and its stitched 2D
/// length, over pairs closer than 2 cm in 3D.
fn worst_edge_error(
    st: &Stitcher,
    poses: &[Isometry3<f64>],
    report: &skin_geom::StitchReport,
) -> (f64, usize) {
    let (a, b) = st.boundary(0).unwrap();
    let (ma, mb) = (&st.maps()[0], &st.maps()[1]);
    let mut worst: f64 = 0.0;
    let mut n = 0;
    for &i in a {
        for &j in b {
            let d3 = (poses[0] * ma.positions[i] - poses[1] * mb.positions[j]).norm();
            if d3 > 0.02 {
                continue;
            }
            let d2 = (report.placements[0].apply(&ma.points[i]) - report.placements[1].apply(&mb.points[j]))
                .norm();
            worst = worst.max((d2 - d3).abs() / d3);
            n += 1;
        }
    }
    (worst, n)
}

#[test]
fn stitched_boundary_edges_keep_their_3d_length_at_every_posture() {
    let mut st = Stitcher::new(maps(), &poses(0.0), StitchOptions::default()).unwrap();
    for angle in [-0.6, 0.0, 0.6, -0.3] {
        let p = poses(angle);
        // A posture far from the last one: start afresh rather than from the last placement.
        let report = st.reset(&p).unwrap();
        let j = report.joints[0];
        assert!(j.converged && j.edges > 10, "{j:?}");
        let (worst, pairs) = worst_edge_error(&st, &p, &report);
        assert!(
            pairs > 20 && worst < 0.05,
            "roll {angle}: worst edge error {worst} over {pairs} pairs"
        );
        // The library's figure is this test's own.
        assert_eq!(st.edge_fidelity(0, &p, &report.placements, 0.02), (worst, pairs));
        assert_eq!(
            st.edge_fidelity(1, &p, &report.placements, 0.02),
            (0.0, 0),
            "no joint 1"
        );
        // The drawing has every triangle of both maps.
        let svg = skin_geom::stitched_svg(st.maps(), &report.placements);
        let faces: usize = st.maps().iter().map(|m| m.faces.len()).sum();
        assert_eq!(svg.matches("<polygon").count(), faces);
        assert!(!svg.contains("NaN") && !svg.contains("inf"), "{svg:.300}");
    }
}

#[test]
fn pre_aligned_maps_converge_in_three_iterations_from_the_warm_start() {
    let mut st = Stitcher::new(maps(), &poses(0.0), StitchOptions::default()).unwrap();
    // Pre-align at the reference posture: the rotation found there holds for every roll.
    let first = st.update(&poses(0.0), Deadline::Iterations(200)).unwrap();
    st.set_mode(
        0,
        JointMode::TranslationOnly {
            angle: first.joints[0].placement.angle,
        },
    );
    // The arm rolls on in small steps, as between two 1 kHz control cycles (0.5 deg).
    let mut angle = 0.0;
    let mut worst_iterations = 0;
    for _ in 0..40 {
        angle += 0.5f64.to_radians();
        let r = st.update(&poses(angle), Deadline::Iterations(50)).unwrap();
        assert!(r.joints[0].converged, "{:?}", r.joints[0]);
        worst_iterations = worst_iterations.max(r.joints[0].iterations);
    }
    assert!(worst_iterations <= 3, "{worst_iterations} iterations");
    // A budget of one iteration still lowers the cost from a stale start.
    let r = st.update(&poses(angle + 0.2), Deadline::Iterations(1)).unwrap();
    let j = r.joints[0];
    assert_eq!(j.iterations, 1);
    assert!(j.cost < j.start_cost, "{j:?}");
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let mut st = Stitcher::new(maps(), &poses(0.0), StitchOptions::default()).unwrap();
    let err = st.update(&poses(0.0)[..1], Deadline::Iterations(5)).unwrap_err();
    // The error says what mismatched, as a type and in words.
    assert!(
        matches!(
            err,
            skin_geom::Error::Length {
                got: 1,
                expected: 2,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(
        err.to_string()
            .contains("poses for the chain's links: 1, expected 2"),
        "{err}"
    );
    let mut nan = poses(0.0);
    nan[1].translation.vector.x = f64::NAN;
    let err = st.update(&nan, Deadline::Iterations(5)).unwrap_err().to_string();
    assert!(err.contains("pose of link 1 is not finite"), "{err}");
    // A zero deadline keeps the last placement (documented fallback).
    let before = st.update(&poses(0.0), Deadline::Iterations(100)).unwrap();
    let zero = st.update(&poses(0.4), Deadline::Iterations(0)).unwrap();
    assert_eq!(zero.joints[0].iterations, 0);
    assert_eq!(zero.placements, before.placements);
    // Links too far apart: no boundary.
    let mut far = poses(0.0);
    far[1].translation.vector.y = 1.0;
    let err = Stitcher::new(maps(), &far, StitchOptions::default())
        .unwrap_err()
        .to_string();
    assert!(err.contains("no boundary taxel"), "{err}");
    // Links pulled apart after set-up: no edge under 3 cm, last placement kept and reported.
    let r = st.update(&far, Deadline::Iterations(10)).unwrap();
    assert!(r.joints[0].kept_last && r.joints[0].edges == 0);
    assert!(Stitcher::new(maps()[..1].to_vec(), &poses(0.0)[..1], StitchOptions::default()).is_err());
}

fn kabsch2(from: &[nalgebra::Point2<f64>], to: &[nalgebra::Point2<f64>]) -> skin_geom::Placement {
    let n = from.len() as f64;
    let cf = from.iter().fold(nalgebra::Vector2::zeros(), |a, p| a + p.coords) / n;
    let ct = to.iter().fold(nalgebra::Vector2::zeros(), |a, p| a + p.coords) / n;
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (f, t) in from.iter().zip(to) {
        let (a, b) = (f.coords - cf, t.coords - ct);
        sxx += a.x * b.x + a.y * b.y;
        sxy += a.x * b.y - a.y * b.x;
    }
    let angle = sxy.atan2(sxx);
    skin_geom::Placement {
        angle,
        offset: ct - nalgebra::Rotation2::new(angle) * cf,
    }
}

/// Two coaxial cylinders unroll into one plane without stretch: the stitched wrist map must sit
/// exactly where unrolling both links together puts it, whatever the roll.
#[test]
fn coaxial_cylinders_stitch_to_their_exact_common_unrolling() {
    let m = maps();
    let mut st = Stitcher::new(m.clone(), &poses(0.0), StitchOptions::default()).unwrap();
    // Unrolled coordinates (arc length, axial position), oriented like the maps (counter-clockwise
    // seen from outside), and the rigid motion that takes them onto the forearm's map.
    // Angles in [-pi/2, 3 pi/2): the covers span [0, pi] rolled by at most half a turn either way.
    let unroll = |p: &Point3<f64>| {
        let a = p.z.atan2(p.x);
        let a = if a < -std::f64::consts::FRAC_PI_2 {
            a + std::f64::consts::TAU
        } else {
            a
        };
        nalgebra::Point2::new(-R * a, p.y)
    };
    let fa: Vec<_> = m[0].positions.iter().map(unroll).collect();
    let to_map = kabsch2(&fa, &m[0].points);
    let fit: f64 = fa
        .iter()
        .zip(&m[0].points)
        .map(|(a, b)| (to_map.apply(a) - b).norm())
        .fold(0.0, f64::max);
    assert!(fit < 1e-4, "the forearm map is its unrolling ({fit} m off)");
    for angle in [-0.5, 0.0, 0.4] {
        let p = poses(angle);
        let report = st.reset(&p).unwrap();
        // The wrist's taxels in the forearm frame, unrolled, then onto the forearm map.
        let want: Vec<_> = m[1]
            .positions
            .iter()
            .map(|q| to_map.apply(&unroll(&(p[1] * q))))
            .collect();
        let worst = m[1]
            .points
            .iter()
            .zip(&want)
            .map(|(u, w)| (report.placements[1].apply(u) - w).norm())
            .fold(0.0, f64::max);
        assert!(
            worst < 2e-4,
            "roll {angle}: wrist taxels up to {worst} m from the exact unrolling"
        );
    }
}

/// A pressure field linear in the stitched plane is reproduced exactly wherever the stitched image
/// shows skin, on either map and across the joint (barycentric interpolation is exact for planes).
#[test]
fn a_linear_field_is_reproduced_across_the_joint() {
    let m = maps();
    let mut st = Stitcher::new(m.clone(), &poses(0.3), StitchOptions::default()).unwrap();
    let report = st.reset(&poses(0.3)).unwrap();
    assert!(!report.bridges.is_empty());
    let field = |p: &nalgebra::Point2<f64>| (1000.0 + 2000.0 * p.x + 3000.0 * p.y) as f32;
    let pressures: Vec<Vec<f32>> = m
        .iter()
        .zip(&report.placements)
        .map(|(map, pl)| map.points.iter().map(|q| field(&pl.apply(q))).collect())
        .collect();
    let mut raster = skin_geom::StitchedRasterizer::new(&m, 1.0).unwrap();
    raster.place(&report.placements, &report.bridges).unwrap();
    let mut image = Vec::new();
    let views: Vec<&[f32]> = pressures.iter().map(Vec::as_slice).collect();
    raster.render(&views, &mut image).unwrap();
    let (mut covered, mut worst) = (0, 0.0f32);
    for row in 0..raster.rows() {
        for col in 0..raster.cols() {
            let v = image[row * raster.cols() + col];
            if v == 0.0 {
                continue;
            }
            covered += 1;
            // Map pixels are read at the nearest link pixel: up to half a pixel away.
            let want = field(&raster.pixel_centre(row, col));
            worst = worst.max((v - want).abs());
        }
    }
    // Half a pixel diagonal (0.7 mm) of a 3.6 counts/mm gradient, plus float rounding.
    assert!(covered > 50_000 && worst < 3.0, "{covered} pixels, worst {worst}");
}

#[test]
fn a_time_deadline_returns_a_usable_placement() {
    let mut st = Stitcher::new(maps(), &poses(0.0), StitchOptions::default()).unwrap();
    let r = st
        .update(&poses(0.02), Deadline::Time(std::time::Duration::from_secs(5)))
        .unwrap();
    assert!(r.joints[0].converged && r.joints[0].cost <= r.joints[0].start_cost);
    let kept = st
        .update(&poses(0.3), Deadline::Time(std::time::Duration::ZERO))
        .unwrap();
    assert_eq!((kept.joints[0].iterations, kept.joints[0].converged), (0, false));
    assert_eq!(kept.placements, r.placements);
}
