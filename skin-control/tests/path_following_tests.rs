//! Path following: a point integrated with the reference velocity runs along the path at the set
//! speed, comes back to it after a push, never goes backwards, and stops on the last waypoint.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Point3, Vector3};
use proptest::prelude::*;
use skin_control::path_following::{PathError, PathFollowing};

fn square() -> Vec<Point3<f64>> {
    vec![
        Point3::new(0.5, -0.1, 0.4),
        Point3::new(0.5, 0.1, 0.4),
        Point3::new(0.5, 0.1, 0.6),
        Point3::new(0.5, -0.1, 0.6),
    ]
}

#[test]
fn on_the_path_the_point_moves_at_the_set_speed_along_it() {
    let mut p = PathFollowing::new(&square(), 0.03, 5.0).unwrap();
    let x = Point3::new(0.5, 0.0, 0.4);
    let r = p.reference(&x);
    assert!(
        (r.velocity - Vector3::new(0.0, 0.03, 0.0)).norm() < 1e-12,
        "{}",
        r.velocity
    );
    assert!(r.error < 1e-12);
    assert!((r.progress - 0.1).abs() < 1e-12);
}

#[test]
fn a_point_integrated_with_the_reference_follows_the_whole_path_and_stops_at_its_end() {
    let mut p = PathFollowing::new(&square(), 0.03, 5.0).unwrap();
    let mut x = Point3::new(0.5, -0.1, 0.4);
    let dt = 0.005;
    let mut last_progress = 0.0;
    let mut worst_error: f64 = 0.0;
    let mut t = 0.0;
    while t < 40.0 {
        let r = p.reference(&x);
        assert!(
            r.progress >= last_progress - 1e-12,
            "progress went back at t = {t}"
        );
        last_progress = r.progress;
        worst_error = worst_error.max(r.error);
        x += r.velocity * dt;
        t += dt;
    }
    // 0.6 m at 0.03 m/s = 20 s, then it settles on the last waypoint.
    assert!((x - Point3::new(0.5, -0.1, 0.6)).norm() < 1e-3, "{x}");
    // Corners are cut by at most speed / gain.
    assert!(worst_error < 0.03 / 5.0 + 1e-9, "{worst_error}");
}

#[test]
fn after_a_push_the_point_returns_to_the_nearest_path_point_not_to_a_timetable() {
    let mut p = PathFollowing::new(&square(), 0.03, 5.0).unwrap();
    // Pushed 5 cm off the first segment, in its middle.
    let x = Point3::new(0.55, 0.0, 0.4);
    let r = p.reference(&x);
    assert!((r.error - 0.05).abs() < 1e-12);
    assert!((r.progress - 0.1).abs() < 1e-12);
    // Back towards the path (-x) and on along it (+y).
    assert!(
        (r.velocity - Vector3::new(-0.25, 0.03, 0.0)).norm() < 1e-12,
        "{}",
        r.velocity
    );
}

#[test]
fn bad_paths_are_refused() {
    let p = Point3::new(0.0, 0.0, 0.0);
    assert_eq!(
        PathFollowing::new(&[p, p], 0.03, 1.0).unwrap_err(),
        PathError::TooShort
    );
    assert_eq!(
        PathFollowing::new(&[p, Point3::new(f64::NAN, 0.0, 0.0)], 0.03, 1.0).unwrap_err(),
        PathError::NotFinite(1)
    );
    assert_eq!(
        PathFollowing::new(&square(), -1.0, 1.0).unwrap_err(),
        PathError::Parameter("speed")
    );
    let mut ok = PathFollowing::new(&square(), 0.03, 1.0).unwrap();
    assert_eq!(
        ok.reference(&Point3::new(f64::NAN, 0.0, 0.0)).velocity,
        Vector3::zeros()
    );
}

proptest! {
    #[test]
    fn the_reference_is_finite_and_bounded_for_any_point(
        x in -10.0..10.0f64, y in -10.0..10.0f64, z in -10.0..10.0f64,
    ) {
        let mut p = PathFollowing::new(&square(), 0.03, 5.0).unwrap();
        let at = Point3::new(x, y, z);
        let r = p.reference(&at);
        prop_assert!(r.velocity.iter().all(|v| v.is_finite()));
        // Along-path speed plus the pull back: never more than speed + gain * error.
        prop_assert!(r.velocity.norm() <= 0.03 + 5.0 * r.error + 1e-9);
    }
}
