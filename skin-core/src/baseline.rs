//! Baselines: from raw readings to pressures.
//!
//! A capacitive taxel reads a no-contact offset that differs from taxel to taxel and drifts
//! slowly with temperature. [`Baseline::from_idle`] learns each taxel's offset and noise from
//! frames recorded without contact; [`Baseline::apply`] then turns every raw frame into pressures:
//! the reading's distance from the offset in the direction pressure moves it, zero when within the
//! noise threshold (the active-set threshold eps of thesis Ch. 9.2.1, per taxel). While a taxel is
//! not in contact its offset follows the reading slowly, so drift is tracked without eating into
//! a touch (the iCub skin manager's compensation works the same way).
//!
//! The same idle frames show taxels that cannot be trusted: no variation at all (dead), or
//! pinned at a rail of the converter (stuck). They are listed so that a map can be rebuilt
//! without them.

use crate::{Error, Result};
use std::path::Path;

/// Which way pressure moves a raw reading (`"rising"` or `"falling"` in configuration files).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Polarity {
    /// Pressure raises the reading (Cyskin, skin16).
    Rising,
    /// Pressure lowers the reading (iCub: 255 = no load).
    Falling,
}

/// Options of [`Baseline::from_idle`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BaselineOptions {
    /// Which way pressure moves a reading.
    pub polarity: Polarity,
    /// The noise threshold is this many standard deviations of the idle readings (default 3).
    pub noise_sigmas: f32,
    /// ...and at least this, in reading units (default 1).
    pub min_noise: f32,
    /// Fraction of the gap between reading and offset closed per frame while not in contact
    /// (default 0.01: a time constant of 100 frames, 5 s at 20 Hz).
    pub drift_per_frame: f32,
    /// The converter's range (lowest, highest reading); a taxel whose idle readings sit on either
    /// end is stuck. Default 0 to 65535 (16 bits).
    pub rails: (f32, f32),
}

impl Default for BaselineOptions {
    fn default() -> Self {
        BaselineOptions {
            polarity: Polarity::Rising,
            noise_sigmas: 3.0,
            min_noise: 1.0,
            drift_per_frame: 0.01,
            rails: (0.0, 65535.0),
        }
    }
}

/// Taxels that the idle frames show to be unusable (layout indices).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TaxelHealth {
    /// Readings that never changed over the idle frames.
    pub dead: Vec<usize>,
    /// Readings pinned at a rail of the converter.
    pub stuck: Vec<usize>,
}

/// Per-taxel offsets and noise thresholds, with drift tracking.
#[derive(Debug, Clone, PartialEq)]
pub struct Baseline {
    offset: Vec<f32>,
    noise: Vec<f32>,
    polarity: Polarity,
    drift: f32,
}

impl Baseline {
    /// Learns offsets and noise from frames without contact (each a slice of one raw reading per
    /// taxel, all the same length). `source` names them in errors.
    pub fn from_idle<'a>(
        frames: impl IntoIterator<Item = &'a [f32]>,
        options: &BaselineOptions,
        source: &Path,
    ) -> Result<(Baseline, TaxelHealth)> {
        let mut n = 0usize;
        let (mut mean, mut m2, mut lo, mut hi) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for (k, frame) in frames.into_iter().enumerate() {
            if n == 0 {
                mean = vec![0.0f64; frame.len()];
                m2 = vec![0.0f64; frame.len()];
                lo = vec![f32::INFINITY; frame.len()];
                hi = vec![f32::NEG_INFINITY; frame.len()];
            } else if frame.len() != mean.len() {
                return Err(Error::invalid(
                    source,
                    format!("idle frame {k}"),
                    format!("{} readings, the first frame has {}", frame.len(), mean.len()),
                ));
            }
            n += 1;
            for (i, &v) in frame.iter().enumerate() {
                if !v.is_finite() {
                    return Err(Error::invalid(
                        source,
                        format!("idle frame {k}, taxel index {i}"),
                        "reading is not finite",
                    ));
                }
                // Welford's running mean and variance: one pass, no stored frames.
                let d = f64::from(v) - mean[i];
                mean[i] += d / n as f64;
                m2[i] += d * (f64::from(v) - mean[i]);
                lo[i] = lo[i].min(v);
                hi[i] = hi[i].max(v);
            }
        }
        if n < 2 {
            return Err(Error::invalid(
                source,
                "idle frames",
                format!("{n} frame(s): at least 2 are needed to measure noise"),
            ));
        }
        let mut health = TaxelHealth::default();
        let mut noise = Vec::with_capacity(mean.len());
        for i in 0..mean.len() {
            let sd = (m2[i] / (n - 1) as f64).sqrt() as f32;
            noise.push((options.noise_sigmas * sd).max(options.min_noise));
            if lo[i] <= options.rails.0 && hi[i] <= options.rails.0 || lo[i] >= options.rails.1 {
                health.stuck.push(i);
            } else if lo[i] == hi[i] {
                health.dead.push(i);
            }
        }
        Ok((
            Baseline {
                offset: mean.iter().map(|&m| m as f32).collect(),
                noise,
                polarity: options.polarity,
                drift: options.drift_per_frame.clamp(0.0, 1.0),
            },
            health,
        ))
    }

    /// Number of taxels.
    pub fn len(&self) -> usize {
        self.offset.len()
    }

    /// Whether there are no taxels.
    pub fn is_empty(&self) -> bool {
        self.offset.is_empty()
    }

    /// Current no-contact offset of each taxel.
    pub fn offsets(&self) -> &[f32] {
        &self.offset
    }

    /// Noise threshold of each taxel, in reading units.
    pub fn noise(&self) -> &[f32] {
        &self.noise
    }

    /// Pressures of one raw frame (same taxel order), and drift tracking for taxels not in
    /// contact. Allocates nothing; a frame of the wrong length is an error and changes nothing.
    pub fn apply(&mut self, raw: &[f32], pressures: &mut [f32]) -> std::result::Result<(), String> {
        if raw.len() != self.offset.len() || pressures.len() != self.offset.len() {
            return Err(format!(
                "frame has {} readings and {} outputs, the baseline {} taxels",
                raw.len(),
                pressures.len(),
                self.offset.len()
            ));
        }
        let sign = match self.polarity {
            Polarity::Rising => 1.0,
            Polarity::Falling => -1.0,
        };
        for (((p, &r), o), &eps) in pressures
            .iter_mut()
            .zip(raw)
            .zip(&mut self.offset)
            .zip(&self.noise)
        {
            let d = sign * (r - *o);
            if d > eps {
                *p = d;
            } else {
                *p = 0.0;
                // Not in contact: follow the reading (both ways, so drift in either direction is
                // tracked; a NaN reading leaves the offset alone).
                if r.is_finite() {
                    *o += self.drift * (r - *o);
                }
            }
        }
        Ok(())
    }
}
