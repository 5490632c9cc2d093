//! Degraded tactile maps for robustness studies (thesis Ch. 5), deterministic per seed.
//!
//! - [`BlindSpots`] (Test A, Ch. 5.2): groups of contiguous taxels fail during contact. Random
//!   taxels are the centres; every taxel within the radius of a centre (on the map) reads zero.
//!   The triangulation is unchanged: the map lists them in [`TactileMap::zeroed`].
//! - [`Decimation`] (Test B, Ch. 5.3): faulty taxels detected at rest are removed and the
//!   survivors re-triangulated in the map plane (Delaunay; no re-flattening). Removal follows one
//!   random order per seed, so the survivors of a larger fraction are a subset of those of a
//!   smaller one. New triangles are kept only where the original map had skin (their centroid
//!   inside an original triangle), so holes and concave borders stay open.
//! - [`masked_ground_truth`] (Ch. 5.3): the segmentation ground truth of a degraded image.

use crate::tactile_map::TactileMap;
use crate::triangulate::delaunay;
use crate::{Error, Result};
use nalgebra::Point2;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

/// Test A: `spots` blind spots of `radius_mm` around random taxels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlindSpots {
    /// Number of spots (the thesis uses 1 to 4).
    pub spots: usize,
    /// Radius of each spot on the map, millimetres (10 to 40 in the thesis).
    pub radius_mm: f64,
    /// Seed of the pattern.
    pub seed: u64,
}

impl BlindSpots {
    /// The map with the spots' taxels zeroed (added to any already zeroed).
    pub fn apply(&self, map: &TactileMap) -> Result<TactileMap> {
        if !(self.radius_mm.is_finite() && self.radius_mm >= 0.0) {
            return Err(Error::Mismatch(format!(
                "blind-spot radius must be a non-negative number of millimetres, not {}",
                self.radius_mm
            )));
        }
        if self.spots > map.points.len() {
            return Err(Error::Mismatch(format!(
                "{} blind spots on a map of {} taxels",
                self.spots,
                map.points.len()
            )));
        }
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let centres = rand::seq::index::sample(&mut rng, map.points.len(), self.spots);
        let r = self.radius_mm * 1e-3;
        let mut zeroed = map.zeroed.clone();
        for c in centres.iter() {
            let centre = map.points[c];
            zeroed.extend((0..map.points.len()).filter(|&i| (map.points[i] - centre).norm() <= r));
        }
        zeroed.sort_unstable();
        zeroed.dedup();
        Ok(TactileMap {
            zeroed,
            ..map.clone()
        })
    }
}

/// Test B: remove `fraction` of the taxels (0 to 1) in a random order fixed by `seed`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Decimation {
    /// Fraction of taxels removed (0.1 to 0.7 in the thesis).
    pub fraction: f64,
    /// Seed of the removal order.
    pub seed: u64,
}

impl Decimation {
    /// The seed's removal order: a permutation of `0..n`; removing `k` taxels removes the first
    /// `k` of it, whatever the fraction, which makes the levels nested.
    pub fn order(seed: u64, n: usize) -> Vec<usize> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut order: Vec<usize> = (0..n).collect();
        order.shuffle(&mut rng);
        order
    }

    /// Indices (into the map's taxels, increasing) of the taxels that survive.
    pub fn survivors(&self, n: usize) -> Result<Vec<usize>> {
        if !(self.fraction.is_finite() && (0.0..1.0).contains(&self.fraction)) {
            return Err(Error::Mismatch(format!(
                "the fraction of taxels removed must be in [0, 1), not {}",
                self.fraction
            )));
        }
        let removed = (self.fraction * n as f64).round() as usize;
        let mut keep: Vec<usize> = Self::order(self.seed, n)[removed.min(n)..].to_vec();
        keep.sort_unstable();
        Ok(keep)
    }

    /// The map of the surviving taxels, re-triangulated in the map plane.
    pub fn apply(&self, map: &TactileMap) -> Result<TactileMap> {
        let keep = self.survivors(map.points.len())?;
        if keep.len() < 3 {
            return Err(Error::TooFewTaxels(format!(
                "{} taxels survive: a map needs at least 3",
                keep.len()
            )));
        }
        let points: Vec<Point2<f64>> = keep.iter().map(|&i| map.points[i]).collect();
        let mut faces = Vec::new();
        for t in delaunay(&points)? {
            let [a, b, c] = t.map(|i| points[i]);
            let centroid = Point2::from((a.coords + b.coords + c.coords) / 3.0);
            if (b - a).perp(&(c - a)) > 0.0 && on_skin(map, &centroid) {
                faces.push(t);
            }
        }
        let mut new_index = vec![usize::MAX; map.points.len()];
        for (k, &i) in keep.iter().enumerate() {
            new_index[i] = k;
        }
        Ok(TactileMap {
            name: map.name.clone(),
            ids: keep.iter().map(|&i| map.ids[i]).collect(),
            positions: if map.positions.is_empty() {
                Vec::new()
            } else {
                keep.iter().map(|&i| map.positions[i]).collect()
            },
            points,
            faces,
            report: map.report.clone(),
            zeroed: map
                .zeroed
                .iter()
                .filter_map(|&i| (new_index[i] != usize::MAX).then_some(new_index[i]))
                .collect(),
        })
    }
}

/// Whether `p` lies in one of the map's triangles.
fn on_skin(map: &TactileMap, p: &Point2<f64>) -> bool {
    map.faces.iter().any(|f| {
        let [a, b, c] = f.map(|i| map.points[i]);
        let d1 = (b - a).perp(&(p - a));
        let d2 = (c - b).perp(&(p - b));
        let d3 = (a - c).perp(&(p - c));
        (d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0) || (d1 <= 0.0 && d2 <= 0.0 && d3 <= 0.0)
    })
}

/// Segmentation ground truth on a degraded map (Ch. 5.3): with `image` the tactile image of the
/// degraded map (I_L^O) and `labels` the part labels drawn on the original map (I_H^T, 0 =
/// background), both the same size, the mask I_M = (labels > 0) AND (image > `threshold`) keeps
/// what both show: returns (I_L = I_L^O I_M, I_L^T = I_H^T I_M).
pub fn masked_ground_truth(image: &[u8], labels: &[u8], threshold: u8) -> Result<(Vec<u8>, Vec<u8>)> {
    if image.len() != labels.len() {
        return Err(Error::Mismatch(format!(
            "image has {} pixels, labels {}",
            image.len(),
            labels.len()
        )));
    }
    Ok(image
        .iter()
        .zip(labels)
        .map(|(&i, &l)| if l > 0 && i > threshold { (i, l) } else { (0, 0) })
        .unzip())
}
