//! Baselines: from raw readings to pressures.
//!
//! A capacitive taxel reads a no-contact offset that differs from taxel to taxel and drifts
//! slowly with temperature. [`Baseline::from_idle`] learns each taxel's offset and noise from
//! frames recorded without contact (the threshold: 6 standard deviations of the taxel's idle
//! readings, or of the link's 90th-percentile taxel's when larger; see [`BaselineOptions`]);
//! [`Baseline::apply`] then turns every raw frame into pressures: the reading's distance from
//! the offset in the direction pressure moves it, zero when within the noise threshold (the
//! active-set threshold eps of thesis Ch. 9.2.1, per taxel). While a taxel is not in contact
//! its offset follows the reading slowly, so drift is tracked without eating into a touch (the
//! iCub skin manager's compensation works the same way).
//!
//! The same idle frames show taxels that cannot be trusted: no variation at all (dead), or
//! pinned at the rail of the converter that pressure moves toward (stuck). A taxel resting at
//! the other rail is not listed: electronics that subtract the offset themselves clip at rest
//! (a Cyskin stream reads 0 on most taxels until touched). They are listed so that a map can be
//! rebuilt without them.

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
    /// The noise threshold is this many standard deviations of the idle readings (default 6).
    pub noise_sigmas: f32,
    /// ...of the taxel's own idle readings, or of the link's taxel at this quantile of the
    /// link's standard deviations, whichever is larger (default 0.9). A few idle frames
    /// underestimate a taxel that happened to sit still: on the real Cyskin recordings, the
    /// median taxel's deviation over 5 idle frames is 55 counts, the 90th percentile's 260 to
    /// 310, and idle readings reach 1,000 to 3,700 counts above their mean later on.
    pub noise_floor_quantile: f32,
    /// ...and at least this, in reading units (default 1).
    pub min_noise: f32,
    /// Fraction of the gap between reading and offset closed per frame while not in contact
    /// (default 0.01: a time constant of 100 frames, 5 s at 20 Hz).
    pub drift_per_frame: f32,
    /// The converter's range (lowest, highest reading); a taxel whose idle readings sit on the
    /// end pressure moves toward is stuck. Default 0 to 65535 (16 bits).
    pub rails: (f32, f32),
}

impl Default for BaselineOptions {
    fn default() -> Self {
        BaselineOptions {
            polarity: Polarity::Rising,
            noise_sigmas: 6.0,
            noise_floor_quantile: 0.9,
            min_noise: 1.0,
            drift_per_frame: 0.01,
            rails: (0.0, 65535.0),
        }
    }
}

/// Taxels that the idle frames show to be unusable (layout indices).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TaxelHealth {
    /// Readings that never changed over the idle frames (away from the rest rail).
    pub dead: Vec<usize>,
    /// Readings pinned at the rail pressure moves them toward.
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
        let mut stats: Option<IdleStats> = None;
        for (k, frame) in frames.into_iter().enumerate() {
            let s = stats.get_or_insert_with(|| IdleStats::new(frame.len()));
            s.push(frame).map_err(|e| match e {
                Error::Length { got, expected, .. } => Error::invalid(
                    source,
                    format!("idle frame {k}"),
                    format!("{got} readings, the first frame has {expected}"),
                ),
                Error::Invalid { place, message, .. } => {
                    Error::invalid(source, format!("idle frame {k}, {place}"), message)
                }
                e => e,
            })?;
        }
        stats.unwrap_or_else(|| IdleStats::new(0)).finish(options, source)
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
    pub fn apply(&mut self, raw: &[f32], pressures: &mut [f32]) -> Result<()> {
        for (what, got) in [
            ("readings of the frame for the baseline's taxels", raw.len()),
            ("pressures for the baseline's taxels", pressures.len()),
        ] {
            if got != self.offset.len() {
                return Err(Error::Length {
                    what,
                    got,
                    expected: self.offset.len(),
                });
            }
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

/// Running statistics of a link's idle readings (Welford's mean and variance, and the range),
/// from which a [`Baseline`] is made: one pass, no stored frames, no allocation per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct IdleStats {
    n: usize,
    mean: Vec<f64>,
    m2: Vec<f64>,
    lo: Vec<f32>,
    hi: Vec<f32>,
}

impl IdleStats {
    /// Statistics of `taxels` taxels, no frame yet.
    pub fn new(taxels: usize) -> IdleStats {
        IdleStats {
            n: 0,
            mean: vec![0.0; taxels],
            m2: vec![0.0; taxels],
            lo: vec![f32::INFINITY; taxels],
            hi: vec![f32::NEG_INFINITY; taxels],
        }
    }

    /// Frames taken so far.
    pub fn frames(&self) -> usize {
        self.n
    }

    /// Takes one idle frame (one reading per taxel). A frame of the wrong length or with a
    /// reading that is not finite is an error and changes nothing.
    pub fn push(&mut self, frame: &[f32]) -> Result<()> {
        self.check(frame)?;
        self.n += 1;
        let n = self.n as f64;
        for (i, &v) in frame.iter().enumerate() {
            let d = f64::from(v) - self.mean[i];
            self.mean[i] += d / n;
            self.m2[i] += d * (f64::from(v) - self.mean[i]);
            self.lo[i] = self.lo[i].min(v);
            self.hi[i] = self.hi[i].max(v);
        }
        Ok(())
    }

    /// Whether `frame` can be taken: one finite reading per taxel.
    fn check(&self, frame: &[f32]) -> Result<()> {
        if frame.len() != self.mean.len() {
            return Err(Error::Length {
                what: "readings of the idle frame for the link's taxels",
                got: frame.len(),
                expected: self.mean.len(),
            });
        }
        match frame.iter().position(|v| !v.is_finite()) {
            Some(i) => Err(Error::Invalid {
                path: Path::new("idle frames").to_owned(),
                place: format!("taxel index {i}"),
                message: "reading is not finite".into(),
            }),
            None => Ok(()),
        }
    }

    /// The baseline and the taxels the frames show to be unusable; at least 2 frames are needed
    /// to measure noise. `source` names the frames in errors.
    pub fn finish(&self, options: &BaselineOptions, source: &Path) -> Result<(Baseline, TaxelHealth)> {
        let n = self.n;
        if n < 2 {
            return Err(Error::invalid(
                source,
                "idle frames",
                format!("{n} frame(s): at least 2 are needed to measure noise"),
            ));
        }
        let mut health = TaxelHealth::default();
        let sds: Vec<f32> = self
            .m2
            .iter()
            .map(|m2| (m2 / (n - 1) as f64).sqrt() as f32)
            .collect();
        // The link's own noise level: its taxels' deviations at the quantile (a dead taxel's
        // zero counts among them; the quantile keeps a few noisy ones from setting it).
        let floor = {
            let mut sorted = sds.clone();
            sorted.sort_by(f32::total_cmp);
            let q = options.noise_floor_quantile.clamp(0.0, 1.0);
            sorted
                .get(((sorted.len().saturating_sub(1)) as f32 * q).round() as usize)
                .copied()
                .unwrap_or(0.0)
        };
        let mut noise = Vec::with_capacity(self.mean.len());
        for (i, &sd) in sds.iter().enumerate() {
            noise.push((options.noise_sigmas * sd.max(floor)).max(options.min_noise));
            let (lo, hi) = (self.lo[i], self.hi[i]);
            // Pinned at the rail pressure moves the reading toward, it cannot read pressure:
            // stuck. Pinned at the other rail is a stream whose electronics subtract the offset
            // and clip (Cyskin sends 0 at rest): quiet, not broken, whatever the idle frames say.
            let (toward, away) = match options.polarity {
                Polarity::Rising => (lo >= options.rails.1, hi <= options.rails.0),
                Polarity::Falling => (hi <= options.rails.0, lo >= options.rails.1),
            };
            if toward {
                health.stuck.push(i);
            } else if lo == hi && !away {
                health.dead.push(i);
            }
        }
        Ok((
            Baseline {
                offset: self.mean.iter().map(|&m| m as f32).collect(),
                noise,
                polarity: options.polarity,
                drift: options.drift_per_frame.clamp(0.0, 1.0),
            },
            health,
        ))
    }
}

/// Learns every link's baseline from the first complete frames of a session, taken as idle (no
/// one touches the skin while it starts): what a runtime does before its first pressure.
///
/// ```
/// use skin_core::{BaselineLearner, BaselineOptions};
///
/// // Two links of 3 and 2 taxels; 20 idle frames with a little noise.
/// let mut learner = BaselineLearner::new(&[3, 2], 20, BaselineOptions::default())?;
/// let mut k = 0.0f32;
/// while !learner.is_done() {
///     k += 1.0;
///     let wobble = if k as u32 % 2 == 0 { 1.0 } else { -1.0 };
///     learner.push(&[vec![1000.0 + wobble; 3], vec![2000.0 - wobble; 2]])?;
/// }
/// let links = learner.finish(std::path::Path::new("session"))?;
/// assert_eq!(links.len(), 2);
/// assert!((links[1].0.offsets()[0] - 2000.0).abs() < 0.1);
/// # Ok::<(), skin_core::Error>(())
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct BaselineLearner {
    links: Vec<IdleStats>,
    frames: usize,
    options: BaselineOptions,
}

impl BaselineLearner {
    /// The most idle frames a learner takes (over an hour at 20 Hz).
    pub const MAX_FRAMES: usize = 100_000;

    /// A learner for links of `taxels[l]` taxels each, done after `frames` frames (2 to
    /// [`Self::MAX_FRAMES`]: at least 2 to measure noise).
    pub fn new(taxels: &[usize], frames: usize, options: BaselineOptions) -> Result<BaselineLearner> {
        if !(2..=Self::MAX_FRAMES).contains(&frames) {
            return Err(Error::invalid(
                Path::new("baseline"),
                "frames",
                format!("{frames}: expected 2 to {} idle frames", Self::MAX_FRAMES),
            ));
        }
        Ok(BaselineLearner {
            links: taxels.iter().map(|&n| IdleStats::new(n)).collect(),
            frames,
            options,
        })
    }

    /// Takes one frame of every link (raw readings in layout order). Call it with complete
    /// frames only: a missing module's readings are not idle readings.
    pub fn push(&mut self, links: &[Vec<f32>]) -> Result<()> {
        if links.len() != self.links.len() {
            return Err(Error::Length {
                what: "links of the frame for the learner's links",
                got: links.len(),
                expected: self.links.len(),
            });
        }
        // Check every link before taking any, so a bad frame changes nothing.
        for (l, (stats, raw)) in self.links.iter().zip(links).enumerate() {
            stats.check(raw).map_err(|e| match e {
                Error::Invalid { path, place, message } => Error::Invalid {
                    path,
                    place: format!("link {l}, {place}"),
                    message,
                },
                e => e,
            })?;
        }
        for (stats, raw) in self.links.iter_mut().zip(links) {
            stats.push(raw)?;
        }
        Ok(())
    }

    /// Frames taken so far.
    pub fn frames(&self) -> usize {
        self.links.first().map_or(0, IdleStats::frames)
    }

    /// Whether it has taken its frames.
    pub fn is_done(&self) -> bool {
        self.frames() >= self.frames
    }

    /// Every link's baseline and unusable taxels, in the order of the links.
    pub fn finish(&self, source: &Path) -> Result<Vec<(Baseline, TaxelHealth)>> {
        self.links
            .iter()
            .map(|s| s.finish(&self.options, source))
            .collect()
    }
}
