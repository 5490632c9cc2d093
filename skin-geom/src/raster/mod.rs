//! Tactile images: resampling a tactile map on a regular grid (thesis Ch. 3.3).

mod build;
mod grey;
mod render;

pub use grey::{NormKind, Normalisation, UnknownNorm, to_grey};

use crate::Result;
use crate::tactile_map::TactileMap;
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
///
/// Tactile images: resampling a tactile map on a regular grid (thesis Ch. 3.3, Fig. 3.2b).
///
/// For a grid point x_rc inside map triangle (m_j, m_k, m_h), the pressure is the barycentric
/// interpolation of the three taxels' pressures:
///
///   K_rc = (A_kj p_h + A_hj p_k + A_hk p_j) / A        (thesis Sec. 3.3)
///
/// where A_kj, A_hj, A_hk are the areas of the sub-triangles opposite each corner and A the
/// triangle's area. Grid points in no triangle have no sensor and read 0.
///
/// Barycentric interpolation inside a triangle is the plane through its three (corner, pressure)
/// points, so K = alpha c + beta r + gamma in pixel coordinates (r, c), with (alpha, beta, gamma)
/// = M_t (p_j, p_k, p_h) and M_t the inverse of the matrix of the corners' [c r 1]. Everything
/// that depends only on the map is computed once by [`Rasterizer::new`]: which triangle covers
/// each pixel, and M_t. Per frame, [`Rasterizer::render`] computes the three plane coefficients of
/// every triangle (a 3 x 3 product each), then one multiply-add pair per pixel. Streaming a
/// 4-byte triangle index per pixel instead of three indices and three weights (24 bytes) is what
/// makes it fast: the per-pixel table of a 247 x 362 image is 0.35 MB instead of 2.1 MB. Nothing
/// is allocated per frame.
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
    /// Triangle covering each covered pixel, in raster order.
    faces: Vec<u32>,
    /// Per triangle, M_t (row-major 3 x 3) and its three taxels.
    planes: Vec<[f32; 9]>,
    corners: Vec<[u32; 3]>,
    /// Taxels used by at least one triangle (their largest reading is the contact maximum).
    used: Vec<u32>,
    /// Per frame: (alpha, beta, gamma, unused) of each triangle.
    coefs: Vec<[f32; 4]>,
    /// When the grid has fewer pixels than about twice the triangles it shows (a coarse grid such
    /// as 68 x 100 on a 3,500-taxel map), computing every triangle's plane costs more than
    /// interpolating each pixel directly: then each covered pixel keeps its three taxels and
    /// barycentric weights instead.
    weights: Option<PixelWeights>,
    /// 0, 1, 2, ... as f32, one per column: loading column numbers is cheaper than converting them.
    columns: Vec<f32>,
    /// Taxels of each visible triangle, and its index in the map.
    map_faces: Vec<[usize; 3]>,
    map_face_ids: Vec<usize>,
    points: Vec<Point2<f64>>,
    positions: Vec<Point3<f64>>,
}

/// Per covered pixel (in table order), its three taxels and barycentric weights.
#[derive(Debug, Clone, PartialEq)]
struct PixelWeights {
    taxels: Vec<[u32; 3]>,
    weights: Vec<[f32; 3]>,
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
        build::build(map, grid)
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
        self.faces.len()
    }

    /// Number of taxels a frame must have.
    pub fn taxel_count(&self) -> usize {
        self.n_taxels
    }

    /// Map coordinates (metres) of the centre of pixel (`row`, `col`); row 0 is the top of the map.
    pub fn pixel_centre(&self, row: usize, col: usize) -> Point2<f64> {
        pixel_centre(self.corner, self.step, row, col)
    }

    /// The pixel (`row`, `col`) containing map point `p` (metres), if it is on the grid.
    pub fn pixel_of(&self, p: Point2<f64>) -> Option<(usize, usize)> {
        let col = (p.x - self.corner.x) / self.step;
        let row = (self.corner.y - p.y) / self.step;
        (col >= 0.0 && row >= 0.0 && (col as usize) < self.cols && (row as usize) < self.rows)
            .then_some((row as usize, col as usize))
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
        let visible = self.faces[(run.table + (i - run.start)) as usize] as usize;
        let taxels = self.map_faces[visible];
        let face = self.map_face_ids[visible];
        // Recomputed in f64 (the per-frame tables hold f32) so the 3D point is on the triangle.
        let p = taxels.map(|k| self.points[k]);
        let x = self.pixel_centre(row, col);
        let area2 = (p[1] - p[0]).perp(&(p[2] - p[0]));
        let w = clamped_weights(&p, area2, x);
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

/// The barycentric coordinates (l0, l1) of `x` in triangle `p`, whose doubled signed area is
/// `area2`: the sub-triangle areas opposite corners 0 and 1 over the whole (thesis Sec. 3.3); the
/// third is 1 - l0 - l1.
fn barycentric(p: &[Point2<f64>; 3], area2: f64, x: Point2<f64>) -> (f64, f64) {
    (
        (p[2] - p[1]).perp(&(x - p[1])) / area2,
        (p[0] - p[2]).perp(&(x - p[2])) / area2,
    )
}

/// The weights of `x`'s three corners in triangle `p`, clamped onto the triangle: none negative,
/// summing to 1.
fn clamped_weights(p: &[Point2<f64>; 3], area2: f64, x: Point2<f64>) -> [f64; 3] {
    let (l0, l1) = barycentric(p, area2, x);
    let l0 = l0.clamp(0.0, 1.0);
    let l1 = l1.clamp(0.0, 1.0 - l0);
    [l0, l1, 1.0 - l0 - l1]
}

fn pixel_centre(corner: Point2<f64>, step: f64, row: usize, col: usize) -> Point2<f64> {
    Point2::new(
        corner.x + (col as f64 + 0.5) * step,
        corner.y - (row as f64 + 0.5) * step,
    )
}
