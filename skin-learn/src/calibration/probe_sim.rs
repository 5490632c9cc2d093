//! A probe simulator: realistic calibration datasets from a ground-truth layout.
//!
//! Each contact presses a random point of the patch with about 5 N. A taxel at in-surface distance
//! d answers
//!
//! ```text
//! response = full_scale * peak * gain_j * (F / 5 N) * exp(-d^2 / (2 spread^2)) + noise
//! ```
//! with gain_j a per-taxel factor drawn once (within +-5 %), F the contact's force, noise Gaussian
//! (sigma 1 % of full scale), responses saturating at full scale, and only responses above
//! 3 sigma reported, as a skin's active-set threshold would. The spread (4 mm) stands for the
//! 1 cm probe tip's footprint seen through the skin's elastic cover (the mechanical low-pass of
//! Ch. 7.2.4). The reported centroid carries Gaussian noise (0.5 mm per axis), as one estimated
//! from the arm's kinematics does.
//!
//! Contacts land uniformly over the patch and a margin around it: a random taxel, then a random
//! point within `margin_mm` in its tangent plane, accepted with probability 1 / (number of
//! taxels within `margin_mm`), which makes the density uniform. On a curved link the tangent
//! plane leaves the surface by d^2 / 2R (0.4 mm at 8 mm on a radius of 80 mm).

use super::dataset::{ProbeContact, ProbeDataset};
use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};
use skin_core::LinkSkin;

/// Simulator settings; the defaults are the documented, deliberately harsh ones.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeSimulator {
    /// Width of a taxel's response around the contact (sigma), millimetres. Default 4.
    pub spread_mm: f64,
    /// Mean probe force, newtons. Default 5.
    pub force_n: f64,
    /// Relative standard deviation of the force from contact to contact. Default 0.05.
    pub force_spread: f64,
    /// Per-taxel gains are drawn uniformly in 1 +- this. Default 0.05.
    pub gain_spread: f64,
    /// Full scale of a response (the converter's range), in response units. Default 1000.
    pub full_scale: f64,
    /// Response right over a taxel at the mean force, as a fraction of full scale. Default 0.8.
    pub peak: f64,
    /// Additive noise sigma, as a fraction of full scale. Default 0.01.
    pub noise: f64,
    /// Responses at or under this many noise sigmas are not reported. Default 3.
    pub report_sigmas: f64,
    /// Noise sigma of the reported contact centroid, per axis, millimetres. Default 0.5.
    pub centroid_noise_mm: f64,
    /// Contacts land within this distance of some taxel, millimetres. Default 8 (a pitch).
    pub margin_mm: f64,
}

impl Default for ProbeSimulator {
    fn default() -> Self {
        ProbeSimulator {
            spread_mm: 4.0,
            force_n: 5.0,
            force_spread: 0.05,
            gain_spread: 0.05,
            full_scale: 1000.0,
            peak: 0.8,
            noise: 0.01,
            report_sigmas: 3.0,
            centroid_noise_mm: 0.5,
            margin_mm: 8.0,
        }
    }
}

/// Any vector perpendicular to `n`.
fn tangent(n: &Vector3<f64>) -> Vector3<f64> {
    let a = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    n.cross(&a).normalize()
}

/// A simulated skin being probed: the patch, its taxels' gains, and the random stream. Made by
/// [`ProbeSimulator::session`]; a closed-loop calibration presses where it chooses with
/// [`ProbeSession::press`].
#[derive(Debug, Clone)]
pub struct ProbeSession<'a> {
    sim: ProbeSimulator,
    patch: &'a LinkSkin,
    gains: Vec<f64>,
    rng: ChaCha8Rng,
}

impl ProbeSimulator {
    /// A probing session on `patch`, deterministic for a given `seed`.
    pub fn session<'a>(&self, patch: &'a LinkSkin, seed: u64) -> ProbeSession<'a> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let gains = patch
            .taxels
            .iter()
            .map(|_| 1.0 + self.gain_spread * rng.random_range(-1.0..=1.0))
            .collect();
        ProbeSession {
            sim: *self,
            patch,
            gains,
            rng,
        }
    }

    /// `contacts` presses at random points of `patch`, deterministic for a given `seed`.
    /// Contacts no taxel answered are kept (with no responses): the robot made them too.
    pub fn run(&self, patch: &LinkSkin, contacts: usize, seed: u64) -> ProbeDataset {
        let mut session = self.session(patch, seed);
        let mut dataset = ProbeDataset::default();
        if patch.taxels.is_empty() {
            return dataset;
        }
        while dataset.contacts.len() < contacts {
            let Some(point) = session.random_point() else {
                continue;
            };
            let force =
                self.force_n * (1.0 + self.force_spread * session.rng.sample::<f64, _>(StandardNormal));
            dataset.contacts.push(session.press(&point, force));
        }
        dataset
    }
}

impl ProbeSession<'_> {
    /// A uniformly random point of the patch and its margin, or `None` for a rejected draw (call
    /// again).
    fn random_point(&mut self) -> Option<Point3<f64>> {
        let taxels = &self.patch.taxels;
        let margin = self.sim.margin_mm.max(0.0) * 1e-3;
        // A point within the margin of a random taxel, in its tangent plane...
        let base = &taxels[self.rng.random_range(0..taxels.len())];
        let t1 = tangent(&base.normal);
        let t2 = base.normal.cross(&t1);
        let r = margin * self.rng.random::<f64>().sqrt();
        let phi = self.rng.random_range(0.0..std::f64::consts::TAU);
        let point = base.position + (t1 * phi.cos() + t2 * phi.sin()) * r;
        // ... kept with probability 1 / (taxels within the margin): uniform density.
        let near = taxels
            .iter()
            .filter(|t| (t.position - point).norm_squared() <= margin * margin)
            .count()
            .max(1);
        (self.rng.random_range(0..near) == 0).then_some(point)
    }

    /// The skin's answer to a press at `point` (on the skin) with `force_n` newtons: every
    /// taxel's response as the simulator's model says, and the centroid as the robot would
    /// report it (with its noise).
    pub fn press(&mut self, point: &Point3<f64>, force_n: f64) -> ProbeContact {
        let sim = self.sim;
        let spread = sim.spread_mm.max(1e-6) * 1e-3;
        let reach2 = (6.0 * spread).powi(2);
        let noise = Normal::new(0.0, (sim.noise * sim.full_scale).max(0.0)).ok();
        let threshold = sim.report_sigmas * sim.noise * sim.full_scale;
        let scale = sim.full_scale * sim.peak * (force_n / sim.force_n.max(1e-9)).max(0.0);
        let mut responses = Vec::new();
        for (t, gain) in self.patch.taxels.iter().zip(&self.gains) {
            let d2 = (t.position - point).norm_squared();
            if d2 > reach2 {
                continue;
            }
            let clean = scale * gain * (-d2 / (2.0 * spread * spread)).exp();
            let noisy = clean + noise.map_or(0.0, |n| n.sample(&mut self.rng));
            let value = noisy.min(sim.full_scale);
            if value > threshold {
                responses.push((t.id, value));
            }
        }
        let jitter = Vector3::from_fn(|_, _| self.rng.sample::<f64, _>(StandardNormal))
            * (sim.centroid_noise_mm * 1e-3);
        ProbeContact {
            centroid: Point3::from(point.coords + jitter),
            force_n: Some(force_n),
            responses,
        }
    }
}
