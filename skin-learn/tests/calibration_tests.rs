//! Spatial calibration (thesis Ch. 7): exact recovery from an exact Gaussian, the thesis' accuracy
//! on simulated patches, flags for taxels that cannot be calibrated, thread independence, and the
//! dataset CSV form.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Point3, Rotation3, Vector3};
use skin_core::{LinkSkin, TaxelId};
use skin_learn::calibration::{
    CalibrationErrors, CalibrationOptions, GaussianFit, ProbeContact, ProbeDataset, ProbeSimulator, Status,
    calibrate, convergence_curve,
};
use std::path::Path;

/// The fixture's known-pose patch: 61 taxels on a hexagonal lattice of 8 mm, tilted and moved.
fn hex_patch() -> LinkSkin {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/hex_patch/layout.json");
    let patch = skin_core::format::load_link(&path).unwrap().value;
    assert_eq!(patch.taxels.len(), 61);
    patch
}

#[test]
fn simulated_hex_patch_meets_the_thesis_figures() {
    // The fixture's 350 contacts, made by the simulator with its default (documented) noise.
    let patch = hex_patch();
    let csv = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/hex_patch/probes.csv");
    let probes = ProbeDataset::read(&csv).unwrap();
    meets_the_thesis_figures(&probes, &patch);
}

/// Calibrates `probes`, checks every taxel of `truth` is fitted and the errors are within the
/// thesis' figures (mean 1.9 mm, max 4.0 mm, normals 0.06 rad); returns them.
fn meets_the_thesis_figures(probes: &ProbeDataset, truth: &LinkSkin) -> CalibrationErrors {
    let report = calibrate(probes, &CalibrationOptions::default());
    let e = CalibrationErrors::compare(&report, truth);
    let flagged: Vec<String> = report
        .flagged()
        .map(|t| format!("{}: {}", t.id, t.status))
        .collect();
    assert!(flagged.is_empty(), "{flagged:?}");
    assert_eq!(e.compared, truth.taxels.len());
    assert!(
        e.mean_mm <= 1.9 && e.max_mm <= 4.0 && e.mean_normal_rad <= 0.06,
        "{e:?}"
    );
    e
}

use skin_test_support::shared_data;

#[test]
fn the_642_taxel_cyskin_patches_meet_the_same_bounds() {
    for (name, seed) in [
        ("cyskin/ur10e_link1_patch1.json", 2),
        ("cyskin/ur10e_link1_patch2.json", 3),
    ] {
        cyskin_patch(name, seed);
    }
}

fn cyskin_patch(name: &str, seed: u64) {
    let Some(path) = shared_data::shared(name) else {
        return;
    };
    let patch = skin_core::format::cyskin::read_skin(&path).unwrap().value;
    assert_eq!(patch.taxels.len(), 642);
    // 350 contacts per 61 taxels, as on the hexagonal patch.
    let contacts = 350 * 642 / 61;
    let probes = ProbeSimulator::default().run(&patch, contacts, seed);
    let e = meets_the_thesis_figures(&probes, &patch);
    eprintln!("{name}, {contacts} contacts: {e:?}");
}

/// Samples of an exact Gaussian around (cx, cy) with widths (w1, w2), on a jittered grid.
fn exact_samples(c: [f64; 2], w: [f64; 2], height: f64) -> (Vec<[f64; 2]>, Vec<f64>) {
    let mut xs = Vec::new();
    let mut ts = Vec::new();
    for i in 0..9 {
        for j in 0..9 {
            let x = [
                -12.0 + 3.0 * f64::from(i) + 0.3 * f64::from(j % 3),
                -12.0 + 3.0 * f64::from(j) - 0.2 * f64::from(i % 2),
            ];
            let q = (x[0] - c[0]).powi(2) / w[0].powi(2) + (x[1] - c[1]).powi(2) / w[1].powi(2);
            xs.push(x);
            ts.push(height * (-q).exp());
        }
    }
    (xs, ts)
}

#[test]
fn noise_free_responses_of_an_exact_gaussian_give_back_its_centre() {
    for (c, w) in [
        ([1.3, -2.2], [4.0, 5.5]),
        ([-3.0, 0.7], [6.0, 3.2]),
        ([0.0, 0.0], [5.0, 5.0]),
    ] {
        let (xs, ts) = exact_samples(c, w, 0.9);
        let fit = GaussianFit::fit(&xs, &ts, GaussianFit::start(&xs, &ts), &Default::default()).unwrap();
        assert!(fit.converged);
        let err = ((fit.beta[0] - c[0]).powi(2) + (fit.beta[1] - c[1]).powi(2)).sqrt();
        assert!(err < 0.01, "centre off by {err} mm: {fit:?}");
        assert!(
            (fit.beta[2] - w[0]).abs() < 1e-6 && (fit.beta[3] - w[1]).abs() < 1e-6,
            "{fit:?}"
        );
        assert!((fit.beta[4] - 0.9).abs() < 1e-9);
    }
    // In 3D too: a tilted plane, metres, back through calibrate().
    let centre = Point3::new(0.10, 0.02, 0.30);
    let tilt = Rotation3::from_euler_angles(0.4, 0.1, -0.3);
    let (xs, ts) = exact_samples([0.0, 0.0], [4.0, 4.0], 500.0);
    let dataset = ProbeDataset {
        contacts: xs
            .iter()
            .zip(&ts)
            .map(|(x, &t)| ProbeContact {
                centroid: centre + tilt * Vector3::new(x[0] * 1e-3 + 0.0011, x[1] * 1e-3 - 0.0007, 0.0),
                force_n: None,
                responses: vec![(TaxelId(5), t)],
            })
            .collect(),
    };
    let report = calibrate(&dataset, &CalibrationOptions::default());
    let t = report.taxel(TaxelId(5)).unwrap();
    assert_eq!(t.status, Status::Fitted);
    let want = centre + tilt * Vector3::new(0.0011, -0.0007, 0.0);
    assert!(
        (t.position.unwrap() - want).norm() < 1e-5,
        "{:?} vs {want:?}",
        t.position
    );
    assert!(t.normal.unwrap().dot(&(tilt * Vector3::z())) > 1.0 - 1e-12);
}

#[test]
fn a_far_start_falls_back_to_gradient_descent_and_still_converges() {
    let (xs, ts) = exact_samples([2.0, 1.0], [5.0, 4.0], 1.0);
    // Twice too wide and off centre: the Hessian is indefinite there.
    let fit = GaussianFit::fit(&xs, &ts, [0.0, 0.0, 10.0, 10.0, 1.0], &Default::default()).unwrap();
    assert!(fit.gradient_steps > 0, "{fit:?}");
    assert!(fit.converged);
    assert!(
        ((fit.beta[0] - 2.0).powi(2) + (fit.beta[1] - 1.0).powi(2)).sqrt() < 0.01,
        "{fit:?}"
    );
}

#[test]
fn taxels_that_cannot_be_calibrated_are_flagged_by_id() {
    let patch = hex_patch();
    let mut probes = ProbeSimulator::default().run(&patch, 350, 3);
    // Taxel 900: answers 3 contacts. Taxel 901: 12 contacts on a line. Taxel 902: only zeros.
    for (k, c) in probes.contacts.iter_mut().enumerate() {
        if k < 3 {
            c.responses.push((TaxelId(900), 100.0));
        }
        c.responses.push((TaxelId(902), 0.0));
    }
    for k in 0..12 {
        probes.contacts.push(ProbeContact {
            centroid: Point3::new(0.001 * f64::from(k), 0.002 * f64::from(k), 0.0),
            force_n: None,
            responses: vec![(TaxelId(901), 50.0 + f64::from(k))],
        });
    }
    let report = calibrate(&probes, &CalibrationOptions::default());
    assert_eq!(
        report.taxel(TaxelId(900)).unwrap().status,
        Status::TooFewResponses { have: 3, need: 8 }
    );
    let status = &report.taxel(TaxelId(901)).unwrap().status;
    assert!(
        matches!(status, Status::Degenerate(why) if why.contains("line")),
        "{status:?}"
    );
    assert_eq!(report.taxel(TaxelId(902)).unwrap().status, Status::NoResponse);
    let flagged: Vec<u32> = report.flagged().map(|t| t.id.0).collect();
    assert_eq!(flagged, [900, 901, 902]);
    // Flagged taxels are not guessed: the layout leaves them out.
    let link = report.to_link("patch");
    assert_eq!(link.taxels.len(), 61);
}

#[test]
fn results_do_not_depend_on_the_number_of_threads() {
    let patch = hex_patch();
    let probes = ProbeSimulator::default().run(&patch, 350, 4);
    let run = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| calibrate(&probes, &CalibrationOptions::default()))
    };
    assert_eq!(run(1), run(2));
    assert_eq!(run(1), run(5));
}

#[test]
fn the_error_curve_flattens_by_16_samples_per_taxel() {
    let patch = hex_patch();
    // Enough contacts that every taxel has 32 samples to draw from: each point of the curve then
    // averages over the same 61 taxels.
    let probes = ProbeSimulator::default().run(&patch, 1200, 5);
    let curve = convergence_curve(
        &probes,
        &patch,
        &[6, 8, 12, 16, 24, 32],
        10,
        9,
        &CalibrationOptions::default(),
    );
    let at = |n| curve.iter().find(|p| p.samples == n).unwrap();
    // With 6 or 8 samples some taxels are still flagged (a centre outside their contacts, or
    // contacts that do not surround it); from 12 on, under one taxel in 61 on average.
    assert!(
        curve.iter().filter(|p| p.samples >= 12).all(|p| p.fitted >= 59.5),
        "{curve:?}"
    );
    // Most of the gain is made by 16 samples: doubling them to 32 gains under a quarter of what
    // going from 6 to 16 gained, and under 0.2 mm.
    let early = at(6).mean_mm - at(16).mean_mm;
    let late = at(16).mean_mm - at(32).mean_mm;
    assert!(early > 0.0 && late < 0.25 * early && late < 0.2, "{curve:?}");
}

#[test]
fn datasets_round_trip_through_csv_and_bad_rows_name_line_and_field() {
    let patch = hex_patch();
    let probes = ProbeSimulator::default().run(&patch, 50, 6);
    let csv = probes.to_csv();
    assert!(csv.starts_with("contact,x_m,y_m,z_m,taxel,response\n"));
    let back = ProbeDataset::parse(&csv, Path::new("p.csv")).unwrap();
    assert_eq!(back.to_csv(), csv);
    let answered = probes.contacts.iter().filter(|c| !c.responses.is_empty()).count();
    assert_eq!(back.contacts.len(), answered);
    let bad = |text: &str, want: &str| {
        let err = ProbeDataset::parse(text, Path::new("p.csv"))
            .unwrap_err()
            .to_string();
        assert!(err.contains(want), "{err} (wanted {want})");
    };
    let h = "contact,x_m,y_m,z_m,taxel,response\n";
    bad("contact,x,y,z,taxel,response\n", "line 1");
    bad(
        &format!("{h}0,0.1,0.2,0.3,16,5\n0,0.1,nan,0.3,17,5\n"),
        "line 3, field y_m",
    );
    bad(&format!("{h}0,0.1,0.2,0.3,sixteen,5\n"), "line 2, field taxel");
    bad(
        &format!("{h}0,0.1,0.2,0.3,16,5\n0,0.1,0.2,0.4,17,5\n"),
        "line 3, field x_m",
    );
    bad(
        &format!("{h}0,0.1,0.2,0.3,16,5\n0,0.1,0.2,0.3,16,6\n"),
        "taxel 16 answers contact 0 twice",
    );
    bad(&format!("{h}0,0.1,0.2,0.3,16\n"), "5 fields");
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Moving the patch and the probe rigidly moves the fitted taxels with them.
        #[test]
        fn calibration_is_invariant_under_rigid_motion(
            angles in prop::array::uniform3(-3.0f64..3.0),
            shift in prop::array::uniform3(-1.0f64..1.0),
            seed in 0u64..1000,
        ) {
            let patch = hex_patch();
            let probes = ProbeSimulator::default().run(&patch, 200, seed);
            let motion = nalgebra::Isometry3::from_parts(
                nalgebra::Translation3::new(shift[0], shift[1], shift[2]),
                nalgebra::UnitQuaternion::from_euler_angles(angles[0], angles[1], angles[2]),
            );
            let moved = ProbeDataset {
                contacts: probes.contacts.iter().map(|c| ProbeContact { centroid: motion * c.centroid, ..c.clone() }).collect(),
            };
            // The side of the normal is given, as it must be on a flat patch seen from anywhere.
            let up = patch.taxels[0].normal.into_inner();
            let opts = |d| CalibrationOptions { outward: Some(d), ..CalibrationOptions::default() };
            let a = calibrate(&probes, &opts(up));
            let b = calibrate(&moved, &opts(motion * up));
            for (x, y) in a.taxels.iter().zip(&b.taxels) {
                // The same verdict for every taxel. (The distance quoted by a "centre far outside
                // the contacts" flag is where a diverging fit stopped: rounding in the moved
                // coordinates changes it, and whether the runaway met the stopping rule, not the
                // verdict. Seed 795's taxel 30 is such a runaway.)
                prop_assert_eq!(std::mem::discriminant(&x.status), std::mem::discriminant(&y.status), "{}: {} vs {}", x.id, x.status, y.status);
                if let (Some(p), Some(q)) = (x.position, y.position) {
                    prop_assert!((motion * p - q).norm() < 1e-7, "{} moved by {} m", x.id, (motion * p - q).norm());
                    prop_assert!((motion * x.normal.unwrap().into_inner() - y.normal.unwrap().into_inner()).norm() < 1e-7);
                }
            }
        }

        /// Arbitrary datasets (few, repeated, huge or tiny values) never panic.
        #[test]
        fn arbitrary_datasets_never_panic(
            rows in prop::collection::vec((0u32..4, prop::array::uniform3(-1e3f64..1e3), -1e6f64..1e6), 0..80),
        ) {
            let mut d = ProbeDataset::default();
            for (k, (taxel, xyz, r)) in rows.iter().enumerate() {
                d.contacts.push(ProbeContact {
                    centroid: Point3::from(*xyz) * if k % 3 == 0 { 1e-9 } else { 1.0 },
                    force_n: None,
                    responses: vec![(TaxelId(*taxel), *r)],
                });
            }
            let report = calibrate(&d, &CalibrationOptions { min_responses: 5, ..CalibrationOptions::default() });
            for t in &report.taxels {
                if let Some(p) = t.position {
                    prop_assert!(p.coords.iter().all(|v| v.is_finite()));
                }
            }
            let _ = ProbeDataset::parse(&d.to_csv(), Path::new("x.csv"));
        }
    }
}

mod support;
use support::elastic_probe::{ElasticProbe, cylinder_patch};

/// Calibrates `probes` of `patch`: (taxels flagged, largest error of the others in mm, the
/// flagged ones' ids).
fn flagged_and_worst(
    patch: &LinkSkin,
    probes: &ProbeDataset,
    options: &CalibrationOptions,
) -> (usize, f64, Vec<TaxelId>) {
    let report = calibrate(probes, options);
    let e = CalibrationErrors::compare(&report, patch);
    let flagged: Vec<TaxelId> = report.flagged().map(|t| t.id).collect();
    assert_eq!(e.compared + flagged.len(), patch.taxels.len());
    (flagged.len(), e.max_mm, flagged)
}

/// The thesis' bound (Table 7.1: 4 mm) on a real-sized patch, with a probe model other than the
/// one the calibration fits, contacts landing near the border and past it as a robot probing a
/// whole link makes them: at most 2% of the taxels flagged, every other one within 4 mm.
#[test]
fn a_524_taxel_patch_probed_4000_times_places_every_unflagged_taxel_within_4_mm() {
    let patch = cylinder_patch(524, 7.3, 60.0);
    assert_eq!(patch.taxels.len(), 524);
    for seed in [1, 2, 3] {
        for (name, probes) in [
            (
                "elastic probe, contacts up to 8 mm past the border",
                ElasticProbe::default().run(&patch, 4000, seed),
            ),
            (
                "elastic probe, contacts up to 4 mm past the border",
                ElasticProbe {
                    margin_mm: 4.0,
                    ..ElasticProbe::default()
                }
                .run(&patch, 4000, seed),
            ),
            (
                "probe-sim, contacts up to 2 mm past the border",
                ProbeSimulator {
                    margin_mm: 2.0,
                    ..ProbeSimulator::default()
                }
                .run(&patch, 4000, seed),
            ),
        ] {
            let (flagged, worst, _) = flagged_and_worst(&patch, &probes, &CalibrationOptions::default());
            eprintln!("seed {seed}, {name}: {flagged} flagged, largest error {worst:.2} mm");
            assert!(flagged * 50 <= 524, "seed {seed}, {name}: {flagged} flagged");
            assert!(
                worst <= 4.0,
                "seed {seed}, {name}: an unflagged taxel {worst:.2} mm off"
            );
        }
    }
}

/// Probed only inside its outermost taxels, a patch's border is one-sided: there the fit
/// extrapolates, and without the surround check some centres land over 4 mm off (6.6 and 7.5 mm
/// measured). With it those taxels are flagged, every flagged one lies at the border, and the
/// others stay within 4 mm.
#[test]
fn probed_only_inside_its_border_a_patch_flags_its_edge_taxels_instead_of_placing_them_off() {
    let patch = cylinder_patch(524, 7.3, 60.0);
    // Border: taxels with fewer than six lattice neighbours; near it: within a pitch of one.
    let near = |a: &skin_core::Taxel, b: &skin_core::Taxel| (a.position - b.position).norm() < 0.0085;
    let border: Vec<&skin_core::Taxel> = patch
        .taxels
        .iter()
        .filter(|t| patch.taxels.iter().filter(|o| o.id != t.id && near(t, o)).count() < 6)
        .collect();
    let unchecked = CalibrationOptions {
        max_open_angle_deg: 360.0,
        ..CalibrationOptions::default()
    };
    let mut worst_unchecked: f64 = 0.0;
    for (name, probes) in [
        (
            "elastic probe",
            ElasticProbe {
                margin_mm: 0.0,
                ..ElasticProbe::default()
            }
            .run(&patch, 4000, 1),
        ),
        (
            "probe-sim",
            ProbeSimulator {
                margin_mm: 0.0,
                ..ProbeSimulator::default()
            }
            .run(&patch, 4000, 1),
        ),
    ] {
        let (flagged, worst, ids) = flagged_and_worst(&patch, &probes, &CalibrationOptions::default());
        eprintln!("{name}, contacts inside the border: {flagged} flagged, largest error {worst:.2} mm");
        assert!(worst <= 4.0, "{name}: an unflagged taxel {worst:.2} mm off");
        for id in &ids {
            let t = patch.taxels.iter().find(|t| t.id == *id).unwrap();
            assert!(
                border.iter().any(|b| b.id == t.id || near(b, t)),
                "{name}: taxel {id} flagged away from the border"
            );
        }
        let report = calibrate(&probes, &CalibrationOptions::default());
        assert!(
            report
                .flagged()
                .any(|t| matches!(t.status, Status::NotSurrounded { .. }))
        );
        worst_unchecked = worst_unchecked.max(flagged_and_worst(&patch, &probes, &unchecked).1);
    }
    assert!(
        worst_unchecked > 4.0,
        "the check is needed: {worst_unchecked:.2} mm without it"
    );
}

/// The centre's uncertainty is the spread of the fitted centre over repeated noisy datasets: a
/// Gaussian sampled with response noise only, fitted 300 times, gives centres whose standard
/// deviation matches the reported one within 20%.
#[test]
fn the_reported_centre_uncertainty_is_the_spread_of_the_fitted_centre() {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let noise = Normal::new(0.0, 0.03).unwrap();
    let (xs, clean) = exact_samples([0.5, -0.4], [4.5, 4.5], 1.0);
    let (mut centres, mut reported) = (Vec::new(), Vec::new());
    for _ in 0..300 {
        let ts: Vec<f64> = clean.iter().map(|t| t + noise.sample(&mut rng)).collect();
        let fit = GaussianFit::fit(&xs, &ts, GaussianFit::start(&xs, &ts), &Default::default()).unwrap();
        centres.push([fit.beta[0], fit.beta[1]]);
        reported.push(fit.centre_sd(&xs, &ts).unwrap());
    }
    let n = centres.len() as f64;
    let spread = |k: usize| {
        let m = centres.iter().map(|c| c[k]).sum::<f64>() / n;
        (centres.iter().map(|c| (c[k] - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    };
    let observed = spread(0).max(spread(1));
    let said = reported.iter().sum::<f64>() / n;
    assert!(
        (said / observed - 1.0).abs() < 0.2,
        "reported {said:.4} mm, observed {observed:.4} mm"
    );
    // Fewer samples than the model has parameters (plus one) say nothing.
    assert!(
        GaussianFit {
            ..GaussianFit::fit(&xs, &clean, GaussianFit::start(&xs, &clean), &Default::default()).unwrap()
        }
        .centre_sd(&xs[..5], &clean[..5])
        .is_none()
    );
}
