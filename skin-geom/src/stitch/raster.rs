//! One tactile image over a chain of stitched maps.

use crate::raster::{Grid, Rasterizer};
use crate::stitch::{BridgeTriangle, Placement};
use crate::tactile_map::TactileMap;
use crate::{ChainError, Error, Result};
use nalgebra::{Point2, Vector2};
use std::ops::Range;

/// The most pixels a stitched canvas may have (its lookup holds two indices a pixel).
const MAX_CANVAS_PIXELS: usize = 50_000_000;

/// One tactile image over a chain of stitched maps.
///
/// Every link keeps its own [`Rasterizer`], built once at the common pixel step: its barycentric
/// tables never change. When the stitcher moves the maps, [`StitchedRasterizer::place`] only
/// recomputes which link pixel each pixel of the stitched canvas shows (the nearest one under the
/// inverse placement); a frame is then each link's image plus one gather. Where two placed maps
/// overlap, the link earlier in the chain is shown. The skin between two links' maps is filled
/// from the stitcher's bridge triangles (barycentric interpolation across the joint, as within a
/// map), so a touch spanning a joint shows as one contact.
#[derive(Debug, Clone)]
pub struct StitchedRasterizer {
    links: Vec<Rasterizer>,
    /// Per link, which of its pixels a triangle covers.
    covered: Vec<Vec<bool>>,
    /// Per link, its rendered pressure image (scratch).
    images: Vec<Vec<f32>>,
    step: f64,
    rows: usize,
    cols: usize,
    /// Per canvas pixel: (link + 1, link pixel), or (0, 0) where no map is.
    lookup: Vec<(u32, u32)>,
    /// Top-left corner of the canvas in the stitched plane.
    corner: Point2<f64>,
    /// Each link's taxels on its map.
    points: Vec<Vec<Point2<f64>>>,
    /// Canvas pixels under a bridge triangle.
    bridge_pixels: Vec<BridgePixel>,
}

/// A canvas pixel under a bridge triangle: pixel index, corners (link, taxel), weights.
type BridgePixel = (u32, [(u32, u32); 3], [f32; 3]);

impl StitchedRasterizer {
    /// Rasterizers for `maps` at a pixel side of `step_mm` millimetres; call
    /// [`StitchedRasterizer::place`] before the first frame.
    pub fn new(maps: &[TactileMap], step_mm: f64) -> Result<StitchedRasterizer> {
        let mut links = Vec::with_capacity(maps.len());
        let mut covered = Vec::with_capacity(maps.len());
        let mut images = Vec::with_capacity(maps.len());
        for map in maps {
            let r = Rasterizer::new(map, Grid::StepMm(step_mm))?;
            let mut mask = vec![false; r.len()];
            for row in 0..r.rows() {
                for col in 0..r.cols() {
                    mask[row * r.cols() + col] = r.back_project(row, col).is_some();
                }
            }
            images.push(vec![0.0; r.len()]);
            covered.push(mask);
            links.push(r);
        }
        Ok(StitchedRasterizer {
            links,
            covered,
            images,
            step: step_mm * 1e-3,
            rows: 0,
            cols: 0,
            lookup: Vec::new(),
            corner: Point2::origin(),
            points: maps.iter().map(|m| m.points.clone()).collect(),
            bridge_pixels: Vec::new(),
        })
    }

    /// Canvas height, pixels.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Canvas width, pixels.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Centre of canvas pixel (row, col) in the stitched plane, metres (row 0 at the top).
    pub fn pixel_centre(&self, row: usize, col: usize) -> Point2<f64> {
        Point2::new(
            self.corner.x + (col as f64 + 0.5) * self.step,
            self.corner.y - (row as f64 + 0.5) * self.step,
        )
    }

    /// Lays the maps out with one placement per link and the bridge triangles across the joints
    /// (both from [`crate::StitchReport`]): sizes the canvas to their union and recomputes the
    /// pixel lookup.
    pub fn place(&mut self, placements: &[Placement], bridges: &[BridgeTriangle]) -> Result<()> {
        if placements.len() != self.links.len() {
            return Err(Error::Length {
                what: "placements for the stitched maps",
                got: placements.len(),
                expected: self.links.len(),
            });
        }
        // Canvas bounds: every link's raster corners, placed.
        let mut lo = Point2::new(f64::INFINITY, f64::INFINITY);
        let mut hi = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for (r, p) in self.links.iter().zip(placements) {
            let (a, b) = placed_box(r, p, self.step / 2.0);
            (lo, hi) = (lo.inf(&a), hi.sup(&b));
        }
        if !(lo.x.is_finite() && lo.y.is_finite() && hi.x.is_finite() && hi.y.is_finite()) {
            return Err(Error::NotFinite {
                what: "a placement".into(),
            });
        }
        let cols = (((hi.x - lo.x) / self.step).ceil() as usize).max(1);
        let rows = (((hi.y - lo.y) / self.step).ceil() as usize).max(1);
        // The canvas of a whole arm at a fine step may be long and thin, past the side limit of a
        // tactile image: what bounds it is the memory its lookup takes.
        if rows.saturating_mul(cols) > MAX_CANVAS_PIXELS {
            return Err(Error::ImageSize {
                rows,
                cols,
                why: "the stitched maps span too many pixels: placements far apart?",
            });
        }
        self.rows = rows;
        self.cols = cols;
        self.corner = Point2::new(lo.x, hi.y);
        self.lookup.clear();
        self.lookup.resize(rows * cols, (0, 0));
        // Links are visited last to first: the earliest covering link wins.
        for (k, p) in placements.iter().enumerate().rev() {
            self.look_up_link(k, p);
        }
        // Bridge triangles, where no map shows.
        self.bridge_pixels.clear();
        for tri in bridges {
            self.fill_bridge(tri, placements)?;
        }
        for &(i, _, _) in &self.bridge_pixels {
            self.lookup[i as usize] = (0, 0);
        }
        Ok(())
    }

    /// The canvas pixels that link `k`, placed by `p`, shows: each takes the link pixel under it.
    fn look_up_link(&mut self, k: usize, p: &Placement) {
        let cols = self.cols;
        let r = &self.links[k];
        // Row 0 is the top (largest y), as in the link rasters.
        let origin = r.pixel_centre(0, 0);
        // Only the canvas pixels under this link's placed raster.
        let (blo, bhi) = placed_box(r, p, self.step / 2.0);
        let (row_span, col_span) = self.pixels_over(blo, bhi);
        for row in row_span {
            for col in col_span.clone() {
                let centre = self.pixel_centre(row, col);
                let q = p.invert(&centre);
                let (c, rr) = (
                    ((q.x - origin.x) / self.step).round(),
                    ((origin.y - q.y) / self.step).round(),
                );
                if c < 0.0 || rr < 0.0 || c >= r.cols() as f64 || rr >= r.rows() as f64 {
                    continue;
                }
                let pixel = rr as usize * r.cols() + c as usize;
                if self.covered[k][pixel] {
                    self.lookup[row * cols + col] = (k as u32 + 1, pixel as u32);
                }
            }
        }
    }

    /// The canvas rows and columns whose pixels may overlap the box from `lo` to `hi` (in the
    /// stitched plane), clipped to the canvas. Row 0 is the top (largest y).
    fn pixels_over(&self, lo: Point2<f64>, hi: Point2<f64>) -> (Range<usize>, Range<usize>) {
        let (x0, y1) = (self.corner.x, self.corner.y);
        let index = |v: f64, n: usize| (v.max(0.0) as usize).min(n);
        let c0 = index(((lo.x - x0) / self.step).floor(), self.cols);
        let c1 = index(((hi.x - x0) / self.step).ceil(), self.cols);
        let r0 = index(((y1 - hi.y) / self.step).floor(), self.rows);
        let r1 = index(((y1 - lo.y) / self.step).ceil(), self.rows);
        (r0..r1, c0..c1)
    }

    /// The canvas pixels in bridge triangle `tri` that no map shows, with their barycentric
    /// weights.
    fn fill_bridge(&mut self, tri: &BridgeTriangle, placements: &[Placement]) -> Result<()> {
        let cols = self.cols;
        if tri
            .corners
            .iter()
            .any(|c| c.link >= self.points.len() || c.taxel >= self.points[c.link].len())
        {
            return Err(Error::Chain(ChainError::Bridge(*tri)));
        }
        let v = tri
            .corners
            .map(|c| placements[c.link].apply(&self.points[c.link][c.taxel]));
        let area = (v[1] - v[0]).perp(&(v[2] - v[0]));
        if area.abs() < 1e-12 {
            return Ok(());
        }
        let (tlo, thi) = (v[0].inf(&v[1]).inf(&v[2]), v[0].sup(&v[1]).sup(&v[2]));
        let (row_span, col_span) = self.pixels_over(tlo, thi);
        for row in row_span {
            for col in col_span.clone() {
                let i = row * cols + col;
                if self.lookup[i].0 != 0 {
                    continue;
                }
                let q = self.pixel_centre(row, col);
                // Barycentric weights (eq. 3.2 of the maps, across the joint).
                let w0 = (v[1] - q).perp(&(v[2] - q)) / area;
                let w1 = (v[2] - q).perp(&(v[0] - q)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 >= -1e-9 && w1 >= -1e-9 && w2 >= -1e-9 {
                    let corners = tri.corners.map(|c| (c.link as u32, c.taxel as u32));
                    self.bridge_pixels
                        .push((i as u32, corners, [w0 as f32, w1 as f32, w2 as f32]));
                    self.lookup[i] = (u32::MAX, 0); // taken
                }
            }
        }
        Ok(())
    }

    /// One stitched frame: `pressures[k]` has one value per taxel of map k (map order); `image`
    /// gets `rows() * cols()` values, row-major, 0 where no map is.
    pub fn render(&mut self, pressures: &[&[f32]], image: &mut Vec<f32>) -> Result<()> {
        if pressures.len() != self.links.len() {
            return Err(Error::Length {
                what: "pressure frames for the stitched maps",
                got: pressures.len(),
                expected: self.links.len(),
            });
        }
        for ((r, p), img) in self.links.iter_mut().zip(pressures).zip(&mut self.images) {
            r.render(p, img)?;
        }
        image.clear();
        image.extend(self.lookup.iter().map(|&(k, pixel)| {
            if k == 0 {
                0.0
            } else {
                self.images[k as usize - 1][pixel as usize]
            }
        }));
        for &(i, corners, w) in &self.bridge_pixels {
            image[i as usize] = corners
                .iter()
                .zip(w)
                .map(|(&(l, t), w)| w * pressures[l as usize].get(t as usize).copied().unwrap_or(0.0))
                .sum();
        }
        Ok(())
    }
}

/// The bounding box of link raster `r`'s pixels (centres `half` from their edges), placed by `p`.
fn placed_box(r: &Rasterizer, p: &Placement, half: f64) -> (Point2<f64>, Point2<f64>) {
    let a = r.pixel_centre(0, 0) + Vector2::new(-half, half);
    let b = r.pixel_centre(r.rows() - 1, r.cols() - 1) + Vector2::new(half, -half);
    let mut lo = Point2::new(f64::INFINITY, f64::INFINITY);
    let mut hi = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
    for c in [a, Point2::new(a.x, b.y), Point2::new(b.x, a.y), b] {
        let q = p.apply(&c);
        lo = lo.inf(&q);
        hi = hi.sup(&q);
    }
    (lo, hi)
}
