//! Labelled synthetic contacts on any skin layout, imaged by the real pipeline (thesis Ch. 4).
//!
//! The thesis dataset (90 subjects, 3,530 images) is not public, so the product draws its own:
//! hands of subjects with their own size and habits doing the actions of Ch. 4.5 ([`hand`]),
//! objects and other body parts ([`objects`]), pressed onto the tactile map. Each taxel reads
//! the pressure under its map position plus sensor noise, and knows which hand part pressed it.
//! The frame then goes through the same [`TactileImager`] as live data (Rasterizer,
//! contact-max normalisation of eq. 3.1, erosion r = 2 and dilation r = 4, resize to 68 x 100),
//! and the part mask follows each pixel back to the taxel that dominates it.
//!
//! Everything is a function of (seed, subject, index): a dataset can be generated in parallel, and
//! a test set of unseen subjects is a range of subject numbers.
//!
//! ```
//! use skin_core::{LinkSkin, Taxel, TaxelId};
//! use skin_geom::{FlattenOptions, TactileMap};
//! use skin_learn::synth::{Synthesizer, SynthOptions};
//! use nalgebra::{Point3, Unit, Vector3};
//!
//! // A flat 25 x 35 grid of taxels, 10 mm apart.
//! let taxels = (0..875u32)
//!     .map(|i| Taxel {
//!         id: TaxelId(i),
//!         position: Point3::new((i % 35) as f64 * 0.01, (i / 35) as f64 * 0.01, 0.0),
//!         normal: Unit::new_normalize(Vector3::z()),
//!     })
//!     .collect();
//! let map = TactileMap::flatten(&LinkSkin::new("patch", taxels), &FlattenOptions::default())?;
//! let mut synth = Synthesizer::new(&map, SynthOptions::default())?;
//! let sample = synth.sample(7, 0, 0); // seed 7, subject 0, first sample
//! assert_eq!(sample.image.len(), 68 * 100);
//! assert_eq!(sample.pressures.len(), 875);
//! # Ok::<(), skin_geom::Error>(())
//! ```

pub mod arm;
mod degraded;
pub mod hand;
pub mod objects;
mod shapes;

use crate::parts::Part;
use degraded::Degradations;
pub use degraded::{DeadSpots, Removal};
pub use hand::{Interaction, Subject};
pub use objects::ObjectKind;

use nalgebra::{Point2, Vector2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use shapes::{Patch, press};
use skin_core::image::ImageSize;
use skin_geom::{Grid, Normalisation, Rasterizer, TactileImager, TactileMap};

/// Where a contact sits on the map: its centre (metres, map coordinates) and rotation (radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Centre of the contact on the map.
    pub centre: Point2<f64>,
    /// Rotation of the contact, counter-clockwise.
    pub angle: f64,
}

/// What made a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// A hand, doing one of the actions of Ch. 4.5.
    Hand(Interaction),
    /// Anything else.
    Other(ObjectKind),
}

impl Kind {
    /// True for a hand.
    pub fn is_hand(self) -> bool {
        matches!(self, Kind::Hand(_))
    }

    /// The interaction or contact name.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Hand(i) => i.name(),
            Kind::Other(c) => c.name(),
        }
    }

    /// The kind with this name.
    pub fn from_name(name: &str) -> Option<Kind> {
        Interaction::ALL
            .iter()
            .map(|&i| Kind::Hand(i))
            .chain(ObjectKind::ALL.iter().map(|&c| Kind::Other(c)))
            .find(|k| k.name() == name)
    }
}

/// Generation settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SynthOptions {
    /// Output image size; 68 x 100 as HandsNet's input (App. C).
    pub image_size: ImageSize,
    /// Grid step on the map before resizing, millimetres (1 mm in the thesis).
    pub step_mm: f64,
    /// Fraction of hand samples (the thesis: 1710 of 3530, 48%).
    pub hand_fraction: f64,
    /// Peak contact reading, raw sensor units, drawn uniformly in this range.
    pub peak: (f32, f32),
    /// Sensor noise: standard deviation of each taxel's reading, raw units.
    pub noise: f32,
    /// Readings below this are zero, as after baseline removal with a dead band.
    pub dead_band: f32,
    /// How a hand sample's mask labels its pixels.
    pub labels: MaskLabels,
    /// Share of the non-hand samples that are small rigid prints, a knob or a rod as a rigid
    /// object prints on a curved, soft link ([`ObjectKind::SMALL`]), placed anywhere on the skin
    /// and over its edge, 0 to 1. 0 (the default) draws none: the samples are those of earlier
    /// datasets of the same seed.
    pub small_objects: f64,
}

/// How a hand sample's part mask labels its pixels. Both label the pixels the image lights, and
/// only those; they differ where a brighter part's blob spreads over a dimmer neighbour's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MaskLabels {
    /// Each lit pixel carries the part that pressed the taxels behind it (the pixel's own
    /// taxels; a pixel only the dilation lights takes the part whose value it copied). Read at
    /// the taxels, this mask is the truth of which part pressed which taxel.
    #[default]
    Pressing,
    /// The regions as they appear on the tactile image, as the thesis' annotators drew them
    /// (Table 4.8): each lit pixel takes the part of the pixel whose value the image's dilation
    /// copied, so a brighter finger's region spreads up to the dilation's 4 grid pixels (4 mm at
    /// the default `step_mm`) over a dimmer neighbour, as its blob does on the image.
    AsImaged,
}

impl Default for SynthOptions {
    fn default() -> Self {
        SynthOptions {
            image_size: ImageSize { rows: 68, cols: 100 },
            step_mm: 1.0,
            hand_fraction: 0.5,
            peak: (30.0, 250.0),
            noise: 1.5,
            dead_band: 4.0,
            labels: MaskLabels::Pressing,
            small_objects: 0.0,
        }
    }
}

/// `imager`'s image of `pressures`; black if it cannot make one (the buffers are sized from the
/// map, so it always can).
fn image_of(imager: &mut TactileImager, pressures: &[f32], size: ImageSize) -> Vec<u8> {
    match imager.process(pressures) {
        Ok(img) => img.to_vec(),
        Err(_) => vec![0; size.pixels()],
    }
}

/// One labelled contact.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample {
    /// Hand (and action) or other contact.
    pub kind: Kind,
    /// The subject who made it.
    pub subject: u32,
    /// Less than 85% of the contact's area lies on the skin (cut at the edge, Fig. 4.2h).
    pub partial: bool,
    /// A hand touching with its fingertips only.
    pub fingertips_only: bool,
    /// One reading per taxel, in map order, raw units.
    pub pressures: Vec<f32>,
    /// The part ([`Part`] as u8) pressing each taxel; 0 where nothing or noise does.
    pub taxel_parts: Vec<u8>,
    /// The tactile image, grey, row-major, of [`SynthOptions::image_size`].
    pub image: Vec<u8>,
    /// The part of each image pixel ([`Part`] as u8); 0 wherever the image is black.
    pub mask: Vec<u8>,
    /// Fraction of the taxels removed from the map the image and mask were made on (0: the
    /// whole map; see [`Removal`]).
    pub removed: f64,
    /// Fraction of the taxels dead in blind spots on the map the image and mask were made on
    /// (0: none; see [`DeadSpots`]).
    pub dead: f64,
}

/// Where a pixel of the full-resolution grid takes its value from.
#[derive(Debug, Clone, Copy)]
struct Source {
    taxels: [u32; 3],
    weights: [f32; 3],
}

/// Draws labelled contacts on one tactile map.
#[derive(Debug, Clone)]
pub struct Synthesizer {
    options: SynthOptions,
    points: Vec<Point2<f64>>,
    imager: TactileImager,
    /// Full-resolution grid: per pixel, its taxels and weights (None outside the map).
    sources: Vec<Option<Source>>,
    rows: usize,
    cols: usize,
    /// Map bounds.
    lo: Point2<f64>,
    hi: Point2<f64>,
    // Per-sample buffers.
    grey: Vec<u8>,
    labels: Vec<u8>,
    /// Degraded maps some samples are imaged through ([`Synthesizer::with_removal`],
    /// [`Synthesizer::with_dead_spots`]).
    degraded: Degradations,
}

impl Synthesizer {
    /// A generator for `map`.
    pub fn new(map: &TactileMap, options: SynthOptions) -> skin_geom::Result<Synthesizer> {
        let raster = Rasterizer::new(map, Grid::StepMm(options.step_mm))?;
        let (rows, cols) = (raster.rows(), raster.cols());
        let mut sources = Vec::with_capacity(rows * cols);
        for r in 0..rows {
            for c in 0..cols {
                sources.push(raster.back_project(r, c).map(|b| Source {
                    taxels: b.taxels.map(|t| t as u32),
                    weights: b.weights.map(|w| w as f32),
                }));
            }
        }
        let (lo, hi) = map.bounds();
        let size = options.image_size;
        let imager = TactileImager::new(raster, Normalisation::ContactMax, true, Some(size))?;
        Ok(Synthesizer {
            options,
            points: map.points.clone(),
            imager,
            sources,
            rows,
            cols,
            lo,
            hi,
            grey: vec![0; rows * cols],
            labels: vec![0; rows * cols],
            degraded: Degradations::default(),
        })
    }

    /// The options.
    pub fn options(&self) -> &SynthOptions {
        &self.options
    }

    /// Subject `subject` of the dataset drawn with `seed`.
    pub fn subject(seed: u64, subject: u32) -> Subject {
        Subject::sample(&mut ChaCha8Rng::seed_from_u64(mix(seed, subject, u32::MAX)))
    }

    /// Sample `index` of `subject` in the dataset drawn with `seed`: a hand with probability
    /// [`SynthOptions::hand_fraction`], else another contact.
    pub fn sample(&mut self, seed: u64, subject: u32, index: u32) -> Sample {
        let who = Self::subject(seed, subject);
        let mut rng = ChaCha8Rng::seed_from_u64(mix(seed, subject, index));
        let kind = if rng.random_bool(self.options.hand_fraction.clamp(0.0, 1.0)) {
            Kind::Hand(Interaction::ALL[rng.random_range(0..Interaction::ALL.len())])
        } else {
            Kind::Other(ObjectKind::sample(&mut rng, self.options.small_objects))
        };
        let mut sample = self.sample_kind(&who, subject, kind, &mut rng);
        self.degraded
            .apply(seed, subject, index, &mut sample, self.options.image_size);
        sample
    }

    fn sample_kind(&mut self, who: &Subject, subject: u32, kind: Kind, rng: &mut ChaCha8Rng) -> Sample {
        let n = self.points.len();
        let reach = match kind {
            Kind::Hand(_) => 0.75 * who.hand_length,
            Kind::Other(_) => 0.3,
        };
        // Place the contact on the skin, or (30% of the time) partly beyond its edge (Ch. 4.2);
        // draw again if fewer than three taxels feel it. The map's own outline cuts what lies
        // beyond it, so an overhanging contact is imaged as the skin's edge clips it.
        let size = match kind {
            Kind::Hand(_) => who.hand_length,
            // A small print (at most 2.8 cm across) overhangs by up to 8 mm.
            Kind::Other(c) if c.is_small() => 0.04,
            Kind::Other(_) => 0.1,
        };
        let margin = if rng.random_bool(0.3) {
            0.2 * size
        } else {
            -0.15 * size
        };
        let span = |lo: f64, hi: f64| {
            let (a, b) = (lo - margin, hi + margin);
            if a < b {
                (a, b)
            } else {
                (0.5 * (lo + hi), 0.5 * (lo + hi) + 1e-9)
            }
        };
        let (xs, ys) = (span(self.lo.x, self.hi.x), span(self.lo.y, self.hi.y));
        let mut patches = Vec::new();
        let mut fingertips_only = false;
        let mut raw = vec![0.0f64; n];
        let mut parts = vec![0u8; n];
        for attempt in 0..50 {
            let centre = if attempt < 49 {
                Point2::new(rng.random_range(xs.0..xs.1), rng.random_range(ys.0..ys.1))
            } else {
                nalgebra::center(&self.lo, &self.hi)
            };
            let at = Placement {
                centre,
                angle: contact_angle(kind, rng),
            };
            (patches, fingertips_only) = match kind {
                Kind::Hand(action) => {
                    let h = hand::hand(who, action, &at, rng);
                    (h.patches, h.fingertips_only)
                }
                Kind::Other(c) => (objects::object(c, &at, who.hand_length / 0.185, rng), false),
            };
            for (i, p) in self.points.iter().enumerate() {
                (raw[i], parts[i]) = press(&patches, *p);
            }
            let top = raw.iter().copied().fold(0.0, f64::max);
            if raw.iter().filter(|&&v| v > 0.15 * top && top > 0.0).count() >= 3 {
                break;
            }
        }
        let partial = self.on_skin_fraction(&patches, reach) < 0.85;

        let pressures = self.readings(&raw, &mut parts, rng);
        let (image, mask) = self.image_and_mask(&pressures, &parts);
        Sample {
            kind,
            subject,
            partial,
            fingertips_only,
            pressures,
            taxel_parts: parts,
            image,
            mask,
            removed: 0.0,
            dead: 0.0,
        }
    }

    /// Readings in whole raw counts from the contact's `raw` pressures: scaled to a peak, with
    /// noise, a few spikes, and the dead band (which also clears those taxels' `parts`).
    fn readings(&self, raw: &[f64], parts: &mut [u8], rng: &mut ChaCha8Rng) -> Vec<f32> {
        let n = raw.len();
        let top = raw.iter().copied().fold(0.0, f64::max).max(1e-12);
        let (lo, hi) = self.options.peak;
        let peak = rng.random_range(lo.min(hi)..=hi.max(lo)) as f64;
        let noise = Normal::new(0.0, f64::from(self.options.noise)).ok();
        let mut pressures: Vec<f32> = raw
            .iter()
            .map(|&v| {
                let n = noise.map_or(0.0, |d| d.sample(rng));
                (v / top * peak * rng.random_range(0.97..1.03) + n).round() as f32
            })
            .collect();
        if n > 0 && rng.random_bool(0.3) {
            for _ in 0..rng.random_range(1..=3) {
                pressures[rng.random_range(0..n)] += (rng.random_range(0.1..0.5) * peak).round() as f32;
            }
        }
        let dead_band = self.options.dead_band;
        for (p, part) in pressures.iter_mut().zip(parts.iter_mut()) {
            if *p < dead_band {
                *p = 0.0;
                *part = 0;
            }
        }
        pressures
    }

    /// The fraction of the patches' area (sampled every 5 mm within `reach` of their centre)
    /// that lies on the skin.
    fn on_skin_fraction(&self, patches: &[Patch], reach: f64) -> f64 {
        let Some(first) = patches.first() else {
            return 1.0;
        };
        let centre = first.origin;
        let k = (reach / 0.005).ceil() as i64;
        let (mut total, mut on) = (0usize, 0usize);
        for i in -k..=k {
            for j in -k..=k {
                let p = centre + Vector2::new(i as f64, j as f64) * 0.005;
                if press(patches, p).0 > 0.0 {
                    total += 1;
                    on += usize::from(
                        self.imager
                            .raster()
                            .pixel_of(p)
                            .is_some_and(|(r, c)| self.sources[r * self.cols + c].is_some()),
                    );
                }
            }
        }
        if total == 0 { 1.0 } else { on as f64 / total as f64 }
    }

    /// The tactile image of `pressures` through the real pipeline, and its part mask.
    ///
    /// The mask follows the image: a pixel of the full grid takes the part of the taxel that
    /// contributes most to it (barycentric weight x reading); a pixel that only the dilation
    /// lights takes the part of the brightest eroded pixel within its disk (the pixel whose value
    /// the dilation copied); resizing takes the majority part of each output pixel's block; black
    /// output pixels are background.
    ///
    /// With [`MaskLabels::Pressing`], a lit pixel keeps its own taxel's part even where the
    /// dilation paints it with a brighter neighbour's value: otherwise a bright finger's part spreads 4 mm over the palm's taxels,
    /// and the mask read at the taxels (as `parts::part_contacts` reads a segmentation) gave
    /// 8.4% of the pressed taxels another part than the one pressing them.
    fn image_and_mask(&mut self, pressures: &[f32], parts: &[u8]) -> (Vec<u8>, Vec<u8>) {
        let image = image_of(&mut self.imager, pressures, self.options.image_size);
        let k_bar = pressures.iter().copied().fold(0.0f32, f32::max);
        let gain = if k_bar > 0.0 { 255.0 / k_bar } else { 0.0 };
        for ((g, &k), (l, s)) in self
            .grey
            .iter_mut()
            .zip(self.imager.pressure_image())
            .zip(self.labels.iter_mut().zip(&self.sources))
        {
            *g = (k * gain).clamp(0.0, 255.0) as u8;
            *l = s.map_or(0, |s| {
                let mut best = (0.0f32, 0u8);
                for (&t, &w) in s.taxels.iter().zip(&s.weights) {
                    let v = w * pressures[t as usize];
                    if v > best.0 {
                        best = (v, parts[t as usize]);
                    }
                }
                best.1
            });
        }
        let (rows, cols) = (self.rows, self.cols);
        let eroded = skin_geom::erode_disk(&self.grey, rows, cols, TactileImager::EROSION_RADIUS);
        let own_first = self.options.labels == MaskLabels::Pressing;
        let dilated = dilate_labels(
            &eroded,
            &self.labels,
            rows,
            cols,
            TactileImager::DILATION_RADIUS,
            own_first,
        );
        let ImageSize {
            rows: out_rows,
            cols: out_cols,
        } = self.options.image_size;
        let mut mask = vec![0u8; out_rows * out_cols];
        for (o, m) in mask.iter_mut().enumerate() {
            if image[o] == 0 {
                continue;
            }
            let (r, c) = (o / out_cols, o % out_cols);
            let (r0, r1) = block(r, rows, out_rows);
            let (c0, c1) = block(c, cols, out_cols);
            let mut votes = [0u32; 7];
            for y in r0..r1 {
                for &l in &dilated[y * cols + c0..y * cols + c1] {
                    if l > 0 && usize::from(l) < votes.len() {
                        votes[usize::from(l)] += 1;
                    }
                }
            }
            let (best, count) = votes
                .iter()
                .enumerate()
                .max_by_key(|&(i, v)| (*v, std::cmp::Reverse(i)))
                .unwrap_or((0, &0));
            *m = if *count > 0 { best as u8 } else { 0 };
        }
        (image, mask)
    }
}

/// The rotation of a contact on the map. Grasping, twisting and pulling wrap the fingers around
/// the link, so they run across its axis, taken as the map's long side (u, which the flattening
/// aligns with the longest extent): the map's v direction, either way, within about 25 degrees.
/// Pushes and other contacts come at any angle.
fn contact_angle(kind: Kind, rng: &mut ChaCha8Rng) -> f64 {
    use std::f64::consts::{PI, TAU};
    match kind {
        Kind::Hand(Interaction::Grasp | Interaction::TwistCw | Interaction::TwistCcw | Interaction::Pull) => {
            let flip = if rng.random_bool(0.5) { PI } else { 0.0 };
            flip + Normal::new(0.0, 25f64.to_radians()).map_or(0.0, |n| n.sample(rng))
        }
        _ => rng.random_range(0.0..TAU),
    }
}

/// Source rows (or columns) [start, end) covered by output row `i` of `n_out` from `n_src`.
fn block(i: usize, n_src: usize, n_out: usize) -> (usize, usize) {
    let start = i * n_src / n_out;
    let end = ((i + 1) * n_src)
        .div_ceil(n_out)
        .clamp(start + 1, n_src.max(start + 1));
    (start, end.min(n_src))
}

/// The labels of a grey dilation with a disk of `radius`: a pixel takes the label of the
/// brightest `grey` pixel within the disk (first in raster order on ties; the pixel whose value
/// the dilation copied), or 0 if all are black; with `own_first`, a pixel with a label of its
/// own keeps it ([`MaskLabels::Pressing`]).
fn dilate_labels(
    grey: &[u8],
    labels: &[u8],
    rows: usize,
    cols: usize,
    radius: usize,
    own_first: bool,
) -> Vec<u8> {
    let r = radius as isize;
    let offsets: Vec<(isize, isize)> = (-r..=r)
        .flat_map(|dy| (-r..=r).map(move |dx| (dy, dx)))
        .filter(|(dy, dx)| dy * dy + dx * dx <= r * r)
        .collect();
    let mut out = vec![0u8; rows * cols];
    for y in 0..rows as isize {
        for x in 0..cols as isize {
            let own = labels[y as usize * cols + x as usize];
            if own_first && own > 0 {
                out[y as usize * cols + x as usize] = own;
                continue;
            }
            let mut best = (0u8, 0u8);
            for &(dy, dx) in &offsets {
                let (yy, xx) = (y + dy, x + dx);
                if yy < 0 || xx < 0 || yy >= rows as isize || xx >= cols as isize {
                    continue;
                }
                let i = yy as usize * cols + xx as usize;
                if grey[i] > best.0 {
                    best = (grey[i], labels[i]);
                }
            }
            out[y as usize * cols + x as usize] = best.1;
        }
    }
    out
}

/// One 64-bit seed per (dataset seed, subject, sample), well mixed (SplitMix64 steps).
fn mix(seed: u64, subject: u32, index: u32) -> u64 {
    let mut z = seed ^ (u64::from(subject) << 32 | u64::from(index)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for _ in 0..2 {
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_as_imaged_follow_the_brighter_pixel_the_dilation_copied() {
        // One row: a bright pixel of part 2 beside a dim one of part 5, then black.
        let grey = [200, 50, 0, 0, 0, 0];
        let labels = [2, 5, 0, 0, 0, 0];
        // Pressing: the dim pixel keeps its own part; the black ones take the brightest within 2.
        assert_eq!(dilate_labels(&grey, &labels, 1, 6, 2, true), [2, 5, 2, 5, 0, 0]);
        // As imaged: the dim pixel shows the bright one's value, so its part too.
        assert_eq!(dilate_labels(&grey, &labels, 1, 6, 2, false), [2, 2, 2, 5, 0, 0]);
    }
}
