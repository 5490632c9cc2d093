//! Where to press next: the exploration rule the thesis lists as missing (Ch. 7.4). Every
//! candidate probe point is scored by the samples it would bring to taxels that still lack them,
//! using the taxels' current (CAD or partly calibrated) positions; the best candidate wins.

use super::{CalibrationReport, Status};
use nalgebra::Point3;
use skin_core::TaxelId;

/// The candidate (index into `candidates`) whose press would help most: the sum, over taxels
/// within `reach` metres of it, of how many samples each still lacks to reach `wanted`. `None`
/// when every taxel within reach of every candidate has its samples (exploration is done). Ties go
/// to the lowest index, so the rule is deterministic. Remove a candidate once pressed: repeated
/// presses at one point add samples but not the spread of positions a Gaussian fit needs.
pub fn next_probe_point(
    candidates: &[Point3<f64>],
    taxels: &[Point3<f64>],
    samples: &[usize],
    wanted: usize,
    reach: f64,
) -> Option<usize> {
    let mut best: Option<(usize, usize)> = None;
    for (k, c) in candidates.iter().enumerate() {
        let score: usize = taxels
            .iter()
            .zip(samples)
            .filter(|(t, _)| (*t - c).norm() <= reach)
            .map(|(_, &s)| wanted.saturating_sub(s))
            .sum();
        if score > 0 && best.is_none_or(|(_, b)| score > b) {
            best = Some((k, score));
        }
    }
    best.map(|(k, _)| k)
}

/// After a calibration: for each taxel its contacts did not surround
/// ([`Status::NotSurrounded`]), the candidate (index into `candidates`) nearest the point
/// `step` metres from the taxel toward its open side, within `reach` of that point. `taxels`
/// gives where each taxel is thought to be (CAD or calibrated). One candidate per such taxel,
/// each at most once, in the report's order: press them and calibrate again.
pub fn beyond_edges(
    report: &CalibrationReport,
    taxels: &[(TaxelId, Point3<f64>)],
    candidates: &[Point3<f64>],
    step: f64,
    reach: f64,
) -> Vec<usize> {
    let mut chosen: Vec<usize> = Vec::new();
    for t in &report.taxels {
        let Status::NotSurrounded { toward, .. } = &t.status else {
            continue;
        };
        let Some((_, at)) = taxels.iter().find(|(id, _)| *id == t.id) else {
            continue;
        };
        let target = at + toward.into_inner() * step;
        let best = candidates
            .iter()
            .enumerate()
            .filter(|(k, c)| !chosen.contains(k) && (*c - target).norm() <= reach)
            .min_by(|a, b| (a.1 - target).norm().total_cmp(&(b.1 - target).norm()));
        if let Some((k, _)) = best {
            chosen.push(k);
        }
    }
    chosen
}
