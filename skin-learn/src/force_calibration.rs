//! Force calibration: a link's [`ForceModel`] fitted from presses with a known load.
//!
//! Each frame `k` with a known total load `F_k` (a load cell's, or a mass resting on the skin)
//! gives one equation in the model's parameters, the shared curve's full scale `C` and
//! half-scale stress `s_half`, and the gain `g_i` of each taxel that was pressed often enough:
//!
//! ```text
//! F_k ~ F^_k = sum_i A_i * s_half * c_ik / (g_i * C - c_ik)      (skin_core::force)
//! ```
//!
//! They are solved together by Levenberg-Marquardt on the relative residuals
//! `(F^_k - F_k) / (F_k + F_0)` (so a 2 N press weighs as much as a 20 N one), each gain held
//! towards 1 by a prior of standard deviation [`ForceFitOptions::gain_sd`] (a taxel seen in few
//! frames keeps about the skin's gain rather than one fitted to its noise). A taxel pressed in
//! fewer than [`ForceFitOptions::min_frames`] frames under a known load gets gain 1 and is
//! listed as such ([`ForceFitReport::unloaded_taxels`]), never a fitted number.
//!
//! The curve's bend (where `c` nears `g C`) is what tells `C` from `s_half`: loads that never
//! reach it determine only their ratio. The fit then refuses, unless the sensor's full scale is
//! given ([`ForceFitOptions::full_scale`]), rather than return one of infinitely many curves that
//! fit equally well.

use skin_core::force::{ForceError, ForceModel, ResponseCurve};
use skin_core::format::force_file::LinkForce;

mod collect;
mod run;

pub use collect::{CollectError, LoadedFrames};
pub use run::{CalibrateForceError, LinkCalibration, Presses, calibrate_link};

/// The largest [`ForceFitOptions::gain_sd`] taken: a prior that wide holds nothing.
pub const MAX_GAIN_SD: f64 = 10.0;

/// How the fit runs.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceFitOptions {
    /// The sensor's full scale `C`, counts, when known (fixed, not fitted); none to fit it.
    pub full_scale: Option<f64>,
    /// Standard deviation of the prior on each taxel's gain about 1 (0.2: gains within about
    /// +-40% need no strong evidence).
    pub gain_sd: f64,
    /// Frames a taxel must read a load in to get a gain of its own.
    pub min_frames: usize,
    /// `F_0` in the relative residual, N: below it a residual counts in newtons rather than as a
    /// fraction.
    pub force_floor_n: f64,
    /// Largest number of Levenberg-Marquardt steps.
    pub max_iterations: usize,
}

impl Default for ForceFitOptions {
    fn default() -> Self {
        ForceFitOptions {
            full_scale: None,
            gain_sd: 0.2,
            min_frames: 3,
            force_floor_n: 0.5,
            max_iterations: 200,
        }
    }
}

/// One frame of a link under a known load.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadedFrame {
    /// Seconds on the recording's clock.
    pub time_s: f64,
    /// The known load, N.
    pub force_n: f64,
    /// The taxels reading above their baseline: (layout index, counts above the baseline).
    pub readings: Vec<(usize, f32)>,
}

/// Why a fit was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ForceFitError {
    /// Too few frames under a load.
    #[error(
        "{loaded} frame(s) under a load above 0 N with the skin reading it: the fit needs at least {needed} (press longer, or with more loads)"
    )]
    TooFewFrames {
        /// Frames with a load and a reading.
        loaded: usize,
        /// Frames needed.
        needed: usize,
    },
    /// The loads all the same size, with the full scale unknown.
    #[error(
        "the loads span {min_n:.3} to {max_n:.3} N and the largest reading is {top:.0} counts: they do not reach the response curve's bend, so its full scale and half-scale stress cannot be told apart. Press harder (towards the sensor's full scale), with loads over a wider range, or give the sensor's full scale in counts"
    )]
    Undetermined {
        /// The smallest load, N.
        min_n: f64,
        /// The largest load, N.
        max_n: f64,
        /// The largest reading, counts above the baseline.
        top: f64,
    },
    /// A taxel index past the areas given.
    #[error("frame at {time_s} s: taxel {taxel} is past the link's {taxels} taxels")]
    Taxel {
        /// The frame's time.
        time_s: f64,
        /// The index.
        taxel: usize,
        /// Taxels of the link.
        taxels: usize,
    },
    /// A number that is not finite, or a given full scale that is not positive.
    #[error("{what} is {value}: it must be a positive, finite number")]
    Number {
        /// What it is.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// The model the fit arrived at was refused (a taxel with no area).
    #[error(transparent)]
    Model(#[from] ForceError),
}

/// How one press (a run of consecutive loaded frames) came out.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PressResidual {
    /// Its first and last frame's times, seconds.
    pub start_s: f64,
    /// Its last frame's time, seconds.
    pub end_s: f64,
    /// Frames in it.
    pub frames: usize,
    /// The known load, mean over its frames, N.
    pub load_n: f64,
    /// The model's force, mean over its frames, N.
    pub fitted_n: f64,
    /// `(fitted - load) / load`, mean over its frames.
    pub relative: f64,
}

/// What the fit did and how well the model explains the loads.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ForceFitReport {
    /// Frames fitted (loaded, or at 0 N within the load's span).
    pub frames: usize,
    /// Coefficient of determination of the model's force against the loads, over those frames;
    /// none when every frame had the same load (nothing to explain).
    pub r_squared: Option<f64>,
    /// Root mean square of the force residuals, N.
    pub rms_n: f64,
    /// Each press's residual, in time order.
    pub presses: Vec<PressResidual>,
    /// Taxels given a gain of their own.
    pub fitted_taxels: usize,
    /// Taxels (layout indices) that read a load in fewer than [`ForceFitOptions::min_frames`]
    /// frames: they got gain 1, the skin's typical taxel, not a fitted one.
    pub unloaded_taxels: Vec<usize>,
    /// Whether the full scale was given (fixed) rather than fitted.
    pub full_scale_given: bool,
    /// Readings past the curve's saturation at the fitted model (lower bounds in the fit).
    pub saturated_readings: usize,
    /// Levenberg-Marquardt steps taken.
    pub iterations: usize,
}

/// A fitted force model and its report.
#[derive(Debug, Clone)]
pub struct ForceFit {
    /// The model: the curve, one gain per taxel, the areas given.
    pub model: ForceModel,
    /// How it came out.
    pub report: ForceFitReport,
}

impl ForceFit {
    /// The fit as a link's entry in a force calibration file: the curve, the gains by the
    /// link's taxel `ids` (layout order), and the report.
    pub fn link_force(&self, name: &str, ids: &[skin_core::TaxelId]) -> LinkForce {
        LinkForce {
            name: name.to_owned(),
            curve: self.model.curve(),
            ids: ids.iter().map(|id| id.0).collect(),
            gains: self.model.gains().to_vec(),
            // Plain numbers and lists: serializing does not fail.
            fit: serde_json::to_value(&self.report).unwrap_or_default(),
        }
    }
}

/// The skin area each taxel of a tactile map's link stands for, m² (layout order), from the
/// map's triangles in 3D: what a fit and the session's force model are built on.
pub fn link_areas(map: &skin_geom::TactileMap) -> Result<Vec<f64>, ForceError> {
    skin_core::force::taxel_areas(&map.positions, &map.faces)
}

/// Frames with a load and a reading needed at the least.
const MIN_LOADED_FRAMES: usize = 3;

/// The smallest relative force residual a fit is judged with, however well it fits: 1%, about
/// what a good load cell and rig give.
const RESIDUAL_FLOOR: f64 = 0.01;

/// The largest standard deviation of the full scale's logarithm that a fit may leave (10%).
const FULL_SCALE_SD: f64 = 0.1;

/// Fits a link's force model to `frames` (its taxels' `areas`, m², in layout order; see the
/// [module](self)).
pub fn fit_force(
    frames: &[LoadedFrame],
    areas: &[f64],
    options: &ForceFitOptions,
) -> Result<ForceFit, ForceFitError> {
    let n = areas.len();
    check_inputs(frames, n, options)?;
    let loaded = frames
        .iter()
        .filter(|f| f.force_n > 0.0 && f.readings.iter().any(|r| r.1 > 0.0))
        .count();
    if loaded < MIN_LOADED_FRAMES {
        return Err(ForceFitError::TooFewFrames {
            loaded,
            needed: MIN_LOADED_FRAMES,
        });
    }
    // Which taxels get a gain of their own: parameter 2 + slot[i].
    let mut seen = vec![0usize; n];
    for f in frames.iter().filter(|f| f.force_n > 0.0) {
        for &(i, c) in &f.readings {
            seen[i] += usize::from(c > 0.0);
        }
    }
    let mut slot = vec![usize::MAX; n];
    let mut own = 0;
    for i in 0..n {
        if seen[i] >= options.min_frames.max(1) {
            slot[i] = own;
            own += 1;
        }
    }
    let top = frames
        .iter()
        .flat_map(|f| f.readings.iter().map(|r| f64::from(r.1)))
        .fold(0.0, f64::max);
    // First the shared curve alone: how far the loads scatter about it says how much a
    // frame's residual weighs against the gains' prior.
    let shared = vec![usize::MAX; n];
    let mut problem = Problem {
        frames,
        areas,
        slot: &shared,
        options,
        residual_sd: 1.0,
    };
    let mut curve = vec![options.full_scale.unwrap_or(top / 0.7).ln(), 0.0];
    curve[1] = problem.best_half_scale(&curve).ln();
    let (curve, first) = problem.levenberg_marquardt(curve);
    problem.residual_sd = problem.residual_sd(&curve);
    problem.slot = &slot;
    let mut theta = vec![0.0; 2 + own];
    theta[..2].copy_from_slice(&curve);
    let (theta, iterations) = problem.levenberg_marquardt(theta);
    let iterations = first + iterations;
    if options.full_scale.is_none() {
        problem.check_determined(&theta, top)?;
    }
    let curve = ResponseCurve {
        full_scale: options.full_scale.unwrap_or(theta[0].exp()),
        half_scale_kpa: theta[1].exp(),
    };
    let gains: Vec<f64> = (0..n).map(|i| problem.gain(&theta, i)).collect();
    let model = ForceModel::new(curve, gains, areas.to_vec())?;
    let report = problem.report(&model, own, iterations);
    Ok(ForceFit { model, report })
}

fn check_inputs(frames: &[LoadedFrame], n: usize, options: &ForceFitOptions) -> Result<(), ForceFitError> {
    if let Some(c) = options.full_scale
        && !(c.is_finite() && c > 0.0)
    {
        return Err(ForceFitError::Number {
            what: "the full scale",
            value: c,
        });
    }
    for f in frames {
        if !(f.force_n.is_finite() && f.force_n >= 0.0) {
            return Err(ForceFitError::Number {
                what: "a frame's load",
                value: f.force_n,
            });
        }
        for &(taxel, c) in &f.readings {
            if taxel >= n {
                return Err(ForceFitError::Taxel {
                    time_s: f.time_s,
                    taxel,
                    taxels: n,
                });
            }
            if !c.is_finite() {
                return Err(ForceFitError::Number {
                    what: "a reading",
                    value: f64::from(c),
                });
            }
        }
    }
    Ok(())
}

/// The least-squares problem: parameters `[ln C, ln s_half, ln g_j...]`.
struct Problem<'a> {
    frames: &'a [LoadedFrame],
    areas: &'a [f64],
    slot: &'a [usize],
    options: &'a ForceFitOptions,
    /// The relative force residual one frame is expected to have (at least
    /// [`RESIDUAL_FLOOR`]): residuals count in units of it against the gains' prior.
    residual_sd: f64,
}

impl Problem<'_> {
    fn gain(&self, theta: &[f64], i: usize) -> f64 {
        match self.slot[i] {
            usize::MAX => 1.0,
            j => theta[2 + j].exp(),
        }
    }

    fn weight(&self, f: &LoadedFrame) -> f64 {
        1.0 / ((f.force_n + self.options.force_floor_n) * self.residual_sd)
    }

    /// The root mean square relative residual at `theta`, at least [`RESIDUAL_FLOOR`].
    fn residual_sd(&self, theta: &[f64]) -> f64 {
        let data: f64 = self
            .frames
            .iter()
            .map(|f| ((self.predict(theta, f, None) - f.force_n) * self.weight(f)).powi(2))
            .sum();
        let dof = self.frames.len().saturating_sub(theta.len()).max(1) as f64;
        (self.residual_sd * (data / dof).sqrt()).max(RESIDUAL_FLOOR)
    }

    /// Frame `f`'s modelled force, and (with `grad`) its derivative by each parameter, as
    /// (parameter, value) pairs.
    fn predict(&self, theta: &[f64], f: &LoadedFrame, mut grad: Option<&mut Vec<(usize, f64)>>) -> f64 {
        let (c_full, half) = (theta[0].exp(), theta[1].exp());
        let mut total = 0.0;
        let mut d_full = 0.0;
        if let Some(g) = grad.as_deref_mut() {
            g.clear();
        }
        for &(i, c) in &f.readings {
            let c = f64::from(c).max(0.0);
            let top = self.gain(theta, i) * c_full;
            let limit = ForceModel::SATURATION * top;
            let (c, saturated) = if c >= limit { (limit, true) } else { (c, false) };
            let term = 1e3 * self.areas[i] * half * c / (top - c);
            total += term;
            // d term / d ln(top): -term * top / (top - c); nothing once saturated (the reading
            // is then held at a fraction of top, and the term does not move with it).
            let d_top = if saturated { 0.0 } else { -term * top / (top - c) };
            d_full += d_top;
            if let (Some(g), j) = (grad.as_deref_mut(), self.slot[i])
                && j != usize::MAX
            {
                g.push((2 + j, d_top));
            }
        }
        if let Some(g) = grad {
            if self.options.full_scale.is_none() {
                g.push((0, d_full));
            }
            g.push((1, total));
        }
        total
    }

    fn cost(&self, theta: &[f64]) -> f64 {
        let data: f64 = self
            .frames
            .iter()
            .map(|f| ((self.predict(theta, f, None) - f.force_n) * self.weight(f)).powi(2))
            .sum();
        let prior: f64 = theta[2..]
            .iter()
            .map(|d| (d / self.options.gain_sd).powi(2))
            .sum();
        data + prior
    }

    /// The half-scale stress that fits best with the other parameters as they are (the force
    /// is proportional to it): the start of the fit.
    fn best_half_scale(&self, theta: &[f64]) -> f64 {
        let mut unit = theta.to_vec();
        unit[1] = 0.0;
        let (mut num, mut den) = (0.0, 0.0);
        for f in self.frames {
            let w = self.weight(f);
            let p = self.predict(&unit, f, None);
            num += w * w * p * f.force_n;
            den += w * w * p * p;
        }
        if den > 0.0 && num > 0.0 { num / den } else { 1.0 }
    }

    /// `J^T J` and `J^T r` (data and prior) at `theta`.
    fn normal_equations(&self, theta: &[f64]) -> (nalgebra::DMatrix<f64>, nalgebra::DVector<f64>) {
        let p = theta.len();
        let mut jtj = nalgebra::DMatrix::zeros(p, p);
        let mut jtr = nalgebra::DVector::zeros(p);
        let mut grad = Vec::new();
        for f in self.frames {
            let w = self.weight(f);
            let r = (self.predict(theta, f, Some(&mut grad)) - f.force_n) * w;
            for &(a, da) in &grad {
                jtr[a] += w * da * r;
                for &(b, db) in &grad {
                    jtj[(a, b)] += w * w * da * db;
                }
            }
        }
        let prior = 1.0 / (self.options.gain_sd * self.options.gain_sd);
        for k in 2..p {
            jtj[(k, k)] += prior;
            jtr[k] += theta[k] * prior;
        }
        if self.options.full_scale.is_some() {
            jtj[(0, 0)] = 1.0; // C is fixed: its row and column stay zero but for this
        }
        (jtj, jtr)
    }

    fn levenberg_marquardt(&self, mut theta: Vec<f64>) -> (Vec<f64>, usize) {
        let mut lambda = 1e-3;
        let mut cost = self.cost(&theta);
        let mut iterations = 0;
        while iterations < self.options.max_iterations {
            iterations += 1;
            let (jtj, jtr) = self.normal_equations(&theta);
            let mut damped = jtj.clone();
            for k in 0..theta.len() {
                damped[(k, k)] += lambda * jtj[(k, k)].max(1e-12);
            }
            let Some(chol) = damped.cholesky() else {
                lambda *= 10.0;
                continue;
            };
            let step = chol.solve(&(-&jtr));
            let trial: Vec<f64> = theta
                .iter()
                .zip(step.iter())
                .map(|(t, s)| t + s.clamp(-1.0, 1.0))
                .collect();
            let trial_cost = self.cost(&trial);
            if trial_cost.is_finite() && trial_cost < cost {
                let gain = cost - trial_cost;
                theta = trial;
                cost = trial_cost;
                lambda = (lambda / 3.0).max(1e-12);
                if gain < 1e-12 * (1.0 + cost) {
                    break;
                }
            } else {
                lambda *= 4.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
        (theta, iterations)
    }

    /// Refuses a fit whose full scale the loads leave open: its standard deviation, from the
    /// fit's covariance scaled by the residuals (at least [`RESIDUAL_FLOOR`]: no rig is better),
    /// is past [`FULL_SCALE_SD`] of it. Loads that never bend the curve leave the full scale and
    /// the half-scale stress moving together, and only their ratio known.
    fn check_determined(&self, theta: &[f64], top: f64) -> Result<(), ForceFitError> {
        // The covariance of the parameters is (J^T J)^-1 in units of the residuals' spread,
        // which the weights already divide by.
        let (jtj, _) = self.normal_equations(theta);
        let sigma = self.residual_sd(theta) / self.residual_sd;
        let sd = jtj
            .try_inverse()
            .map_or(f64::INFINITY, |cov| sigma * cov[(0, 0)].sqrt());
        if sd.is_finite() && sd < FULL_SCALE_SD {
            return Ok(());
        }
        let loads = self.frames.iter().filter(|f| f.force_n > 0.0).map(|f| f.force_n);
        let (min_n, max_n) = loads.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
        Err(ForceFitError::Undetermined { min_n, max_n, top })
    }

    fn report(&self, model: &ForceModel, fitted_taxels: usize, iterations: usize) -> ForceFitReport {
        let mut seen = vec![0usize; self.areas.len()];
        let (mut ss_res, mut saturated) = (0.0, 0);
        let mut presses: Vec<PressResidual> = Vec::new();
        let mut open = false;
        let mut fitted = Vec::with_capacity(self.frames.len());
        for f in self.frames {
            let mut total = 0.0;
            for &(i, c) in &f.readings {
                let (force, sat) = model.force(i, f64::from(c));
                total += force;
                saturated += usize::from(sat);
                if f.force_n > 0.0 && c > 0.0 {
                    seen[i] += 1;
                }
            }
            fitted.push(total);
            ss_res += (total - f.force_n).powi(2);
            if f.force_n > 0.0 {
                let rel = (total - f.force_n) / f.force_n;
                match (open, presses.last_mut()) {
                    (true, Some(p)) => {
                        let k = p.frames as f64;
                        p.end_s = f.time_s;
                        p.load_n = (p.load_n * k + f.force_n) / (k + 1.0);
                        p.fitted_n = (p.fitted_n * k + total) / (k + 1.0);
                        p.relative = (p.relative * k + rel) / (k + 1.0);
                        p.frames += 1;
                    }
                    _ => presses.push(PressResidual {
                        start_s: f.time_s,
                        end_s: f.time_s,
                        frames: 1,
                        load_n: f.force_n,
                        fitted_n: total,
                        relative: rel,
                    }),
                }
            }
            open = f.force_n > 0.0;
        }
        let count = self.frames.len().max(1) as f64;
        let mean = self.frames.iter().map(|f| f.force_n).sum::<f64>() / count;
        let ss_tot: f64 = self.frames.iter().map(|f| (f.force_n - mean).powi(2)).sum();
        let min = self.options.min_frames.max(1);
        ForceFitReport {
            frames: self.frames.len(),
            r_squared: (ss_tot > 0.0).then(|| 1.0 - ss_res / ss_tot),
            rms_n: (ss_res / count).sqrt(),
            presses,
            fitted_taxels,
            unloaded_taxels: (0..self.areas.len()).filter(|&i| seen[i] < min).collect(),
            full_scale_given: self.options.full_scale.is_some(),
            saturated_readings: saturated,
            iterations,
        }
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)] // a failed set-up should stop the test
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const TRUE: ResponseCurve = ResponseCurve {
        full_scale: 4095.0,
        half_scale_kpa: 150.0,
    };

    /// A 12 x 12 grid, 6 mm pitch: every taxel stands for 36 mm² (edges aside).
    fn areas() -> Vec<f64> {
        let n = 12;
        let points: Vec<_> = (0..n * n)
            .map(|i| nalgebra::Point3::new((i % n) as f64 * 0.006, (i / n) as f64 * 0.006, 0.0))
            .collect();
        let mut faces = Vec::new();
        for r in 0..n - 1 {
            for c in 0..n - 1 {
                let i = r * n + c;
                faces.push([i, i + 1, i + n + 1]);
                faces.push([i, i + n + 1, i + n]);
            }
        }
        skin_core::force::taxel_areas(&points, &faces).unwrap()
    }

    /// Presses of a round load, `radius` taxels wide, at random places with forces in
    /// `forces`, read through `gains` and the true curve with `noise` counts.
    fn presses(gains: &[f64], forces: (f64, f64), count: usize, noise: f64, seed: u64) -> Vec<LoadedFrame> {
        let areas = areas();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let n = 12;
        (0..count)
            .map(|k| {
                let (cr, cc) = (rng.random_range(2.0..9.0), rng.random_range(2.0..9.0));
                let force: f64 = rng.random_range(forces.0..forces.1);
                let under: Vec<usize> = (0..n * n)
                    .filter(|i| {
                        let (r, c) = ((i / n) as f64, (i % n) as f64);
                        (r - cr).powi(2) + (c - cc).powi(2) <= 2.0f64.powi(2)
                    })
                    .collect();
                let area: f64 = under.iter().map(|&i| areas[i]).sum();
                let stress = force / area / 1e3; // kPa, uniform under the load
                let readings = under
                    .iter()
                    .map(|&i| {
                        let c = TRUE.counts(stress, gains[i]) + noise * rng.random_range(-1.0..1.0);
                        (i, c.max(0.0) as f32)
                    })
                    .collect();
                LoadedFrame {
                    time_s: k as f64 * 0.05,
                    force_n: force,
                    readings,
                }
            })
            .collect()
    }

    fn gains(seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..144).map(|_| rng.random_range(0.85..1.15)).collect()
    }

    #[test]
    fn the_fit_finds_the_curve_and_the_gains_of_a_simulated_skin() {
        let g = gains(1);
        let frames = presses(&g, (1.0, 30.0), 400, 1.0, 2);
        let fit = fit_force(&frames, &areas(), &ForceFitOptions::default()).unwrap();
        let curve = fit.model.curve();
        // The curve and every gain are found up to one common scale (a gain of 1 is the skin's
        // typical taxel, not the true curve's), so compare what the skin reads: g_i * C.
        let scale = curve.full_scale / TRUE.full_scale;
        assert!(
            (curve.half_scale_kpa / TRUE.half_scale_kpa - 1.0).abs() < 0.05,
            "{curve:?}"
        );
        // Taxels pressed in many frames have their own gain; the few pressed rarely stay near
        // the skin's (the prior), which is the point of it.
        let mut seen = [0; 144];
        for f in &frames {
            for &(i, _) in &f.readings {
                seen[i] += 1;
            }
        }
        let mut errors: Vec<f64> = (0..144)
            .filter(|&i| seen[i] >= 40)
            .map(|i| (fit.model.gains()[i] * scale / g[i] - 1.0).abs())
            .collect();
        errors.sort_by(f64::total_cmp);
        let (median, worst) = (errors[errors.len() / 2], errors[errors.len() - 1]);
        assert!(
            median < 0.02 && worst < 0.08,
            "gain errors: median {median}, worst {worst}"
        );
        let well_seen = seen.iter().filter(|&&k| k >= 40).count();
        assert!(well_seen >= 30, "{well_seen} taxels pressed in 40 frames or more");
        assert!(
            fit.report.r_squared.is_some_and(|r| r > 0.999),
            "{:?}",
            fit.report
        );
        // Held-out presses elsewhere, with a gain spread the fit knew: within 2%.
        let check = presses(&g, (2.0, 20.0), 100, 1.0, 3);
        for f in &check {
            let total: f64 = f
                .readings
                .iter()
                .map(|&(i, c)| fit.model.force(i, f64::from(c)).0)
                .sum();
            assert!(
                (total / f.force_n - 1.0).abs() < 0.02,
                "{total} N for {} N",
                f.force_n
            );
        }
    }

    #[test]
    fn a_given_full_scale_fits_one_load_and_loads_that_miss_the_bend_are_refused() {
        let g = vec![1.0; 144];
        // Light loads only: the readings stay on the curve's straight part.
        let light = presses(&g, (0.5, 0.6), 60, 1.0, 4);
        let e = fit_force(&light, &areas(), &ForceFitOptions::default()).unwrap_err();
        assert!(matches!(e, ForceFitError::Undetermined { .. }), "{e}");
        assert!(e.to_string().contains("full scale"), "{e}");
        let fixed = ForceFitOptions {
            full_scale: Some(TRUE.full_scale),
            ..ForceFitOptions::default()
        };
        let fit = fit_force(&light, &areas(), &fixed).unwrap();
        assert!((fit.model.curve().half_scale_kpa / TRUE.half_scale_kpa - 1.0).abs() < 0.02);
        assert!(fit.report.full_scale_given);
    }

    #[test]
    fn too_little_load_is_refused_and_untouched_taxels_are_listed() {
        let g = vec![1.0; 144];
        let mut frames = presses(&g, (5.0, 6.0), 2, 0.0, 5);
        let e = fit_force(&frames, &areas(), &ForceFitOptions::default()).unwrap_err();
        assert_eq!(e, ForceFitError::TooFewFrames { loaded: 2, needed: 3 });
        for f in &mut frames {
            f.force_n = 0.0;
        }
        assert!(fit_force(&frames, &areas(), &ForceFitOptions::default()).is_err());
        let frames = presses(&g, (1.0, 30.0), 200, 0.0, 6);
        let fit = fit_force(&frames, &areas(), &ForceFitOptions::default()).unwrap();
        // The presses' centres stay 2 taxels in: the corners are never pressed.
        assert!(
            fit.report.unloaded_taxels.contains(&0),
            "{:?}",
            fit.report.unloaded_taxels
        );
        assert_eq!(fit.model.gains()[0], 1.0);
        let bad = vec![LoadedFrame {
            time_s: 0.0,
            force_n: 1.0,
            readings: vec![(500, 10.0)],
        }];
        assert!(matches!(
            fit_force(&bad, &areas(), &ForceFitOptions::default()),
            Err(ForceFitError::Taxel { taxel: 500, .. })
        ));
    }
}
