//! Samples imaged through degraded maps, as the robustness tests of Ch. 5 degrade them: taxels
//! removed (Test B, [`Removal`]) or dead in blind spots (Test A, [`DeadSpots`]).
//!
//! A model trained only on whole maps loses a sixth of its accuracy when 70% of the taxels are
//! gone (Table 5.3) and 8% with four blind spots of 40 mm (Table 5.1); trained with some of
//! its images from degraded maps, it keeps its decisions on a skin with dead or missing taxels.
//! The degraded maps come from skin-geom's [`Decimation`] and [`BlindSpots`], the code `skin
//! degrade` and `skin eval --test-a/--test-b` use, with seeds of their own: salted with the
//! dataset's seed and their top bit set, never one of the small seeds the tests draw their maps
//! with.
//!
//! The contact is pressed on the whole map as always (its readings, in `frames.txt`, keep every
//! taxel); a sample is then imaged, image and mask, through at most one degraded map. Its mask
//! is the whole map's, cut to the pixels the degraded image still lights: the truth the tests
//! score a segmenter against (Ch. 5.3). Each choice has its own random stream, so the contacts
//! are those of the same dataset without degradation, and adding blind spots leaves the samples
//! thinned by a removal as they were.

use super::{Sample, SynthOptions, Synthesizer, image_of, mix};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_core::image::ImageSize;
use skin_geom::{BlindSpots, Decimation, Grid, Normalisation, Rasterizer, TactileImager, TactileMap};

/// Taxels removed from the map a share of the samples is imaged through, as Test B removes them:
/// one of `maps` thinned maps whose removed fractions are spread evenly up to `up_to`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Removal {
    /// Share of all samples imaged through a thinned map, 0 to 1.
    pub share: f64,
    /// Largest fraction of taxels removed, 0 to 1 (exclusive); 0.7 is Table 5.3's last row.
    pub up_to: f64,
    /// How many thinned maps to draw from (fractions `up_to * k / maps`, k = 1..=maps).
    pub maps: usize,
}

impl Removal {
    /// The thinned maps `skin synth --remove-up-to` and the Python `synthesize` draw from.
    pub const MAPS: usize = 16;
}

/// Blind spots on the map a share of the samples is imaged through, as Test A makes them: every
/// taxel within a radius of a few random taxels reads zero (a patch of skin torn or unplugged
/// during contact). Each of `maps` maps has 1 to `spots` spots of one radius drawn evenly from
/// a quarter of `radius_mm` to `radius_mm`; Table 5.1's cells, 1-4 spots of 10-40 mm, are
/// `spots: 4, radius_mm: 40.0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeadSpots {
    /// Share of all samples imaged through a map with blind spots, 0 to 1; with a [`Removal`],
    /// the two shares add up to at most 1 (a sample is degraded one way or the other).
    pub share: f64,
    /// Most spots on a map, 1 to 64.
    pub spots: usize,
    /// Largest spot radius on the map, millimetres (above 0, at most 1,000).
    pub radius_mm: f64,
    /// How many maps with blind spots to draw from, 1 to 1,024.
    pub maps: usize,
}

impl DeadSpots {
    /// The maps `skin synth --blind-spots` and the Python `synthesize` draw from: more than
    /// [`Removal::MAPS`], as each spot sits in one place where a removal thins the whole map.
    pub const MAPS: usize = 64;
}

/// A degraded map: the taxels it keeps (None: all, some dead), and the image pipeline on it.
#[derive(Debug, Clone)]
struct Degraded {
    keep: Option<Vec<usize>>,
    removed: f64,
    dead: f64,
    imager: TactileImager,
}

/// The degraded maps a [`Synthesizer`] images some samples through.
#[derive(Debug, Clone, Default)]
pub(super) struct Degradations {
    removal: Option<(f64, Vec<Degraded>)>,
    dead_spots: Option<(f64, Vec<Degraded>)>,
}

/// Salts of the random streams: which map a sample is imaged through, and the maps themselves.
const REMOVAL_SALT: u64 = 0x7E57_B000_0000_0000;
const DEAD_SPOTS_SALT: u64 = 0x7E57_A000_0000_0000;

impl Degradations {
    /// Images `sample` through one degraded map, or leaves it whole, as its own random streams
    /// (from `seed`, `subject` and `index`) decide.
    pub(super) fn apply(
        &mut self,
        seed: u64,
        subject: u32,
        index: u32,
        sample: &mut Sample,
        size: ImageSize,
    ) {
        let removal_share = self.removal.as_ref().map_or(0.0, |(share, _)| *share);
        let drawn = |salt: u64, share: f64, maps: usize| {
            let mut rng = ChaCha8Rng::seed_from_u64(mix(seed ^ salt, subject, index));
            (maps > 0 && rng.random_bool(share.clamp(0.0, 1.0))).then(|| rng.random_range(0..maps))
        };
        let mut chosen = None;
        if let Some((share, maps)) = &mut self.removal {
            chosen = drawn(REMOVAL_SALT, *share, maps.len()).map(|k| &mut maps[k]);
        }
        if chosen.is_none()
            && let Some((share, maps)) = &mut self.dead_spots
        {
            // Of the samples the removal left whole, the share that makes `share` of all.
            let p = if removal_share < 1.0 {
                *share / (1.0 - removal_share)
            } else {
                0.0
            };
            chosen = drawn(DEAD_SPOTS_SALT, p, maps.len()).map(|k| &mut maps[k]);
        }
        let Some(d) = chosen else {
            return;
        };
        let image = match &d.keep {
            Some(keep) => {
                let pressures: Vec<f32> = keep.iter().map(|&i| sample.pressures[i]).collect();
                image_of(&mut d.imager, &pressures, size)
            }
            // A dead taxel's column of the imager is zero: the readings go in whole.
            None => image_of(&mut d.imager, &sample.pressures, size),
        };
        // The truth the tests score against (Ch. 5.3): the whole map's parts, where the degraded
        // image still shows something.
        for (m, &g) in sample.mask.iter_mut().zip(&image) {
            if g == 0 {
                *m = 0;
            }
        }
        sample.image = image;
        sample.removed = d.removed;
        sample.dead = d.dead;
    }
}

/// The real image pipeline on `map` at the generator's grid step and output size.
fn pipeline(map: &TactileMap, options: &SynthOptions) -> skin_geom::Result<TactileImager> {
    let raster = Rasterizer::new(map, Grid::StepMm(options.step_mm))?;
    TactileImager::new(raster, Normalisation::ContactMax, true, Some(options.image_size))
}

fn bad(name: &'static str, value: f64, expected: &'static str) -> skin_geom::Error {
    skin_geom::Error::Parameter {
        name,
        value,
        expected,
    }
}

impl Synthesizer {
    /// The same generator, with a share of the samples imaged through maps with taxels removed
    /// (see [`Removal`]); `map` is the generator's own map, `seed` draws the removal orders (use
    /// the dataset's seed). An error if `map` is another map, a setting is out of range, the
    /// shares with [`Synthesizer::with_dead_spots`] add up to more than 1, or a thinned map keeps
    /// fewer than three taxels.
    pub fn with_removal(
        mut self,
        map: &TactileMap,
        removal: Removal,
        seed: u64,
    ) -> skin_geom::Result<Synthesizer> {
        self.check_map(map, "taxels of the map to thin")?;
        let other = self.degraded.dead_spots.as_ref().map_or(0.0, |d| d.0);
        check_share("share of samples thinned", removal.share, other)?;
        if !(removal.up_to.is_finite() && removal.up_to > 0.0 && removal.up_to < 1.0) {
            return Err(bad(
                "fraction of taxels removed",
                removal.up_to,
                "above 0, below 1",
            ));
        }
        if !(1..=256).contains(&removal.maps) {
            return Err(bad("thinned maps", removal.maps as f64, "1 to 256"));
        }
        let mut thinned = Vec::with_capacity(removal.maps);
        for k in 1..=removal.maps {
            let decimation = Decimation {
                fraction: removal.up_to * k as f64 / removal.maps as f64,
                // Top bit set: never one of the test's maps (seeds 0, 1, 2, ...).
                seed: mix(seed ^ REMOVAL_SALT, u32::MAX, k as u32) | 1 << 63,
            };
            let keep = decimation.survivors(map.points.len())?;
            let smaller = decimation.apply(map)?;
            thinned.push(Degraded {
                removed: 1.0 - keep.len() as f64 / map.points.len().max(1) as f64,
                dead: 0.0,
                keep: Some(keep),
                imager: pipeline(&smaller, &self.options)?,
            });
        }
        self.degraded.removal = Some((removal.share, thinned));
        Ok(self)
    }

    /// The same generator, with a share of the samples imaged through maps with blind spots
    /// (see [`DeadSpots`]); `map` is the generator's own map, `seed` draws the spots (use the
    /// dataset's seed). An error if `map` is another map, a setting is out of range, or the
    /// shares with [`Synthesizer::with_removal`] add up to more than 1.
    pub fn with_dead_spots(
        mut self,
        map: &TactileMap,
        dead: DeadSpots,
        seed: u64,
    ) -> skin_geom::Result<Synthesizer> {
        self.check_map(map, "taxels of the map to give blind spots")?;
        let other = self.degraded.removal.as_ref().map_or(0.0, |r| r.0);
        check_share("share of samples with blind spots", dead.share, other)?;
        if !(1..=64).contains(&dead.spots) {
            return Err(bad("blind spots on a map", dead.spots as f64, "1 to 64"));
        }
        if !(dead.radius_mm.is_finite() && dead.radius_mm > 0.0 && dead.radius_mm <= 1e3) {
            return Err(bad(
                "blind-spot radius (mm)",
                dead.radius_mm,
                "above 0, at most 1,000",
            ));
        }
        if !(1..=1024).contains(&dead.maps) {
            return Err(bad("maps with blind spots", dead.maps as f64, "1 to 1,024"));
        }
        let n = map.points.len();
        let mut maps = Vec::with_capacity(dead.maps);
        for k in 1..=dead.maps {
            let mut rng = ChaCha8Rng::seed_from_u64(mix(seed ^ DEAD_SPOTS_SALT, u32::MAX, k as u32));
            let spots = BlindSpots {
                spots: rng.random_range(1..=dead.spots.min(n)),
                radius_mm: rng.random_range(0.25 * dead.radius_mm..=dead.radius_mm),
                // Top bit set: never one of the test's maps (seeds 0, 1, 2, ...).
                seed: rng.random::<u64>() | 1 << 63,
            };
            let blinded = spots.apply(map)?;
            maps.push(Degraded {
                keep: None,
                removed: 0.0,
                // Only the spots' taxels: a map may come with dead taxels of its own.
                dead: blinded.zeroed.len().saturating_sub(map.zeroed.len()) as f64 / n.max(1) as f64,
                imager: pipeline(&blinded, &self.options)?,
            });
        }
        self.degraded.dead_spots = Some((dead.share, maps));
        Ok(self)
    }

    /// An error unless `map` is the generator's own.
    fn check_map(&self, map: &TactileMap, name: &'static str) -> skin_geom::Result<()> {
        if map.points != self.points {
            return Err(bad(name, map.points.len() as f64, "the generator's own map"));
        }
        Ok(())
    }
}

/// An error unless `share` is 0 to 1 and, with the `other` degradation's, at most 1.
fn check_share(name: &'static str, share: f64, other: f64) -> skin_geom::Result<()> {
    if !(share.is_finite() && (0.0..=1.0).contains(&share)) {
        return Err(bad(name, share, "0 to 1"));
    }
    if share + other > 1.0 + 1e-9 {
        return Err(bad(
            name,
            share,
            "at most 1 with the other degradation's share (a sample is degraded one way)",
        ));
    }
    Ok(())
}
