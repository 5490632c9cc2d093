//! Fuzzing of skin-learn's reader of probe datasets (CSV): arbitrary text and hostile edits of a
//! valid file (see `test-support/mutate.rs`) give `Ok` or an error, never a panic; what is
//! accepted holds centroids within `MAX_POSITION_M`, finite bounded responses and no taxel
//! twice per contact, and calibrates (or flags its taxels) without a panic.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::Point3;
use proptest::prelude::*;
use skin_core::TaxelId;
use skin_core::format::MAX_POSITION_M;
use skin_core::format::recording::MAX_READING;
use skin_learn::calibration::{CalibrationOptions, ProbeContact, ProbeDataset, calibrate};
use std::collections::HashSet;
use std::path::Path;

#[path = "../../test-support/mutate.rs"]
mod mutate;
use mutate::{arbitrary_text, config, mutated};

/// Six presses around three taxels, each answered by all three.
fn csv() -> String {
    let contacts = (0..6)
        .map(|k| {
            let a = f64::from(k) * 1.05;
            let centroid = Point3::new(0.01 * a.cos(), 0.01 * a.sin(), 0.1);
            ProbeContact {
                centroid,
                force_n: None,
                responses: (0..3)
                    .map(|t| {
                        let taxel = Point3::new(0.004 * f64::from(t), 0.0, 0.1);
                        (
                            TaxelId(16 + t),
                            600.0 * (-(centroid - taxel).norm_squared() / 2e-4).exp(),
                        )
                    })
                    .collect(),
            }
        })
        .collect();
    ProbeDataset { contacts }.to_csv()
}

#[test]
fn the_valid_file_reads() {
    let d = ProbeDataset::parse(&csv(), Path::new("probes.csv")).unwrap();
    assert_eq!(d.contacts.len(), 6);
    assert!(d.contacts.iter().all(|c| c.responses.len() == 3));
}

#[test]
fn a_huge_cell_is_quoted_by_its_first_characters() {
    let long = "9".repeat(100_000);
    let text = format!("contact,x_m,y_m,z_m,taxel,response\n0,{long},0,0,16,1\n");
    let e = ProbeDataset::parse(&text, Path::new("probes.csv"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x_m") && e.contains("100000 bytes") && e.len() < 400,
        "{e}"
    );
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn probe_datasets(text in prop_oneof![mutated(&csv()), arbitrary_text()]) {
        let Ok(d) = ProbeDataset::parse(&text, Path::new("probes.csv")) else {
            return Ok(());
        };
        for c in &d.contacts {
            prop_assert!(c.centroid.coords.iter().all(|v| v.is_finite() && v.abs() <= MAX_POSITION_M));
            prop_assert!(c.responses.iter().all(|(_, r)| r.is_finite() && r.abs() <= f64::from(MAX_READING)));
            prop_assert_eq!(c.responses.iter().map(|(t, _)| t).collect::<HashSet<_>>().len(), c.responses.len());
        }
        let report = calibrate(&d, &CalibrationOptions { min_responses: 3, ..CalibrationOptions::default() });
        for t in &report.taxels {
            if let Some(p) = t.position {
                prop_assert!(p.coords.iter().all(|v| v.is_finite()), "taxel {} at {p:?}", t.id);
            }
        }
    }
}
