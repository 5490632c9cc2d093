//! What each hand part does, once a tactile image is segmented (thesis Fig. 4.9): how many
//! taxels it presses, their mean reading, and where it presses on the 3D link.
//!
//! Each taxel takes the part of the output pixel its map position falls in; the centroid is the
//! reading-weighted mean of those taxels' 3D positions, so it lies where the part presses on the
//! link, not on the flat map.

use nalgebra::Point3;
use skin_core::image::ImageSize;
use skin_geom::{Rasterizer, TactileMap};

/// The segmentation classes (thesis Ch. 4.4), as stored in part masks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum Part {
    /// No hand part: no contact, or a contact that is not a hand.
    Background = 0,
    /// Thumb.
    Thumb = 1,
    /// Index finger.
    Index = 2,
    /// Middle finger.
    Middle = 3,
    /// Ring finger.
    Ring = 4,
    /// Little finger.
    Pinkie = 5,
    /// Palm.
    Palm = 6,
}

impl Part {
    /// All classes in label order.
    pub const ALL: [Part; 7] = [
        Part::Background,
        Part::Thumb,
        Part::Index,
        Part::Middle,
        Part::Ring,
        Part::Pinkie,
        Part::Palm,
    ];

    /// The class of a mask value, if it is one.
    pub fn from_label(label: u8) -> Option<Part> {
        Part::ALL.get(usize::from(label)).copied()
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Part::Background => "background",
            Part::Thumb => "thumb",
            Part::Index => "index",
            Part::Middle => "middle",
            Part::Ring => "ring",
            Part::Pinkie => "pinkie",
            Part::Palm => "palm",
        }
    }
}

/// Colours of the parts, in label order (background black): [`colour_mask`].
const COLOURS: [[u8; 3]; 7] = [
    [0, 0, 0],
    [230, 25, 75],
    [60, 180, 75],
    [255, 225, 25],
    [0, 130, 200],
    [245, 130, 48],
    [145, 30, 180],
];

/// A part mask as RGB pixels (3 bytes per label), one colour per part, white for a label that
/// is not a part: what `skin segment` writes as `*_parts.png`.
pub fn colour_mask(labels: &[u8]) -> Vec<u8> {
    labels
        .iter()
        .flat_map(|&l| COLOURS.get(usize::from(l)).copied().unwrap_or([255, 255, 255]))
        .collect()
}

/// Each label's share of a part mask's pressed (non-background) pixels, by label.
#[derive(Debug, Clone, PartialEq)]
pub struct Shares(pub Vec<(u8, f64)>);

impl Shares {
    /// The shares of `labels`: each label above 0 that occurs, with the fraction (0..1) of the
    /// pressed pixels it has, in label order.
    pub fn of(labels: &[u8]) -> Shares {
        let mut counts = [0usize; 256];
        for &l in labels {
            counts[usize::from(l)] += 1;
        }
        let pressed: usize = counts[1..].iter().sum();
        Shares(
            (1..=255u8)
                .zip(&counts[1..])
                .filter(|(_, n)| **n > 0)
                .map(|(l, n)| (l, *n as f64 / pressed as f64))
                .collect(),
        )
    }
}

/// E.g. "palm 52%, index 20%" (a label that is not a part is "`class<label>`"), or "no hand part".
impl std::fmt::Display for Shares {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_empty() {
            return f.write_str("no hand part");
        }
        for (k, (label, share)) in self.0.iter().enumerate() {
            let sep = if k == 0 { "" } else { ", " };
            match Part::from_label(*label) {
                Some(p) => write!(f, "{sep}{} {:.0}%", p.name(), 100.0 * share)?,
                None => write!(f, "{sep}class{label} {:.0}%", 100.0 * share)?,
            }
        }
        Ok(())
    }
}

/// A part is written by its name (`"thumb"`, ...), as events and tables give it.
impl serde::Serialize for Part {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// One hand part's share of a contact.
#[derive(Debug, Clone, PartialEq)]
pub struct PartContact {
    /// The part.
    pub part: Part,
    /// Taxels with a positive reading under it.
    pub taxels: usize,
    /// Their mean reading, in the frame's units.
    pub mean_pressure: f32,
    /// Reading-weighted centroid of their 3D positions, metres in the link frame (`None` when
    /// the map has no 3D positions).
    pub centroid: Option<Point3<f64>>,
}

/// The parts pressing in `labels` (a segmentation of `size`, the image made from
/// `pressures` through `raster` on `map`), thumb to palm; parts with no pressed taxel are left
/// out.
pub fn part_contacts(
    map: &TactileMap,
    raster: &Rasterizer,
    size: ImageSize,
    labels: &[u8],
    pressures: &[f32],
) -> Vec<PartContact> {
    let mut sums = [(0usize, 0.0f64, nalgebra::Vector3::zeros()); 7];
    for (i, label) in taxel_labels(map, raster, size, labels, pressures) {
        let Some(slot) = sums.get_mut(usize::from(label)) else {
            continue;
        };
        let p = pressures[i];
        slot.0 += 1;
        slot.1 += f64::from(p);
        if let Some(x) = map.positions.get(i) {
            slot.2 += x.coords * f64::from(p);
        }
    }
    Part::ALL[1..]
        .iter()
        .zip(&sums[1..])
        .filter(|(_, s)| s.0 > 0)
        .map(|(&part, &(n, sum, moment))| PartContact {
            part,
            taxels: n,
            mean_pressure: (sum / n as f64) as f32,
            centroid: (map.positions.len() == map.points.len()).then(|| Point3::from(moment / sum)),
        })
        .collect()
}

/// Each pressed taxel (positive reading, not zeroed in `map`) with the label of the output
/// pixel of `labels` (of `size`) its map position falls in: (taxel index in map order,
/// label). Taxels off the image are left out. This is how a segmentation reaches the taxels, so
/// it is also how a segmenter is scored against per-taxel truth.
pub fn taxel_labels<'a>(
    map: &'a TactileMap,
    raster: &'a Rasterizer,
    size: ImageSize,
    labels: &'a [u8],
    pressures: &'a [f32],
) -> impl Iterator<Item = (usize, u8)> + 'a {
    let ImageSize { rows, cols } = size;
    pressures
        .iter()
        .zip(&map.points)
        .enumerate()
        .filter_map(move |(i, (&p, point))| {
            if !(p > 0.0) || map.zeroed.binary_search(&i).is_ok() {
                return None;
            }
            let (r, c) = raster.pixel_of(*point)?;
            let (r, c) = (r * rows / raster.rows().max(1), c * cols / raster.cols().max(1));
            labels.get(r * cols + c).map(|&label| (i, label))
        })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test
    use super::*;
    use nalgebra::{Unit, Vector3};
    use skin_core::{LinkSkin, Taxel, TaxelId};
    use skin_geom::{FlattenOptions, Grid};

    #[test]
    fn shares_and_colours_of_a_mask() {
        // 6 pressed pixels: 3 palm, 2 index, 1 of a label that is no part; 4 background.
        let labels = [0, 6, 6, 0, 2, 6, 0, 2, 9, 0];
        let s = Shares::of(&labels);
        assert_eq!(s.0, vec![(2, 2.0 / 6.0), (6, 0.5), (9, 1.0 / 6.0)]);
        assert_eq!(s.to_string(), "index 33%, palm 50%, class9 17%");
        assert_eq!(Shares::of(&[0, 0]).to_string(), "no hand part");
        assert_eq!(Shares::of(&[]).to_string(), "no hand part");
        let rgb = colour_mask(&[0, 1, 9]);
        assert_eq!(rgb, [0, 0, 0, 230, 25, 75, 255, 255, 255]);
    }

    #[test]
    fn two_parts_get_their_taxels_and_centroids() {
        // A flat 20 x 10 patch, 10 mm pitch: left half labelled thumb, right half palm.
        let taxels = (0..200u32)
            .map(|i| Taxel {
                id: TaxelId(i),
                position: Point3::new((i % 20) as f64 * 0.01, (i / 20) as f64 * 0.01, 0.0),
                normal: Unit::new_normalize(Vector3::z()),
            })
            .collect();
        let map = TactileMap::flatten(&LinkSkin::new("p", taxels), &FlattenOptions::default()).unwrap();
        let raster = Rasterizer::new(&map, Grid::StepMm(1.0)).unwrap();
        let size = ImageSize { rows: 10, cols: 20 };
        let labels: Vec<u8> = (0..200).map(|k| if k % 20 < 10 { 1 } else { 6 }).collect();
        // Two pressed taxels under each half (in map coordinates, whatever the flattening did).
        let mut pressures = vec![0.0f32; 200];
        let mut expected = [Vec::new(), Vec::new()];
        for (i, p) in map.points.iter().enumerate() {
            let (r, c) = raster.pixel_of(*p).unwrap();
            let (r, c) = (r * 10 / raster.rows(), c * 20 / raster.cols());
            let half = usize::from(labels[r * 20 + c] == 6);
            if expected[half].len() < 2 && r > 2 && c % 10 > 2 {
                pressures[i] = 10.0 * (expected[half].len() + 1) as f32;
                expected[half].push(i);
            }
        }
        // Only the pressed taxels reach the segmentation, each with its half's label.
        let got: Vec<(usize, u8)> = taxel_labels(&map, &raster, size, &labels, &pressures).collect();
        let mut want: Vec<(usize, u8)> = expected[0].iter().map(|&i| (i, 1)).collect();
        want.extend(expected[1].iter().map(|&i| (i, 6)));
        want.sort_unstable();
        assert_eq!(got, want);
        let parts = part_contacts(&map, &raster, size, &labels, &pressures);
        assert_eq!(parts.len(), 2);
        for (pc, taxels) in parts.iter().zip(&expected) {
            assert_eq!(pc.taxels, 2);
            assert!((pc.mean_pressure - 15.0).abs() < 1e-6);
            let want =
                (map.positions[taxels[0]].coords * 10.0 + map.positions[taxels[1]].coords * 20.0) / 30.0;
            assert!((pc.centroid.unwrap().coords - want).norm() < 1e-12);
        }
        assert_eq!((parts[0].part, parts[1].part), (Part::Thumb, Part::Palm));
    }
}
