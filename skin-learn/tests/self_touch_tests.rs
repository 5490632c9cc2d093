//! The self-touch pieces of the calibration procedure (Ch. 7.2.1-7.2.2) on a synthetic RGB-D
//! frame: a two-link arm (capsules of radius 5 cm) over a floor, seen from above.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Isometry3, Point3, Translation3, UnitQuaternion};
use skin_learn::calibration::body_detection::{
    PinholeCamera, body_mask, containing_polygon, link_thickness, pick_target, surface_at,
};
use skin_learn::calibration::exploration::next_probe_point;

const RADIUS: f64 = 0.05;

fn camera() -> PinholeCamera {
    // 1.2 m above the base, looking straight down, slightly rolled.
    let pose = Isometry3::from_parts(
        Translation3::new(0.05, 0.02, 1.2),
        UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.2),
    );
    PinholeCamera {
        kx: 300.0,
        ky: 300.0,
        u0: 80.0,
        v0: 60.0,
        width: 160,
        height: 120,
        base_to_camera: pose.inverse(),
    }
}

fn joints() -> [Point3<f64>; 3] {
    [
        Point3::new(-0.25, -0.05, 0.3),
        Point3::new(0.1, 0.0, 0.3),
        Point3::new(0.3, 0.15, 0.32),
    ]
}

/// Depth image and true body mask: rays marched in 0.5 mm steps against the two capsules; the
/// floor (z = -0.3) behind them.
fn render(cam: &PinholeCamera) -> (Vec<f32>, Vec<bool>) {
    let j = joints();
    let centre = cam.centre();
    let mut depth = vec![0.0f32; cam.width * cam.height];
    let mut truth = vec![false; cam.width * cam.height];
    for v in 0..cam.height {
        for u in 0..cam.width {
            let far = cam.back_project(u as f64, v as f64, 1.0);
            let dir = (far - centre).normalize();
            let mut hit = None;
            let mut s = 0.6;
            while s < 1.2 {
                let p = centre + dir * s;
                let inside = j.windows(2).any(|w| {
                    let ab = w[1] - w[0];
                    let t = ((p - w[0]).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
                    (p - (w[0] + ab * t)).norm() <= RADIUS
                });
                if inside {
                    hit = Some(p);
                    break;
                }
                s += 0.0005;
            }
            let k = v * cam.width + u;
            match hit {
                Some(p) => {
                    depth[k] = cam.depth_of(&p) as f32;
                    truth[k] = true;
                }
                None => {
                    let t = (-0.3 - centre.z) / dir.z;
                    depth[k] = cam.depth_of(&(centre + dir * t)) as f32;
                }
            }
        }
    }
    (depth, truth)
}

#[test]
fn eq_7_1_projects_and_back_projects() {
    let cam = camera();
    let p = Point3::new(0.12, -0.07, 0.31);
    let [u, v] = cam.project(&p).unwrap();
    let c = cam.base_to_camera * p;
    assert!((u - (300.0 * c.x / c.z + 80.0)).abs() < 1e-12 && (v - (300.0 * c.y / c.z + 60.0)).abs() < 1e-12);
    assert!((cam.back_project(u, v, cam.depth_of(&p)) - p).norm() < 1e-12);
    // Behind the camera: no pixel.
    assert!(cam.project(&Point3::new(0.0, 0.0, 2.0)).is_none());
}

#[test]
fn the_body_is_segmented_from_the_background() {
    let cam = camera();
    let (depth, truth) = render(&cam);
    let j = joints();
    // Link thickness from depth (Fig. 7.3): the capsules' radius, seen from above.
    let mut widths = Vec::new();
    let mut links = Vec::new();
    for w in j.windows(2) {
        let (d_max, px) = link_thickness(&cam, &depth, &w[0], &w[1], 0.2).unwrap();
        assert!((d_max - RADIUS).abs() < 0.1 * RADIUS, "d_max {d_max}");
        widths.push(px);
        links.push((w[0], w[1], d_max));
    }
    // The polygon's half-width must cover the link's silhouette (radius, not just the top), so
    // grow it a little as a user would; the mask then keeps only depth-consistent pixels.
    let skeleton: Vec<[f64; 2]> = j.iter().map(|p| cam.project(p).unwrap()).collect();
    let polygon = containing_polygon(&skeleton, &widths.iter().map(|w| w * 1.3).collect::<Vec<_>>());
    assert_eq!(polygon.len(), 2 * j.len(), "{polygon:?}");
    let mask = body_mask(&cam, &depth, &polygon, &links);
    let inter = mask.iter().zip(&truth).filter(|(a, b)| **a && **b).count() as f64;
    let union = mask.iter().zip(&truth).filter(|(a, b)| **a || **b).count() as f64;
    eprintln!("body mask IoU {:.3}", inter / union);
    assert!(inter / union > 0.97, "IoU {}", inter / union);
    // Almost nothing of the floor.
    let floor_in_mask = mask.iter().zip(&truth).filter(|(m, t)| **m && !**t).count();
    assert!(
        floor_in_mask * 50 < truth.iter().filter(|t| **t).count(),
        "{floor_in_mask}"
    );

    // Targets on the body, reachable (here: the first link only), with outward normals.
    let first = |p: &Point3<f64>| p.x < 0.05;
    for seed in 0..10 {
        let (p, n) = pick_target(&cam, &depth, &mask, 3, seed, 1000, first).unwrap();
        assert!(first(&p));
        let ab = j[1] - j[0];
        let t = ((p - j[0]).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
        let radial = p - (j[0] + ab * t);
        assert!(
            (radial.norm() - RADIUS).abs() < 0.003,
            "target off the surface by {}",
            radial.norm() - RADIUS
        );
        assert!(n.dot(&radial.normalize()) > 0.99, "normal {n:?} vs {radial:?}");
    }
    assert!(pick_target(&cam, &depth, &mask, 3, 0, 100, |_| false).is_none());
}

#[test]
fn the_normal_at_a_target_is_the_surface_normal() {
    let cam = camera();
    let (depth, truth) = render(&cam);
    let j = joints();
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for v in (10..cam.height - 10).step_by(7) {
        for u in (10..cam.width - 10).step_by(7) {
            // Targets well inside the silhouette, where a probe would press.
            let all_body = (-4i64..=4).all(|d| {
                truth[(v as i64 + d) as usize * cam.width + u]
                    && truth[v * cam.width + (u as i64 + d) as usize]
            });
            if !all_body {
                continue;
            }
            let (p, n) = surface_at(&cam, &depth, u, v, 3).unwrap();
            // True normal: from the nearest axis point outwards.
            let axis = j
                .windows(2)
                .map(|w| {
                    let ab = w[1] - w[0];
                    let t = ((p - w[0]).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
                    w[0] + ab * t
                })
                .min_by(|a, b| (p - a).norm().total_cmp(&(p - b).norm()))
                .unwrap();
            let want = (p - axis).normalize();
            worst = worst.max(n.dot(&want).clamp(-1.0, 1.0).acos());
            checked += 1;
        }
    }
    assert!(checked > 20, "{checked}");
    eprintln!(
        "{checked} targets, worst normal error {:.2} deg",
        worst.to_degrees()
    );
    assert!(
        worst.to_degrees() < 8.0,
        "worst normal error {:.2} deg",
        worst.to_degrees()
    );
}

#[test]
fn exploration_goes_where_samples_are_missing() {
    let taxels: Vec<Point3<f64>> = (0..10)
        .map(|k| Point3::new(0.008 * f64::from(k), 0.0, 0.0))
        .collect();
    let candidates: Vec<Point3<f64>> = (0..10)
        .map(|k| Point3::new(0.008 * f64::from(k), 0.0, 0.001))
        .collect();
    let mut samples = vec![20; 10];
    samples[7] = 3;
    samples[8] = 5;
    assert_eq!(
        next_probe_point(&candidates, &taxels, &samples, 16, 0.010),
        Some(7)
    );
    assert_eq!(next_probe_point(&candidates, &taxels, &[16; 10], 16, 0.010), None);
    // A loop that presses where the rule says reaches the wanted samples everywhere.
    let mut samples = vec![0usize; 10];
    let mut presses = 0;
    while let Some(k) = next_probe_point(&candidates, &taxels, &samples, 16, 0.010) {
        for (t, s) in taxels.iter().zip(samples.iter_mut()) {
            if (t - candidates[k]).norm() <= 0.010 {
                *s += 1;
            }
        }
        presses += 1;
        assert!(presses < 200);
    }
    assert!(samples.iter().all(|&s| s >= 16));
}

/// A CAD layout (every taxel of `truth` up to 3 mm off in the patch plane) and candidate probe
/// points: 30 random points within 8 mm of every CAD taxel (what the segmented body offers);
/// each is pressed at most once, so samples come from many places.
fn cad_and_candidates(truth: &skin_core::LinkSkin) -> (Vec<Point3<f64>>, Vec<Point3<f64>>) {
    use rand::{Rng, SeedableRng};
    let n = truth.taxels[0].normal.into_inner();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let t1 = n.cross(&nalgebra::Vector3::x()).normalize();
    let t2 = n.cross(&t1);
    let cad: Vec<Point3<f64>> = truth
        .taxels
        .iter()
        .map(|t| t.position + (t1 * rng.random_range(-1.0..1.0) + t2 * rng.random_range(-1.0..1.0)) * 0.003)
        .collect();
    let mut candidates = Vec::new();
    for p in &cad {
        for _ in 0..30 {
            let a = rng.random_range(0.0..std::f64::consts::TAU);
            let r = 0.008 * rng.random::<f64>().sqrt();
            candidates.push(p + (t1 * a.cos() + t2 * a.sin()) * r);
        }
    }
    (cad, candidates)
}

/// The whole procedure without a person choosing the points: the exploration rule picks where to
/// press from rough (CAD) taxel positions, the approach-then-press controller drives a simulated
/// probe into a spring-like skin until the force settles at 5 N, the simulated skin answers, and
/// the dataset is calibrated.
#[test]
fn a_closed_loop_calibrates_a_patch_on_its_own() {
    use skin_control::approach_press::{ApproachPress, Phase, PressOptions};
    use skin_learn::calibration::exploration::beyond_edges;
    use skin_learn::calibration::{
        CalibrationErrors, CalibrationOptions, ProbeDataset, ProbeSimulator, calibrate,
    };

    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/hex_patch/layout.json");
    let truth = skin_core::format::load_link(&path).unwrap().value;
    let normal = truth.taxels[0].normal;
    let n = normal.into_inner();
    let (cad, mut candidates) = cad_and_candidates(&truth);
    let mut session = ProbeSimulator::default().session(&truth, 8);
    let stiffness = 10_000.0; // N/m: 0.5 mm of skin compression at 5 N
    let surface = truth.taxels[0].position;
    let mut dataset = ProbeDataset::default();
    let mut samples = vec![0usize; truth.taxels.len()];
    let dt = 0.001;
    // A sample counts for a taxel when the press lands within 6 mm of where the taxel is thought
    // to be: far answers are weak and leave the Gaussian's centre loose.
    // One press: approach, settle at 5 N, and the skin's answer with the tip as the centroid.
    let mut press_at = |target: Point3<f64>| {
        let mut press = ApproachPress::new(target, normal, PressOptions::default());
        let mut tip = target + n * 0.05;
        let mut force = 0.0;
        let mut steps = 0;
        while press.phase() != Phase::Settled {
            let v = press.step(&tip, force);
            tip += v * dt;
            force = stiffness * (surface - tip).dot(&n).max(0.0);
            steps += 1;
            assert!(
                steps < 20_000,
                "press at {target} did not settle: {:?}",
                press.phase()
            );
        }
        assert!((force - 5.0).abs() < 0.1);
        // The robot records the tip as the contact centroid (Ch. 7.2.3).
        (tip, session.press(&tip, force))
    };
    while let Some(k) = next_probe_point(&candidates, &cad, &samples, 16, 0.006) {
        assert!(dataset.contacts.len() < 1000, "exploration does not end");
        let (tip, contact) = press_at(candidates.swap_remove(k));
        for (id, _) in &contact.responses {
            let i = id.0 as usize;
            if (tip - cad[i]).norm() <= 0.006 {
                samples[i] += 1;
            }
        }
        dataset.contacts.push(contact);
    }
    // Taxels at the patch's edge may have been pressed from one side only: the calibration flags
    // them with the side to press, and the loop presses there until none is left.
    let at: Vec<_> = truth.taxels.iter().zip(&cad).map(|(t, p)| (t.id, *p)).collect();
    let mut rounds = 0;
    loop {
        let report = calibrate(&dataset, &CalibrationOptions::default());
        let mut picks = beyond_edges(&report, &at, &candidates, 0.005, 0.004);
        if picks.is_empty() {
            break;
        }
        rounds += 1;
        assert!(rounds <= 5, "edge taxels still one-sided after 5 rounds");
        picks.sort_unstable();
        for k in picks.into_iter().rev() {
            let (_, contact) = press_at(candidates.swap_remove(k));
            dataset.contacts.push(contact);
        }
    }
    let report = calibrate(&dataset, &CalibrationOptions::default());
    let e = CalibrationErrors::compare(&report, &truth);
    eprintln!("closed loop: {} presses, {e:?}", dataset.contacts.len());
    for t in report.flagged() {
        eprintln!(
            "flagged {}: {} ({} samples) {:?}",
            t.id, t.status, t.samples, t.fit
        );
    }
    assert_eq!(e.compared, 61, "every taxel calibrated");
    assert!(
        e.mean_mm <= 1.9 && e.max_mm <= 4.0 && e.mean_normal_rad <= 0.06,
        "{e:?}"
    );
}
