//! How good a calibration is against ground truth (thesis Eq. 7.5-7.8), and how it improves with
//! the number of samples per taxel (Fig. 7.9).

use super::{
    CalibrationOptions, CalibrationReport, ProbeDataset, TaxelSamples, calibrate_taxels, outward_of,
};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;
use skin_core::LinkSkin;
use std::collections::{BTreeMap, HashMap};
use std::fmt::Write as _;

/// Errors of the fitted taxels against their true poses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationErrors {
    /// Fitted taxels that are in the truth (M of Eq. 7.5).
    pub compared: usize,
    /// Taxels of the truth without a fitted pose (flagged, or not in the dataset).
    pub missing: usize,
    /// Mean position error, millimetres (Eq. 7.5).
    pub mean_mm: f64,
    /// Standard deviation of the position error, millimetres (Eq. 7.6).
    pub std_mm: f64,
    /// Largest position error, millimetres (Eq. 7.7).
    pub max_mm: f64,
    /// Mean angle between fitted and true normals, radians (Eq. 7.8).
    pub mean_normal_rad: f64,
}

impl CalibrationErrors {
    /// Compares the fitted taxels of `report` with `truth`, matching taxels by id.
    pub fn compare(report: &CalibrationReport, truth: &LinkSkin) -> CalibrationErrors {
        let truth_at: HashMap<_, _> = truth.taxels.iter().map(|t| (t.id, t)).collect();
        let mut errors = Vec::new();
        let mut angles = Vec::new();
        for t in &report.taxels {
            let (Some(p), Some(n), Some(real)) = (t.position, t.normal, truth_at.get(&t.id)) else {
                continue;
            };
            errors.push((p - real.position).norm() * 1e3);
            angles.push(n.dot(&real.normal).clamp(-1.0, 1.0).acos());
        }
        let m = errors.len();
        let mean = errors.iter().sum::<f64>() / m.max(1) as f64;
        let var = errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (m.max(2) - 1) as f64;
        CalibrationErrors {
            compared: m,
            missing: truth.taxels.len() - m.min(truth.taxels.len()),
            mean_mm: mean,
            std_mm: var.sqrt(),
            max_mm: errors.iter().copied().fold(0.0, f64::max),
            mean_normal_rad: angles.iter().sum::<f64>() / m.max(1) as f64,
        }
    }
}

/// One point of the convergence curve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurvePoint {
    /// Samples per taxel.
    pub samples: usize,
    /// Mean over the trials of the mean position error, millimetres.
    pub mean_mm: f64,
    /// Mean over the trials of the standard deviation of the position error, millimetres.
    pub std_mm: f64,
    /// Mean number of taxels fitted (taxels with fewer samples than asked are left out).
    pub fitted: f64,
}

/// The error as a function of the samples per taxel (Fig. 7.9): for each count, `trials`
/// calibrations in which every taxel keeps a random subset of that many of its samples.
pub fn convergence_curve(
    dataset: &ProbeDataset,
    truth: &LinkSkin,
    counts: &[usize],
    trials: usize,
    seed: u64,
    options: &CalibrationOptions,
) -> Vec<CurvePoint> {
    let by_taxel = dataset.by_taxel();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let options = CalibrationOptions {
        min_responses: 5,
        ..*options
    };
    // The normals' side comes from the whole dataset, not from a subset.
    let outward = outward_of(dataset, &options);
    counts
        .iter()
        .map(|&n| {
            let (mut mean, mut std, mut fitted) = (0.0, 0.0, 0.0);
            for _ in 0..trials.max(1) {
                // Each taxel keeps a random n of its samples.
                let mut subset = BTreeMap::new();
                for (id, s) in &by_taxel {
                    if s.centroids.len() < n {
                        continue;
                    }
                    let mut pick: Vec<usize> = (0..s.centroids.len()).collect();
                    pick.shuffle(&mut rng);
                    let keep = &pick[..n];
                    subset.insert(
                        *id,
                        TaxelSamples {
                            centroids: keep.iter().map(|&k| s.centroids[k]).collect(),
                            responses: keep.iter().map(|&k| s.responses[k]).collect(),
                        },
                    );
                }
                let report = calibrate_taxels(subset, &outward, &options);
                let e = CalibrationErrors::compare(&report, truth);
                mean += e.mean_mm;
                std += e.std_mm;
                fitted += e.compared as f64;
            }
            let t = trials.max(1) as f64;
            CurvePoint {
                samples: n,
                mean_mm: mean / t,
                std_mm: std / t,
                fitted: fitted / t,
            }
        })
        .collect()
}

/// The convergence curve as a small SVG plot (mean error with a +- one standard deviation band).
pub fn curve_svg(curve: &[CurvePoint], title: &str) -> String {
    let (w, h, left, bottom, top, right) = (560.0, 340.0, 60.0, 50.0, 30.0, 20.0);
    let x_max = curve.iter().map(|p| p.samples).max().unwrap_or(1).max(1) as f64;
    let y_max = curve
        .iter()
        .map(|p| p.mean_mm + p.std_mm)
        .fold(1.0, f64::max)
        .ceil();
    let x = |v: f64| left + (w - left - right) * v / x_max;
    let y = |v: f64| h - bottom - (h - bottom - top) * v / y_max;
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"{}\" y=\"18\" text-anchor=\"middle\">{}</text>\n",
        w / 2.0,
        escape(title)
    );
    let _ = writeln!(
        s,
        "<line x1=\"{left}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"black\"/><line x1=\"{left}\" y1=\"{top}\" x2=\"{left}\" y2=\"{}\" stroke=\"black\"/>",
        h - bottom,
        w - right,
        h - bottom,
        h - bottom
    );
    for k in 0..=4 {
        let v = y_max * f64::from(k) / 4.0;
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{v:.1}</text>",
            left - 6.0,
            y(v) + 4.0
        );
    }
    for p in curve {
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
            x(p.samples as f64),
            h - bottom + 16.0,
            p.samples
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">samples per taxel</text>\n<text transform=\"translate(16 {}) rotate(-90)\" text-anchor=\"middle\">position error, mm</text>",
        (left + w - right) / 2.0,
        h - 12.0,
        (top + h - bottom) / 2.0
    );
    let band: Vec<String> = curve
        .iter()
        .map(|p| format!("{:.1},{:.1}", x(p.samples as f64), y(p.mean_mm + p.std_mm)))
        .chain(curve.iter().rev().map(|p| {
            format!(
                "{:.1},{:.1}",
                x(p.samples as f64),
                y((p.mean_mm - p.std_mm).max(0.0))
            )
        }))
        .collect();
    let line: Vec<String> = curve
        .iter()
        .map(|p| format!("{:.1},{:.1}", x(p.samples as f64), y(p.mean_mm)))
        .collect();
    let _ = writeln!(
        s,
        "<polygon points=\"{}\" fill=\"#9ecae1\" fill-opacity=\"0.6\"/>\n<polyline points=\"{}\" fill=\"none\" stroke=\"#08519c\" stroke-width=\"2\"/>",
        band.join(" "),
        line.join(" ")
    );
    for p in curve {
        let _ = writeln!(
            s,
            "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3\" fill=\"#08519c\"/>",
            x(p.samples as f64),
            y(p.mean_mm)
        );
    }
    s.push_str("</svg>\n");
    s
}

fn escape(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}
