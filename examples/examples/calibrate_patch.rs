//! Calibrate a skin patch: where is each taxel, from a probe pressing it?
//!
//! ```text
//! cargo run --release -p skin-examples --example calibrate_patch
//! ```
//! Simulates the thesis' experiment (Ch. 7.3) on the fixture's 61-taxel hexagonal patch: 350
//! presses of a 5 N probe with noisy responses and noisy contact centroids, then fits every
//! taxel's position and normal from its own responses, and compares with the true layout
//! (Eq. 7.5-7.8). On a robot, the dataset comes from the probe instead (`ProbeDataset::read`
//! reads its CSV).

use skin_core::format::load_link;
use skin_learn::calibration::{CalibrationErrors, CalibrationOptions, ProbeSimulator, calibrate};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let fixtures = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/hex_patch");
    let truth = load_link(&fixtures.join("layout.json"))?.value;

    let probes = ProbeSimulator::default().run(&truth, 350, 42);
    let report = calibrate(&probes, &CalibrationOptions::default());
    for t in report.flagged() {
        println!("taxel {} not calibrated: {}", t.id, t.status);
    }
    let e = CalibrationErrors::compare(&report, &truth);
    println!(
        "{} taxels: mean error {:.2} mm (sigma {:.2}), max {:.2} mm, normals off by {:.3} rad",
        e.compared, e.mean_mm, e.std_mm, e.max_mm, e.mean_normal_rad
    );
    println!("thesis, same experiment on hardware: 1.9 mm (0.8), max 4.0 mm, 0.06 rad");
    // The calibrated layout, ready for `skin flatten`.
    let calibrated = report.to_link("hex_patch");
    println!("calibrated layout: {} taxels", calibrated.taxels.len());
    Ok(())
}
