//! Where to press next: the exploration rule the thesis lists as missing (Ch. 7.4). Every
//! candidate probe point is scored by the samples it would bring to taxels that still lack them,
//! using the taxels' current (CAD or partly calibrated) positions; the best candidate wins.

use nalgebra::Point3;

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
