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
            return Err(Error::Parameter {
                name: "blind-spot radius (mm)",
                value: self.radius_mm,
                expected: "a non-negative number of millimetres",
            });
        }
        if self.spots > map.points.len() {
            return Err(Error::Parameter {
                name: "blind spots",
                value: self.spots as f64,
                expected: "at most one per taxel of the map",
            });
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
            return Err(Error::Parameter {
                name: "fraction of taxels removed",
                value: self.fraction,
                expected: "from 0 up to (not including) 1",
            });
        }
        let removed = (self.fraction * n as f64).round() as usize;
        let mut keep: Vec<usize> = Self::order(self.seed, n)[removed.min(n)..].to_vec();
        keep.sort_unstable();
        Ok(keep)
    }

    /// The map of the surviving taxels, re-triangulated in the map plane.
    pub fn apply(&self, map: &TactileMap) -> Result<TactileMap> {
        keep_only(map, &self.survivors(map.points.len())?)
    }
}

/// The map without the taxels at `dead` (indices into its taxels): dead taxels (no reading in a
/// recording, no bus slot, a placeholder id) are handled as Test B handles removed ones, the
/// survivors re-triangulated in the map plane where the map had skin, so an image interpolates
/// across a dead taxel instead of showing a hole. Indices out of range are ignored.
pub(crate) fn without_taxels(map: &TactileMap, dead: &[usize]) -> Result<TactileMap> {
    keep_only(map, &alive(map.points.len(), dead))
}

/// The indices below `n` not in `dead`, increasing.
fn alive(n: usize, dead: &[usize]) -> Vec<usize> {
    let mut is_dead = vec![false; n];
    for &i in dead {
        if let Some(d) = is_dead.get_mut(i) {
            *d = true;
        }
    }
    (0..n).filter(|&i| !is_dead[i]).collect()
}

/// The map with every taxel in its place (same indices, ids and points) but its triangles made
/// again without the `dead` ones, as [`without_taxels`] makes them: a dead taxel belongs to no
/// triangle, so contacts join across it and images interpolate across it, while readings keep
/// the layout's order. What a running session needs when a recording lacks some taxels.
pub(crate) fn bridging_dead(map: &TactileMap, dead: &[usize]) -> Result<TactileMap> {
    let keep = alive(map.points.len(), dead);
    let reduced = keep_only(map, &keep)?;
    Ok(TactileMap {
        faces: reduced.faces.iter().map(|f| f.map(|k| keep[k])).collect(),
        ..map.clone()
    })
}

/// The map of the taxels `keep` (increasing indices), re-triangulated in the map plane.
fn keep_only(map: &TactileMap, keep: &[usize]) -> Result<TactileMap> {
    if keep.len() < 3 {
        return Err(Error::TooFewTaxels(format!(
            "{} taxels survive: a map needs at least 3",
            keep.len()
        )));
    }
    let points: Vec<Point2<f64>> = keep.iter().map(|&i| map.points[i]).collect();
    let skin = FaceGrid::new(map);
    let mut faces = Vec::new();
    for t in delaunay(&points)? {
        let [a, b, c] = t.map(|i| points[i]);
        let centroid = Point2::from((a.coords + b.coords + c.coords) / 3.0);
        if (b - a).perp(&(c - a)) > 0.0 && skin.contains(&centroid) {
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

/// The map's triangles bucketed on a uniform grid of about one cell per triangle, so that
/// "is this point on the skin?" tests a handful of triangles instead of all of them (a removal
/// level is then one Delaunay and a linear pass, not quadratic in the taxels).
struct FaceGrid<'a> {
    map: &'a TactileMap,
    origin: Point2<f64>,
    cell: f64,
    cols: usize,
    rows: usize,
    /// Face indices of cell `r * cols + c` are `faces[start[k]..start[k + 1]]`.
    start: Vec<usize>,
    faces: Vec<usize>,
}

impl<'a> FaceGrid<'a> {
    fn new(map: &'a TactileMap) -> FaceGrid<'a> {
        let (mut lo, mut hi) = (Point2::new(f64::MAX, f64::MAX), Point2::new(f64::MIN, f64::MIN));
        for p in &map.points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        let n = map.faces.len().max(1);
        let (w, h) = ((hi.x - lo.x).max(0.0), (hi.y - lo.y).max(0.0));
        let cell = ((w * h / n as f64).sqrt()).max(w.max(h) / 4096.0).max(1e-12);
        let cols = ((w / cell) as usize + 1).min(4096);
        let rows = ((h / cell) as usize + 1).min(4096);
        let cell_of = |x: f64, y: f64| {
            let c = (((x - lo.x) / cell) as usize).min(cols - 1);
            let r = (((y - lo.y) / cell) as usize).min(rows - 1);
            (r, c)
        };
        // Counting sort of (cell, face) pairs by cell.
        let mut pairs: Vec<(usize, usize)> = Vec::with_capacity(map.faces.len() * 2);
        for (f, face) in map.faces.iter().enumerate() {
            let [a, b, c] = face.map(|i| map.points[i]);
            let (r0, c0) = cell_of(a.x.min(b.x).min(c.x), a.y.min(b.y).min(c.y));
            let (r1, c1) = cell_of(a.x.max(b.x).max(c.x), a.y.max(b.y).max(c.y));
            for r in r0..=r1 {
                for c in c0..=c1 {
                    pairs.push((r * cols + c, f));
                }
            }
        }
        let mut start = vec![0usize; rows * cols + 1];
        for &(k, _) in &pairs {
            start[k + 1] += 1;
        }
        for k in 0..rows * cols {
            start[k + 1] += start[k];
        }
        let mut next = start.clone();
        let mut faces = vec![0usize; pairs.len()];
        for &(k, f) in &pairs {
            faces[next[k]] = f;
            next[k] += 1;
        }
        FaceGrid {
            map,
            origin: lo,
            cell,
            cols,
            rows,
            start,
            faces,
        }
    }

    /// Whether `p` lies in one of the map's triangles (edges included).
    fn contains(&self, p: &Point2<f64>) -> bool {
        // Clamping is safe: a point outside the grid is in no triangle, and the test below is
        // exact whatever cell it looks in.
        let x = ((p.x - self.origin.x) / self.cell).max(0.0);
        let y = ((p.y - self.origin.y) / self.cell).max(0.0);
        let (c, r) = ((x as usize).min(self.cols - 1), (y as usize).min(self.rows - 1));
        let k = r * self.cols + c;
        self.faces[self.start[k]..self.start[k + 1]].iter().any(|&f| {
            let [a, b, c] = self.map.faces[f].map(|i| self.map.points[i]);
            let d1 = (b - a).perp(&(p - a));
            let d2 = (c - b).perp(&(p - b));
            let d3 = (a - c).perp(&(p - c));
            (d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0) || (d1 <= 0.0 && d2 <= 0.0 && d3 <= 0.0)
        })
    }
}

/// Segmentation ground truth on a degraded map (Ch. 5.3): with `image` the tactile image of the
/// degraded map (I_L^O) and `labels` the part labels drawn on the original map (I_H^T, 0 =
/// background), both the same size, the mask I_M = (labels > 0) AND (image > `threshold`) keeps
/// what both show: returns (I_L = I_L^O I_M, I_L^T = I_H^T I_M).
pub fn masked_ground_truth(image: &[u8], labels: &[u8], threshold: u8) -> Result<(Vec<u8>, Vec<u8>)> {
    if image.len() != labels.len() {
        return Err(Error::Length {
            what: "labels for the image's pixels",
            got: labels.len(),
            expected: image.len(),
        });
    }
    Ok(image
        .iter()
        .zip(labels)
        .map(|(&i, &l)| if l > 0 && i > threshold { (i, l) } else { (0, 0) })
        .unzip())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// The grid answers as the scan over every triangle it replaced.
    #[test]
    fn the_face_grid_agrees_with_a_scan_of_every_triangle() {
        let (w, h) = (20, 13);
        let points: Vec<Point2<f64>> = (0..w * h)
            .map(|k| {
                let (i, j) = ((k % w) as f64, (k / w) as f64);
                // A sheared, unevenly spaced grid, with a hole cut out below.
                Point2::new(0.01 * i + 0.003 * j + 0.0005 * (i * j).sin(), 0.008 * j)
            })
            .collect();
        let mut faces = Vec::new();
        for j in 0..h - 1 {
            for i in 0..w - 1 {
                if (5..9).contains(&i) && (4..8).contains(&j) {
                    continue;
                }
                let k = j * w + i;
                faces.push([k, k + 1, k + w + 1]);
                faces.push([k, k + w + 1, k + w]);
            }
        }
        let map = TactileMap {
            name: "grid".into(),
            ids: (0..points.len() as u32).map(skin_core::TaxelId).collect(),
            positions: Vec::new(),
            points,
            faces,
            report: Default::default(),
            zeroed: Vec::new(),
        };
        let grid = FaceGrid::new(&map);
        let scan = |p: &Point2<f64>| {
            map.faces.iter().any(|f| {
                let [a, b, c] = f.map(|i| map.points[i]);
                let d1 = (b - a).perp(&(p - a));
                let d2 = (c - b).perp(&(p - b));
                let d3 = (a - c).perp(&(p - c));
                (d1 >= 0.0 && d2 >= 0.0 && d3 >= 0.0) || (d1 <= 0.0 && d2 <= 0.0 && d3 <= 0.0)
            })
        };
        let (mut inside, mut outside) = (0, 0);
        for k in 0..40_000u32 {
            // A low-discrepancy walk over a box larger than the map, and every vertex.
            let x = -0.05 + 0.35 * ((f64::from(k) * 0.618_034) % 1.0);
            let y = -0.03 + 0.16 * ((f64::from(k) * 0.754_877) % 1.0);
            let p = Point2::new(x, y);
            assert_eq!(grid.contains(&p), scan(&p), "{p:?}");
            if scan(&p) {
                inside += 1;
            } else {
                outside += 1;
            }
        }
        for p in &map.points {
            assert_eq!(grid.contains(p), scan(p), "{p:?}");
        }
        assert!(inside > 1000 && outside > 1000, "{inside} {outside}");
    }
}
