//! The tables of the reach experiment (like the thesis' Tables 8.1 and 8.2), with 95% confidence
//! intervals: Wilson's score interval for a success rate (sound for small samples and rates near
//! 0 or 1, where the normal approximation is not) and Student's t interval for a mean.

use super::reach::{Outcome, Trial};
use std::fmt::Write;

/// z of a two-sided 95% interval.
const Z95: f64 = 1.959_963_984_540_054;

/// Wilson's 95% score interval for `k` successes in `n` trials, as fractions; (0, 1) for n = 0.
pub fn wilson(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (k, n) = (k as f64, n as f64);
    let p = k / n;
    let z2 = Z95 * Z95;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = Z95 / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// Two-sided 97.5% quantile of Student's t with `dof` degrees of freedom (table for 1-30,
/// then the normal's, which is within 2% beyond).
fn t975(dof: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145,
        2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048,
        2.045, 2.042,
    ];
    match dof {
        0 => f64::INFINITY,
        d if d <= 30 => T[d - 1],
        _ => Z95,
    }
}

/// Mean and the half-width of its 95% t interval (infinite for fewer than two values); None for
/// no values.
pub fn mean_ci(values: &[f64]) -> Option<(f64, f64)> {
    if values.is_empty() {
        return None;
    }
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    if values.len() < 2 {
        return Some((mean, f64::INFINITY));
    }
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    Some((mean, t975(values.len() - 1) * (var / n).sqrt()))
}

/// Counts of one group of trials.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counts {
    /// Trials.
    pub trials: usize,
    /// Successes.
    pub success: usize,
    /// Failures by force above the threshold.
    pub force: usize,
    /// Failures by stall.
    pub stall: usize,
    /// Failures by timeout.
    pub timeout: usize,
}

/// Counts of `trials`.
pub fn counts<'a>(trials: impl IntoIterator<Item = &'a Trial>) -> Counts {
    let mut c = Counts::default();
    for t in trials {
        c.trials += 1;
        match t.outcome {
            Outcome::Success => c.success += 1,
            Outcome::Force => c.force += 1,
            Outcome::Stall => c.stall += 1,
            Outcome::Timeout => c.timeout += 1,
        }
    }
    c
}

fn row(out: &mut String, name: &str, trials: &[&Trial]) {
    let c = counts(trials.iter().copied());
    let (lo, hi) = wilson(c.success, c.trials);
    // Force statistics over the successful trials, as in the thesis.
    let forces: Vec<f64> = trials
        .iter()
        .filter(|t| t.outcome == Outcome::Success)
        .map(|t| t.max_force)
        .collect();
    let force = match mean_ci(&forces) {
        None => format!("{:>15}", "-"),
        Some((m, h)) if h.is_finite() => format!("{m:>6.2} +- {h:<5.2}"),
        Some((m, _)) => format!("{m:>6.2} +- {:<5}", "inf"),
    };
    let min = forces.iter().copied().fold(f64::INFINITY, f64::min);
    let max = forces.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (min, max) = if forces.is_empty() {
        ("-".to_string(), "-".to_string())
    } else {
        (format!("{min:.2}"), format!("{max:.2}"))
    };
    let _ = writeln!(
        out,
        "{name:<6} {:>3}/{:<3} {:>5.1}%  [{:>5.1}, {:>5.1}]  {force}  {min:>6}  {max:>6}  {:>5}  {:>5}  {:>7}",
        c.success,
        c.trials,
        100.0 * c.success as f64 / c.trials.max(1) as f64,
        100.0 * lo,
        100.0 * hi,
        c.force,
        c.stall,
        c.timeout
    );
}

/// The table of a run: one row per goal (A, B, ...) and a total. Force columns are over the
/// successful trials (the per-trial maximum contact force: mean with its 95% interval, smallest,
/// largest); the last three count the failures by cause.
pub fn table(trials: &[Trial], goals: usize, threshold: f64, no_skin: bool) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "F_thresh = {threshold} N{}; success = within tolerance of the goal, no force above F_thresh",
        if no_skin { ", WITHOUT skin (baseline)" } else { "" }
    );
    let _ = writeln!(
        out,
        "{:<6} {:>7} {:>6}  {:>14}  {:>15}  {:>6}  {:>6}  {:>5}  {:>5}  {:>7}",
        "goal", "success", "", "95% CI", "F mean (N)", "F_m", "F_M", "force", "stall", "timeout"
    );
    for g in 0..goals {
        let these: Vec<&Trial> = trials.iter().filter(|t| t.goal == g).collect();
        row(&mut out, &goal_name(g), &these);
    }
    let all: Vec<&Trial> = trials.iter().collect();
    row(&mut out, "all", &all);
    out
}

/// The trials of one seed (its own random starts): with the skin, and without it when the
/// baseline was run.
#[derive(Debug, Clone)]
pub struct SeedRun {
    /// The seed of the starting postures.
    pub seed: u64,
    /// Every trial with the skin.
    pub skin: Vec<Trial>,
    /// The same trials without it (the baseline), when run.
    pub baseline: Option<Vec<Trial>>,
}

fn rate(trials: &[Trial]) -> String {
    let c = counts(trials);
    let (lo, hi) = wilson(c.success, c.trials);
    format!(
        "{:>4}/{:<4} {:>5.1}% [{:>5.1}, {:>5.1}]",
        c.success,
        c.trials,
        100.0 * c.success as f64 / c.trials.max(1) as f64,
        100.0 * lo,
        100.0 * hi
    )
}

fn seed_means(rates: &[f64]) -> String {
    match mean_ci(rates) {
        Some((m, h)) if h.is_finite() => format!("{:.1}% +- {:.1}", 100.0 * m, 100.0 * h),
        Some((m, _)) => format!("{:.1}%", 100.0 * m),
        None => "-".into(),
    }
}

/// The success rate of each seed with its 95% Wilson interval, with and without the skin, then
/// all seeds pooled, then the mean of the seeds' rates with its 95% t interval (the seeds are
/// the independent samples: a scene's starts from one seed are not).
pub fn seeds_table(runs: &[SeedRun], threshold: f64) -> String {
    let mut out = String::new();
    let baseline = runs.iter().all(|r| r.baseline.is_some());
    let _ = writeln!(
        out,
        "success per seed, F_thresh = {threshold} N (95% Wilson interval){}",
        if baseline {
            "; without skin: the baseline, same starts"
        } else {
            ""
        }
    );
    let _ = writeln!(
        out,
        "{:<6} {:<30}{}",
        "seed",
        "with skin",
        if baseline { "  without skin" } else { "" }
    );
    let rate_of = |t: &[Trial]| counts(t).success as f64 / counts(t).trials.max(1) as f64;
    for r in runs {
        let base = r
            .baseline
            .as_deref()
            .map_or(String::new(), |b| format!("  {}", rate(b)));
        let _ = writeln!(out, "{:<6} {:<30}{base}", r.seed, rate(&r.skin));
    }
    let skin: Vec<Trial> = runs.iter().flat_map(|r| r.skin.iter().cloned()).collect();
    let pooled_base: Vec<Trial> = runs
        .iter()
        .flat_map(|r| r.baseline.iter().flatten().cloned())
        .collect();
    let base = if baseline {
        format!("  {}", rate(&pooled_base))
    } else {
        String::new()
    };
    let _ = writeln!(out, "{:<6} {:<30}{base}", "all", rate(&skin));
    let skin_rates: Vec<f64> = runs.iter().map(|r| rate_of(&r.skin)).collect();
    let base_rates: Vec<f64> = runs
        .iter()
        .filter_map(|r| r.baseline.as_deref().map(rate_of))
        .collect();
    let _ = writeln!(
        out,
        "mean over {} seeds (95% t interval): with skin {}{}",
        runs.len(),
        seed_means(&skin_rates),
        if baseline {
            format!(", without skin {}", seed_means(&base_rates))
        } else {
            String::new()
        }
    );
    out
}

/// A, B, ..., Z, then G27, G28, ...
pub fn goal_name(g: usize) -> String {
    if g < 26 {
        char::from(b'A' + g as u8).to_string()
    } else {
        format!("G{}", g + 1)
    }
}
