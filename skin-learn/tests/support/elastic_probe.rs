//! A second probe simulator, written apart from `skin probe-sim` so that the calibration is not
//! checked only against the model it fits. Where `ProbeSimulator` makes Gaussian responses, this
//! one follows the mechanics of a round probe tip on a soft cover:
//!
//! - the tip (a hemisphere of radius 10 mm, thesis Ch. 7.3) presses the cover with a force drawn
//!   around 5 N (10% spread); the contact pressure is Hertz's, `p(r) = 3F / (2 pi a^2)
//!   sqrt(1 - r^2 / a^2)` over a disc of radius `a = (3 F R / 4 E*)^(1/3)` (E* = 0.5 MPa, a soft
//!   silicone: a is about 4 mm at 5 N);
//! - the cover (2.5 mm) carries it down to the sensing layer by Boussinesq's point-load stress,
//!   `sigma_z(rho) = 3 h^3 / (2 pi (rho^2 + h^2)^(5/2))` per newton, summed over the disc: a
//!   response with heavier tails than a Gaussian and a flat top;
//! - each taxel converts stress to counts through a saturating curve (a capacitive cell stiffens),
//!   with its own gain (15% spread) and noise (1% of full scale), rounded to integer counts and
//!   reported above 3 noise sigmas;
//! - the robot reports the tip's centre with 0.7 mm of noise per axis.
//!
//! Contacts land uniformly over the patch and a margin around it, so taxels at the border are
//! pressed from outside too, as a robot probing a whole link would; a margin of 0 presses only
//! inside the outermost taxels, which leaves the border one-sided.

use nalgebra::{Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal, StandardNormal};
use skin_core::LinkSkin;
use skin_learn::calibration::{ProbeContact, ProbeDataset};

/// Settings of the elastic probe.
#[derive(Debug, Clone, Copy)]
pub struct ElasticProbe {
    /// Contacts land within this distance of some taxel, millimetres.
    pub margin_mm: f64,
    /// Cover thickness, millimetres.
    pub cover_mm: f64,
    /// Per-taxel gains uniformly in 1 +- this.
    pub gain_spread: f64,
    /// Reported tip centre noise per axis, millimetres.
    pub centroid_noise_mm: f64,
}

impl Default for ElasticProbe {
    fn default() -> Self {
        ElasticProbe {
            margin_mm: 8.0,
            cover_mm: 2.5,
            gain_spread: 0.15,
            centroid_noise_mm: 0.7,
        }
    }
}

const TIP_RADIUS_M: f64 = 0.010;
const E_STAR_PA: f64 = 0.5e6;
const FULL_SCALE: f64 = 4095.0;
/// Stress (Pa) at which a cell reads half its full scale.
const HALF_SCALE_PA: f64 = 60e3;

fn tangent(n: &Vector3<f64>) -> Vector3<f64> {
    let a = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    n.cross(&a).normalize()
}

impl ElasticProbe {
    /// `contacts` presses on `patch`, deterministic for `seed`.
    pub fn run(&self, patch: &LinkSkin, contacts: usize, seed: u64) -> ProbeDataset {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_e1a5);
        let taxels = &patch.taxels;
        let gains: Vec<f64> = taxels
            .iter()
            .map(|_| 1.0 + self.gain_spread * rng.random_range(-1.0..=1.0))
            .collect();
        let margin = self.margin_mm * 1e-3;
        let h = self.cover_mm * 1e-3;
        let noise = Normal::new(0.0, 0.01 * FULL_SCALE).unwrap();
        let mut dataset = ProbeDataset::default();
        while dataset.contacts.len() < contacts {
            // A point of the patch or its margin: a random taxel, a random point of the disc of
            // radius max(margin, 4 mm) in its tangent plane, kept with probability 1 / (taxels
            // within that radius) for a uniform density.
            let reach = margin.max(0.004);
            let base = &taxels[rng.random_range(0..taxels.len())];
            let (t1, n) = (tangent(&base.normal), base.normal.into_inner());
            let t2 = n.cross(&t1);
            let r = reach * rng.random::<f64>().sqrt();
            let phi = rng.random_range(0.0..std::f64::consts::TAU);
            let point = base.position + (t1 * phi.cos() + t2 * phi.sin()) * r;
            let near: Vec<usize> = (0..taxels.len())
                .filter(|&k| (taxels[k].position - point).norm() <= reach)
                .collect();
            if rng.random_range(0..near.len().max(1)) != 0 {
                continue;
            }
            // With no margin, only points inside the outermost taxels: the point must lie between
            // taxels on all sides (within 6 mm of at least three, around it).
            if margin <= 0.0 && !surrounded(patch, &point, &n) {
                continue;
            }
            let force = (5.0 * (1.0 + 0.1 * rng.sample::<f64, _>(StandardNormal))).max(1.0);
            let a = (3.0 * force * TIP_RADIUS_M / (4.0 * E_STAR_PA)).cbrt();
            let p0 = 3.0 * force / (2.0 * std::f64::consts::PI * a * a);
            // The contact disc, in rings: (offset in the tangent plane, area).
            let rings = 6;
            let mut disc = Vec::new();
            for i in 0..rings {
                let (r0, r1) = (a * i as f64 / rings as f64, a * (i + 1) as f64 / rings as f64);
                let rm = 0.5 * (r0 + r1);
                let pieces = (6 * i).max(1);
                let area = std::f64::consts::PI * (r1 * r1 - r0 * r0) / pieces as f64;
                let pressure = p0 * (1.0 - (rm / a).powi(2)).max(0.0).sqrt();
                for k in 0..pieces {
                    let ang = std::f64::consts::TAU * k as f64 / pieces as f64;
                    disc.push(((t1 * ang.cos() + t2 * ang.sin()) * rm, pressure * area));
                }
            }
            let mut responses = Vec::new();
            for (k, t) in taxels.iter().enumerate() {
                if (t.position - point).norm() > 0.025 {
                    continue;
                }
                let stress: f64 = disc
                    .iter()
                    .map(|(off, load)| {
                        let rho2 = (t.position - (point + off)).norm_squared();
                        load * 3.0 * h.powi(3) / (2.0 * std::f64::consts::PI * (rho2 + h * h).powf(2.5))
                    })
                    .sum();
                let clean = FULL_SCALE * gains[k] * stress / (stress + HALF_SCALE_PA);
                let value = (clean + noise.sample(&mut rng)).round().min(FULL_SCALE);
                if value > 3.0 * 0.01 * FULL_SCALE {
                    responses.push((t.id, value));
                }
            }
            let jitter = Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal))
                * (self.centroid_noise_mm * 1e-3);
            dataset.contacts.push(ProbeContact {
                centroid: Point3::from(point.coords + jitter),
                force_n: Some(force),
                responses,
            });
        }
        dataset
    }
}

/// Whether taxels lie around `point` on every side (no half-plane of the tangent plane around it
/// is empty of taxels within 10 mm).
fn surrounded(patch: &LinkSkin, point: &Point3<f64>, n: &Vector3<f64>) -> bool {
    let t1 = tangent(n);
    let t2 = n.cross(&t1);
    let mut angles: Vec<f64> = patch
        .taxels
        .iter()
        .filter(|t| (t.position - point).norm() <= 0.010)
        .map(|t| {
            let d = t.position - point;
            d.dot(&t2).atan2(d.dot(&t1))
        })
        .collect();
    if angles.len() < 3 {
        return false;
    }
    angles.sort_by(f64::total_cmp);
    let mut gap = angles[0] + std::f64::consts::TAU - angles[angles.len() - 1];
    for w in angles.windows(2) {
        gap = gap.max(w[1] - w[0]);
    }
    gap < std::f64::consts::PI
}

/// A curved patch of `count` taxels: a triangular lattice of `pitch_mm` wrapped on a cylinder
/// of radius `radius_mm` (a robot link), the `count` lattice points nearest its middle.
pub fn cylinder_patch(count: usize, pitch_mm: f64, radius_mm: f64) -> LinkSkin {
    use nalgebra::Unit;
    use skin_core::{Taxel, TaxelId};
    let (p, r) = (pitch_mm * 1e-3, radius_mm * 1e-3);
    let side = ((count as f64).sqrt() as i64) + 4;
    let mut points = Vec::new();
    for j in -side..=side {
        for i in -side..=side {
            let u = (i as f64 + 0.5 * (j.rem_euclid(2)) as f64) * p;
            let v = j as f64 * p * 3f64.sqrt() / 2.0;
            points.push((u, v));
        }
    }
    points.sort_by(|a, b| {
        (a.0.hypot(a.1))
            .total_cmp(&b.0.hypot(b.1))
            .then(a.0.total_cmp(&b.0))
    });
    points.truncate(count);
    let taxels = points
        .iter()
        .enumerate()
        .map(|(k, &(u, v))| {
            let ang = u / r;
            let normal = Vector3::new(ang.sin(), 0.0, ang.cos());
            Taxel {
                id: TaxelId(k as u32 + 1),
                position: Point3::new(r * ang.sin(), v, r * ang.cos()),
                normal: Unit::new_normalize(normal),
            }
        })
        .collect();
    LinkSkin::new("patch524", taxels)
}
