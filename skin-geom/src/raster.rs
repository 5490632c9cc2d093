//! Tactile images: resampling a tactile map on a regular grid (thesis Ch. 3.3, Fig. 3.2b).
//!
//! For a grid point x_rc inside map triangle (m_j, m_k, m_h), the pressure is the barycentric
//! interpolation of the three taxels' pressures:
//!
//!   K_rc = (A_kj p_h + A_hj p_k + A_hk p_j) / A        (thesis Sec. 3.3)
//!
//! where A_kj, A_hj, A_hk are the areas of the sub-triangles opposite each corner and A the
//! triangle's area. Grid points in no triangle have no sensor and read 0. Everything but the
//! weighted sum depends only on the map, so [`Rasterizer::new`] computes, once, each pixel's three
//! taxels and weights; [`Rasterizer::render`] is then a gather and two multiply-adds per pixel,
//! with no allocation.

use crate::morphology::Morphology;
use crate::resize::Resizer;
use crate::{Error, Result, TactileMap};
use nalgebra::{Point2, Point3};

/// The grid laid on a tactile map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Grid {
    /// Square pixels of this side, millimetres (the thesis uses 1 mm); the grid covers the map.
    StepMm(f64),
    /// This many rows and columns; square pixels as large as needed to cover the map.
    Size {
        /// Rows (image height).
        rows: usize,
        /// Columns (image width).
        cols: usize,
    },
}

impl Default for Grid {
    fn default() -> Self {
        Grid::StepMm(1.0)
    }
}

/// A run of consecutive covered pixels in raster order.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Run {
    /// First pixel (row-major index).
    start: u32,
    /// Number of pixels.
    len: u32,
    /// Offset of the run's first pixel in the weight tables.
    table: u32,
}

/// The precomputed resampling of one tactile map on one grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Rasterizer {
    rows: usize,
    cols: usize,
    /// Pixel side, metres.
    step: f64,
    /// Map coordinates of the top-left corner of pixel (0, 0).
    corner: Point2<f64>,
    n_taxels: usize,
    runs: Vec<Run>,
    taxels: Vec<[u32; 3]>,
    weights: Vec<[f32; 3]>,
    faces: Vec<u32>,
    map_faces: Vec<[usize; 3]>,
    points: Vec<Point2<f64>>,
    positions: Vec<Point3<f64>>,
}

/// Where a pixel comes from on the skin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackProjection {
    /// The map triangle the pixel centre falls in.
    pub face: usize,
    /// Its three taxels (layout indices).
    pub taxels: [usize; 3],
    /// Barycentric weight of each taxel (they sum to 1).
    pub weights: [f64; 3],
    /// The corresponding point on the 3D mesh, metres in the link frame (`None` when the map was
    /// read without 3D positions).
    pub point: Option<Point3<f64>>,
}

impl Rasterizer {
    /// Lays `grid` on `map` (centred on its bounding box) and precomputes every pixel.
    pub fn new(map: &TactileMap, grid: Grid) -> Result<Rasterizer> {
        if map.faces.is_empty() {
            return Err(Error::Mismatch(format!(
                "tactile map \"{}\" has no triangle",
                map.name
            )));
        }
        let (lo, hi) = map.bounds();
        let (w, h) = (hi.x - lo.x, hi.y - lo.y);
        let (rows, cols, step) = match grid {
            Grid::StepMm(mm) => {
                if !(mm.is_finite() && mm > 0.0) {
                    return Err(Error::Mismatch(format!(
                        "grid step must be a positive number of millimetres, got {mm}"
                    )));
                }
                let s = mm * 1e-3;
                (
                    ((h / s).ceil() as usize).max(1),
                    ((w / s).ceil() as usize).max(1),
                    s,
                )
            }
            Grid::Size { rows, cols } => {
                if rows == 0 || cols == 0 {
                    return Err(Error::Mismatch(format!(
                        "image size {rows} x {cols} has no pixel"
                    )));
                }
                (rows, cols, (w / cols as f64).max(h / rows as f64))
            }
        };
        if rows.saturating_mul(cols) > 50_000_000 {
            return Err(Error::Mismatch(format!(
                "a {rows} x {cols} image is too large: use a coarser grid step"
            )));
        }
        let centre = Point2::new(0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
        let corner = Point2::new(
            centre.x - 0.5 * cols as f64 * step,
            centre.y + 0.5 * rows as f64 * step,
        );

        // Each pixel takes the first triangle that contains its centre.
        const NONE: u32 = u32::MAX;
        let mut owner = vec![NONE; rows * cols];
        let mut bary = vec![[0.0f64; 3]; rows * cols];
        for (f, face) in map.faces.iter().enumerate() {
            let p = face.map(|t| map.points[t]);
            let area2 = (p[1] - p[0]).perp(&(p[2] - p[0]));
            if area2.abs() <= f64::EPSILON * (w * h).max(f64::MIN_POSITIVE) {
                continue;
            }
            let (min_u, max_u) = (p[0].x.min(p[1].x).min(p[2].x), p[0].x.max(p[1].x).max(p[2].x));
            let (min_v, max_v) = (p[0].y.min(p[1].y).min(p[2].y), p[0].y.max(p[1].y).max(p[2].y));
            let c0 = (((min_u - corner.x) / step - 0.5).floor().max(0.0)) as usize;
            let c1 = (((max_u - corner.x) / step - 0.5).ceil().max(0.0) as usize).min(cols - 1);
            let r0 = (((corner.y - max_v) / step - 0.5).floor().max(0.0)) as usize;
            let r1 = (((corner.y - min_v) / step - 0.5).ceil().max(0.0) as usize).min(rows - 1);
            for r in r0..=r1 {
                for c in c0..=c1 {
                    let i = r * cols + c;
                    if owner[i] != NONE {
                        continue;
                    }
                    let x = pixel_centre(corner, step, r, c);
                    // Sub-triangle areas opposite each corner, over the whole area.
                    let l0 = (p[2] - p[1]).perp(&(x - p[1])) / area2;
                    let l1 = (p[0] - p[2]).perp(&(x - p[2])) / area2;
                    let l2 = 1.0 - l0 - l1;
                    let tol = -1e-9;
                    if l0 >= tol && l1 >= tol && l2 >= tol {
                        owner[i] = f as u32;
                        bary[i] = [l0.max(0.0), l1.max(0.0), l2.max(0.0)];
                    }
                }
            }
        }
        let mut runs = Vec::new();
        let mut taxels = Vec::new();
        let mut weights = Vec::new();
        let mut faces = Vec::new();
        let mut i = 0;
        while i < owner.len() {
            if owner[i] == NONE {
                i += 1;
                continue;
            }
            let start = i;
            while i < owner.len() && owner[i] != NONE && (i == start || i % cols != 0) {
                let f = owner[i] as usize;
                let b = bary[i];
                let s = b[0] + b[1] + b[2];
                taxels.push(map.faces[f].map(|t| t as u32));
                weights.push([(b[0] / s) as f32, (b[1] / s) as f32, (b[2] / s) as f32]);
                faces.push(f as u32);
                i += 1;
            }
            runs.push(Run {
                start: start as u32,
                len: (i - start) as u32,
                table: (taxels.len() - (i - start)) as u32,
            });
        }
        Ok(Rasterizer {
            rows,
            cols,
            step,
            corner,
            n_taxels: map.ids.len(),
            runs,
            taxels,
            weights,
            faces,
            map_faces: map.faces.clone(),
            points: map.points.clone(),
            positions: map.positions.clone(),
        })
    }

    /// Image height in pixels.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Image width in pixels.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Number of pixels (`rows * cols`).
    pub fn len(&self) -> usize {
        self.rows * self.cols
    }

    /// Whether the image has no pixel (never true for a built rasterizer).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Pixel side, metres.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// Number of pixels inside the map.
    pub fn covered(&self) -> usize {
        self.taxels.len()
    }

    /// Number of taxels a frame must have.
    pub fn taxel_count(&self) -> usize {
        self.n_taxels
    }

    /// Map coordinates (metres) of the centre of pixel (`row`, `col`); row 0 is the top of the map.
    pub fn pixel_centre(&self, row: usize, col: usize) -> Point2<f64> {
        pixel_centre(self.corner, self.step, row, col)
    }

    /// Interpolates one frame: `pressures` has one value per taxel in map order, `image` one value
    /// per pixel, row-major. Pixels outside the map get 0. Allocates nothing.
    pub fn render(&self, pressures: &[f32], image: &mut [f32]) -> Result<()> {
        if pressures.len() != self.n_taxels {
            return Err(Error::Mismatch(format!(
                "frame has {} values but the map has {} taxels",
                pressures.len(),
                self.n_taxels
            )));
        }
        if image.len() != self.len() {
            return Err(Error::Mismatch(format!(
                "image buffer has {} pixels, the grid {} x {} = {}",
                image.len(),
                self.rows,
                self.cols,
                self.len()
            )));
        }
        let mut next = 0usize;
        for run in &self.runs {
            let (start, len, table) = (run.start as usize, run.len as usize, run.table as usize);
            image[next..start].fill(0.0);
            let out = &mut image[start..start + len];
            let idx = &self.taxels[table..table + len];
            let w = &self.weights[table..table + len];
            for ((o, t), w) in out.iter_mut().zip(idx).zip(w) {
                // Indices were checked against the taxel count when the tables were built.
                *o = w[0] * pressures[t[0] as usize]
                    + w[1] * pressures[t[1] as usize]
                    + w[2] * pressures[t[2] as usize];
            }
            next = start + len;
        }
        image[next..].fill(0.0);
        Ok(())
    }

    /// Where pixel (`row`, `col`) comes from: its triangle, taxels and weights, and the 3D point
    /// on the mesh. `None` for a pixel outside the map or the grid.
    pub fn back_project(&self, row: usize, col: usize) -> Option<BackProjection> {
        if row >= self.rows || col >= self.cols {
            return None;
        }
        let i = (row * self.cols + col) as u32;
        let k = self.runs.partition_point(|r| r.start + r.len <= i);
        let run = self.runs.get(k)?;
        if i < run.start {
            return None;
        }
        let t = (run.table + (i - run.start)) as usize;
        let face = self.faces[t] as usize;
        let taxels = self.map_faces[face];
        // Recomputed in f64 (the per-frame tables hold f32) so the 3D point is on the triangle.
        let p = taxels.map(|k| self.points[k]);
        let x = self.pixel_centre(row, col);
        let area2 = (p[1] - p[0]).perp(&(p[2] - p[0]));
        let w0 = ((p[2] - p[1]).perp(&(x - p[1])) / area2).clamp(0.0, 1.0);
        let w1 = ((p[0] - p[2]).perp(&(x - p[2])) / area2).clamp(0.0, 1.0 - w0);
        let w = [w0, w1, 1.0 - w0 - w1];
        let point = (!self.positions.is_empty()).then(|| {
            Point3::from(
                self.positions[taxels[0]].coords * w[0]
                    + self.positions[taxels[1]].coords * w[1]
                    + self.positions[taxels[2]].coords * w[2],
            )
        });
        Some(BackProjection {
            face,
            taxels,
            weights: w,
            point,
        })
    }
}

fn pixel_centre(corner: Point2<f64>, step: f64, row: usize, col: usize) -> Point2<f64> {
    Point2::new(
        corner.x + (col as f64 + 0.5) * step,
        corner.y - (row as f64 + 0.5) * step,
    )
}

/// The pressure K_bar that maps to grey level 255 (thesis eq. 3.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Normalisation {
    /// The sensor's full scale, in the frame's units: images of different touches compare.
    FullScale(f32),
    /// The largest pressure in the current image: the contact's shape at full contrast
    /// (thesis Ch. 4.2, for classification).
    ContactMax,
}

/// Grey levels from pressures: I = floor(255 K / K_bar), clamped to 0..=255 (thesis eq. 3.1).
/// With [`Normalisation::ContactMax`] and no positive pressure, the image is black.
pub fn to_grey(pressure: &[f32], norm: Normalisation, grey: &mut [u8]) {
    let k_bar = match norm {
        Normalisation::FullScale(k) => k,
        Normalisation::ContactMax => pressure.iter().copied().fold(0.0f32, f32::max),
    };
    if !(k_bar > 0.0) {
        grey.fill(0);
        return;
    }
    let gain = 255.0 / k_bar;
    for (g, &k) in grey.iter_mut().zip(pressure) {
        // `as u8` saturates (and maps NaN to 0), which is the clamp eq. 3.1 needs.
        *g = (k * gain).floor() as u8;
    }
}

/// The whole per-frame image path of one link, with its buffers: interpolate, convert to grey,
/// optionally erode (disk r = 2) then dilate (disk r = 4) (thesis Ch. 4.5), optionally resize
/// (68 x 100 for the hand classifier, App. C). [`TactileImager::process`] allocates nothing.
#[derive(Debug, Clone)]
pub struct TactileImager {
    raster: Rasterizer,
    norm: Normalisation,
    morphology: Option<Morphology>,
    resizer: Option<Resizer>,
    pressure: Vec<f32>,
    grey: Vec<u8>,
    morphed: Vec<u8>,
    resized: Vec<u8>,
}

impl TactileImager {
    /// Erosion radius before dilation, pixels (thesis Ch. 4.5).
    pub const EROSION_RADIUS: usize = 2;
    /// Dilation radius, pixels (thesis Ch. 4.5).
    pub const DILATION_RADIUS: usize = 4;

    /// An imager for `raster`, with grey normalisation `norm`, optional erosion/dilation, and an
    /// optional output size (rows, cols).
    pub fn new(
        raster: Rasterizer,
        norm: Normalisation,
        morphology: bool,
        size: Option<(usize, usize)>,
    ) -> Result<Self> {
        let (rows, cols) = (raster.rows(), raster.cols());
        let resizer = match size {
            Some((r, c)) if (r, c) != (rows, cols) => Some(Resizer::new(rows, cols, r, c)?),
            _ => None,
        };
        let out_len = size.map_or(rows * cols, |(r, c)| r * c);
        Ok(TactileImager {
            morphology: morphology.then(|| Morphology::new(rows, cols, Self::DILATION_RADIUS)),
            pressure: vec![0.0; rows * cols],
            grey: vec![0; rows * cols],
            morphed: vec![0; rows * cols],
            resized: vec![0; out_len],
            raster,
            norm,
            resizer,
        })
    }

    /// The rasterizer.
    pub fn raster(&self) -> &Rasterizer {
        &self.raster
    }

    /// Output image size (rows, cols).
    pub fn output_size(&self) -> (usize, usize) {
        match &self.resizer {
            Some(r) => r.output_size(),
            None => (self.raster.rows(), self.raster.cols()),
        }
    }

    /// Processes one frame and returns the grey image, row-major, of [`Self::output_size`].
    pub fn process(&mut self, pressures: &[f32]) -> Result<&[u8]> {
        self.raster.render(pressures, &mut self.pressure)?;
        to_grey(&self.pressure, self.norm, &mut self.grey);
        if let Some(m) = &mut self.morphology {
            m.erode(&self.grey, Self::EROSION_RADIUS, &mut self.morphed);
            m.dilate(&self.morphed, Self::DILATION_RADIUS, &mut self.grey);
        }
        let current: &[u8] = &self.grey;
        match &mut self.resizer {
            Some(r) => {
                r.resize(current, &mut self.resized);
                Ok(&self.resized)
            }
            None => Ok(current),
        }
    }

    /// The pressure image K of the last processed frame (real pressures, before grey conversion).
    pub fn pressure_image(&self) -> &[f32] {
        &self.pressure
    }
}
