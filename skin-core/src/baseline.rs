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
//! iCub skin manager's compensation works the same way); a taxel in contact follows the mean
//! drift of its link's taxels that are not, so that a press held while the rest level moves
//! keeps its pressure and leaves no phantom touch behind.
//!
//! A session can start at any moment, someone leaning on the skin included:
//! - Frames that are not idle are not learned from. A taxel that moved during the idle frames far
//!   beyond the skin's noise (its deviation over [`BaselineOptions::moving_ratio`] times the
//!   link's median taxel's) and smoothly, as pressure moves a reading and noise does not (a von
//!   Neumann ratio under 1: successive differences small against the spread), is a touch in
//!   progress. Its offset is its least pressed reading of those frames and its noise the link's;
//!   it is listed in [`TaxelHealth::pressed`]. It does not set the link's noise either.
//! - A baseline learned under pressure, or drifted under a long touch, shows when the pressure
//!   goes: the reading falls below the offset, against the way pressure moves it, beyond the
//!   noise. Pressure never does that, so after two such frames in a row (one could be a glitch)
//!   the offset is reset to the reading and the taxel counted ([`Baseline::apply`] returns how
//!   many): the taxel reads pressure right again at once, instead of being blind until the slow
//!   drift tracking catches up.
//!
//! The same idle frames show taxels that cannot be trusted: no variation at all (dead), or
//! pinned at the rail of the converter that pressure moves toward (stuck). A taxel resting at
//! the other rail is not listed: electronics that subtract the offset themselves clip at rest
//! (a Cyskin stream reads 0 on most taxels until touched). They are listed so that a map can be
//! rebuilt without them.

use crate::{Error, Result};
use std::path::Path;

/// Which way pressure moves a raw reading (`"rising"` or `"falling"` in configuration files,
/// read with [`str::parse`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Polarity {
    /// Pressure raises the reading (Cyskin, skin16).
    Rising,
    /// Pressure lowers the reading (iCub: 255 = no load).
    Falling,
}

crate::by_name!(Polarity, UnknownPolarity, "\"rising\" or \"falling\"", {
    Rising => "rising",
    Falling => "falling",
});

/// A polarity is read by its name ([`str::parse`]), so a wrong one is named with the names
/// there are.
impl<'de> serde::Deserialize<'de> for Polarity {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Polarity, D::Error> {
        let name = std::borrow::Cow::<'de, str>::deserialize(d)?;
        name.parse().map_err(serde::de::Error::custom)
    }
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
    /// A taxel whose idle readings deviate more than this many times the link's median taxel's
    /// (and smoothly, not as noise) was pressed while the baseline was learned (default 10).
    /// On the real Cyskin recordings nobody touches, 0.4 taxels a recording (at most 2 of 716)
    /// pass both tests over 5 idle frames; a press moves a reading a hundred times the median
    /// and more.
    pub moving_ratio: f32,
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
            moving_ratio: 10.0,
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
    /// Readings that moved as pressure moves them while the idle frames were taken: a touch in
    /// progress. Their offsets are their least pressed readings, corrected when the pressure
    /// goes.
    pub pressed: Vec<usize>,
}

/// Per-taxel offsets and noise thresholds, with drift tracking.
#[derive(Debug, Clone, PartialEq)]
pub struct Baseline {
    offset: Vec<f32>,
    noise: Vec<f32>,
    polarity: Polarity,
    drift: f32,
    /// Frames in a row each taxel has read below its offset beyond its noise.
    below: Vec<u8>,
    /// Taxels reset since [`Baseline::take_corrected`] last looked, and how many they are.
    corrected: Vec<bool>,
    corrected_count: usize,
}

/// Frames in a row a reading must stay below its offset (beyond the noise) before the offset is
/// taken to be wrong: one frame could be a glitch of the converter.
const BELOW_FRAMES: u8 = 2;

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
    /// contact. A taxel that reads below its offset beyond its noise for a second frame in a row
    /// (its offset was learned, or drifted, under pressure: see the [module](self)) has its offset
    /// reset to the reading. Returns how many taxels were reset by this frame. Allocates
    /// nothing; a frame of the wrong length is an error and changes nothing.
    pub fn apply(&mut self, raw: &[f32], pressures: &mut [f32]) -> Result<usize> {
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
        let mut reset = 0;
        // What the taxels not in contact follow this frame, summed: the link's common drift.
        let (mut followed, mut following) = (0.0f64, 0usize);
        for (i, (((p, &r), o), &eps)) in pressures
            .iter_mut()
            .zip(raw)
            .zip(&mut self.offset)
            .zip(&self.noise)
            .enumerate()
        {
            let d = sign * (r - *o);
            if d > eps {
                *p = d;
                self.below[i] = 0;
                continue;
            }
            *p = 0.0;
            if !r.is_finite() {
                continue; // a NaN reading leaves the offset alone
            }
            if d < -eps {
                // Against the way pressure moves a reading, beyond the noise: not noise, so the
                // offset is wrong. Not followed at once: one frame could be a glitch.
                self.below[i] = self.below[i].saturating_add(1);
                if self.below[i] >= BELOW_FRAMES {
                    *o = r;
                    self.below[i] = 0;
                    reset += 1;
                    if !self.corrected[i] {
                        self.corrected[i] = true;
                        self.corrected_count += 1;
                    }
                }
            } else {
                // Not in contact: follow the reading (both ways, so drift in either direction
                // is tracked).
                self.below[i] = 0;
                let step = self.drift * (r - *o);
                *o += step;
                followed += f64::from(step);
                following += 1;
            }
        }
        // A taxel in contact cannot tell drift from pressure, so it follows the link's common
        // drift (temperature moves a link's taxels together): a press held for minutes while the
        // rest level rises keeps its pressure, and leaves no phantom touch when it goes.
        if following > 0 {
            let common = (followed / following as f64) as f32;
            for (o, &p) in self.offset.iter_mut().zip(pressures.iter()) {
                if p > 0.0 {
                    *o += common;
                }
            }
        }
        Ok(reset)
    }

    /// How many taxels had their offset reset ([`Baseline::apply`]) since the last call, each
    /// counted once; the count starts again from zero.
    pub fn take_corrected(&mut self) -> usize {
        if self.corrected_count > 0 {
            self.corrected.fill(false);
        }
        std::mem::take(&mut self.corrected_count)
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
    /// The last frame, and the sum of squared differences between successive frames (the
    /// numerator of the von Neumann ratio, which tells a trend from noise).
    last: Vec<f32>,
    successive: Vec<f64>,
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
            last: vec![0.0; taxels],
            successive: vec![0.0; taxels],
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
            if self.n > 1 {
                let step = f64::from(v) - f64::from(self.last[i]);
                self.successive[i] += step * step;
            }
            self.last[i] = v;
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
        let pressed = self.pressed(&sds, options);
        // The link's own noise level: its taxels' deviations at the quantile (a dead taxel's
        // zero counts among them; the quantile keeps a few noisy ones from setting it). A taxel
        // pressed meanwhile measured the touch, not the noise: left out.
        let floor = {
            let mut sorted: Vec<f32> = sds
                .iter()
                .zip(&pressed)
                .filter(|&(_, &p)| !p)
                .map(|(&sd, _)| sd)
                .collect();
            sorted.sort_by(f32::total_cmp);
            let q = options.noise_floor_quantile.clamp(0.0, 1.0);
            sorted
                .get(((sorted.len().saturating_sub(1)) as f32 * q).round() as usize)
                .copied()
                .unwrap_or(0.0)
        };
        let mut noise = Vec::with_capacity(self.mean.len());
        let mut offset: Vec<f32> = self.mean.iter().map(|&m| m as f32).collect();
        for (i, &sd) in sds.iter().enumerate() {
            let (lo, hi) = (self.lo[i], self.hi[i]);
            if pressed[i] {
                // Its least pressed reading is the nearest to its rest; the pressure going
                // corrects the rest (Baseline::apply).
                offset[i] = match options.polarity {
                    Polarity::Rising => lo,
                    Polarity::Falling => hi,
                };
                noise.push((options.noise_sigmas * floor).max(options.min_noise));
                health.pressed.push(i);
                continue;
            }
            noise.push((options.noise_sigmas * sd.max(floor)).max(options.min_noise));
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
        let taxels = offset.len();
        Ok((
            Baseline {
                offset,
                noise,
                polarity: options.polarity,
                drift: options.drift_per_frame.clamp(0.0, 1.0),
                below: vec![0; taxels],
                corrected: vec![false; taxels],
                corrected_count: 0,
            },
            health,
        ))
    }

    /// Which taxels moved during the idle frames as a touch moves a reading: far beyond the
    /// link's typical noise (the median taxel's deviation, robust to the few taxels a touch
    /// covers) and smoothly. The von Neumann ratio (mean squared successive difference over the
    /// variance) is about 2 for noise and near 0 for a trend or a step; a taxel must be under 1.
    fn pressed(&self, sds: &[f32], options: &BaselineOptions) -> Vec<bool> {
        let mut sorted = sds.to_vec();
        sorted.sort_by(f32::total_cmp);
        let typical = sorted
            .get(sorted.len() / 2)
            .copied()
            .unwrap_or(0.0)
            .max(options.min_noise);
        let limit = options.moving_ratio * typical;
        sds.iter()
            .zip(self.m2.iter().zip(&self.successive))
            .map(|(&sd, (&m2, &successive))| {
                // successive / (n - 1) over m2 / (n - 1): the counts cancel.
                sd > limit && m2 > 0.0 && successive < m2
            })
            .collect()
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
