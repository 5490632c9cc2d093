//! Tactile images: resampling a tactile map on a regular grid (thesis Ch. 3.3, Fig. 3.2b).
//!
//! For a grid point x_rc inside map triangle (m_j, m_k, m_h), the pressure is the barycentric
//! interpolation of the three taxels' pressures:
//!
//!   K_rc = (A_kj p_h + A_hj p_k + A_hk p_j) / A        (thesis Sec. 3.3)
//!
//! where A_kj, A_hj, A_hk are the areas of the sub-triangles opposite each corner and A the
//! triangle's area. Grid points in no triangle have no sensor and read 0.
//!
//! Barycentric interpolation inside a triangle is the plane through its three (corner, pressure)
//! points, so K = alpha c + beta r + gamma in pixel coordinates (r, c), with (alpha, beta, gamma)
//! = M_t (p_j, p_k, p_h) and M_t the inverse of the matrix of the corners' [c r 1]. Everything
//! that depends only on the map is computed once by [`Rasterizer::new`]: which triangle covers
//! each pixel, and M_t. Per frame, [`Rasterizer::render`] computes the three plane coefficients of
//! every triangle (a 3 x 3 product each), then one multiply-add pair per pixel. Streaming a
//! 4-byte triangle index per pixel instead of three indices and three weights (24 bytes) is what
//! makes it fast: the per-pixel table of a 247 x 362 image is 0.35 MB instead of 2.1 MB. Nothing
//! is allocated per frame.

use crate::morphology::Morphology;
use crate::resize::Resizer;
use crate::{Error, Result, TactileMap};
use image::ImageEncoder as _;
use nalgebra::{Point2, Point3};

/// The largest side of a tactile image grid, pixels (4096 x 4096 is 16.7 million pixels, about
/// 300 MB of per-pixel tables).
pub const MAX_SIDE: usize = 4096;

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
        if map.faces.is_empty() {
            return Err(Error::NoTriangle {
                map: map.name.clone(),
            });
        }
        let (lo, hi) = map.bounds();
        let (w, h) = (hi.x - lo.x, hi.y - lo.y);
        let (rows, cols, step) = match grid {
            Grid::StepMm(mm) => {
                if !(mm.is_finite() && mm > 0.0) {
                    return Err(Error::Parameter {
                        name: "grid step (mm)",
                        value: mm,
                        expected: "a positive number of millimetres",
                    });
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
                    return Err(Error::ImageSize {
                        rows,
                        cols,
                        why: "no pixel",
                    });
                }
                (rows, cols, (w / cols as f64).max(h / rows as f64))
            }
        };
        if rows > MAX_SIDE || cols > MAX_SIDE {
            return Err(Error::ImageSize {
                rows,
                cols,
                why: "too large (at most 4096 pixels a side): use a coarser grid step",
            });
        }
        let centre = Point2::new(0.5 * (lo.x + hi.x), 0.5 * (lo.y + hi.y));
        let corner = Point2::new(
            centre.x - 0.5 * cols as f64 * step,
            centre.y + 0.5 * rows as f64 * step,
        );

        // Each pixel takes the first triangle that contains its centre.
        const NONE: u32 = u32::MAX;
        let mut owner = vec![NONE; rows * cols];
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
                    }
                }
            }
        }
        let mut runs = Vec::new();
        let mut faces = Vec::new();
        let mut i = 0;
        while i < owner.len() {
            if owner[i] == NONE {
                i += 1;
                continue;
            }
            let start = i;
            while i < owner.len() && owner[i] != NONE && (i == start || i % cols != 0) {
                faces.push(owner[i]);
                i += 1;
            }
            runs.push(Run {
                start: start as u32,
                len: (i - start) as u32,
                table: (faces.len() - (i - start)) as u32,
            });
        }
        // Number the triangles in the order the raster scan meets them: the per-frame tables then
        // hold only triangles that cover a pixel, and neighbouring pixels read neighbouring
        // coefficients.
        let mut visible: Vec<usize> = Vec::new();
        let mut renumber = vec![NONE; map.faces.len()];
        for f in faces.iter_mut() {
            let old = *f as usize;
            if renumber[old] == NONE {
                renumber[old] = visible.len() as u32;
                visible.push(old);
            }
            *f = renumber[old];
        }
        let to_pixel = |p: Point2<f64>| ((p.x - corner.x) / step - 0.5, (corner.y - p.y) / step - 0.5);
        let planes: Vec<[f32; 9]> = visible
            .iter()
            .map(|&f| {
                let f = map.faces[f];
                let m = nalgebra::Matrix3::from_fn(|i, j| {
                    let (c, r) = to_pixel(map.points[f[i]]);
                    [c, r, 1.0][j]
                });
                // A triangle that covers a pixel has a non-zero area, so the inverse exists.
                let inv = m.try_inverse().unwrap_or_else(nalgebra::Matrix3::zeros);
                let mut a = [0.0f32; 9];
                for (k, v) in a.iter_mut().enumerate() {
                    *v = inv[(k / 3, k % 3)] as f32;
                }
                a
            })
            .collect();
        let corners: Vec<[u32; 3]> = visible.iter().map(|&f| map.faces[f].map(|t| t as u32)).collect();
        // Blind spots: a zeroed taxel's column of every plane matrix (and its pixel weights below)
        // is zero, so its readings never reach the image, at no cost per frame.
        let mut dead = vec![false; map.ids.len()];
        for &z in &map.zeroed {
            if let Some(d) = dead.get_mut(z) {
                *d = true;
            }
        }
        let mut planes = planes;
        for (a, c) in planes.iter_mut().zip(&corners) {
            for (j, &t) in c.iter().enumerate() {
                if dead[t as usize] {
                    a[j] = 0.0;
                    a[3 + j] = 0.0;
                    a[6 + j] = 0.0;
                }
            }
        }
        let visible_faces = visible.clone();
        let weights = (faces.len() < 2 * visible.len()).then(|| {
            let mut taxels = Vec::with_capacity(faces.len());
            let mut w = Vec::with_capacity(faces.len());
            for run in &runs {
                for i in run.start as usize..(run.start + run.len) as usize {
                    let f = map.faces[visible[faces[run.table as usize + i - run.start as usize] as usize]];
                    let p = f.map(|t| map.points[t]);
                    let x = pixel_centre(corner, step, i / cols, i % cols);
                    let area2 = (p[1] - p[0]).perp(&(p[2] - p[0]));
                    let l0 = ((p[2] - p[1]).perp(&(x - p[1])) / area2).clamp(0.0, 1.0);
                    let l1 = ((p[0] - p[2]).perp(&(x - p[2])) / area2).clamp(0.0, 1.0 - l0);
                    taxels.push(f.map(|t| t as u32));
                    let mut weights = [l0 as f32, l1 as f32, (1.0 - l0 - l1) as f32];
                    for (wk, &t) in weights.iter_mut().zip(&f) {
                        if dead[t] {
                            *wk = 0.0;
                        }
                    }
                    w.push(weights);
                }
            }
            PixelWeights { taxels, weights: w }
        });
        let mut used: Vec<u32> = map.faces.iter().flatten().map(|&t| t as u32).collect();
        used.sort_unstable();
        used.dedup();
        used.retain(|&t| !dead[t as usize]);
        Ok(Rasterizer {
            rows,
            cols,
            step,
            corner,
            n_taxels: map.ids.len(),
            runs,
            faces,
            planes,
            corners,
            used,
            coefs: vec![[0.0; 4]; visible_faces.len()],
            weights,
            columns: (0..cols).map(|c| c as f32).collect(),
            map_faces: visible_faces.iter().map(|&f| map.faces[f]).collect(),
            map_face_ids: visible_faces,
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

    /// Interpolates one frame: `pressures` has one value per taxel in map order, `image` one value
    /// per pixel, row-major. Pixels outside the map get 0. Allocates nothing.
    pub fn render(&mut self, pressures: &[f32], image: &mut [f32]) -> Result<()> {
        self.check(pressures, image.len())?;
        if self.weights.is_none() {
            self.planes_for(pressures);
        }
        let mut next = 0usize;
        for run in &self.runs {
            let (start, len, table) = (run.start as usize, run.len as usize, run.table as usize);
            image[next..start].fill(0.0);
            let out = &mut image[start..start + len];
            match &self.weights {
                Some(PixelWeights { taxels, weights }) => {
                    let cells = taxels[table..table + len]
                        .iter()
                        .zip(&weights[table..table + len]);
                    for (o, (t, w)) in out.iter_mut().zip(cells) {
                        *o = w[0] * pressures[t[0] as usize]
                            + w[1] * pressures[t[1] as usize]
                            + w[2] * pressures[t[2] as usize];
                    }
                }
                None => {
                    let (row, col) = ((start / self.cols) as f32, start % self.cols);
                    for ((c, o), &t) in (col..).zip(out.iter_mut()).zip(&self.faces[table..table + len]) {
                        let [alpha, beta, gamma, _] = self.coefs[t as usize];
                        *o = alpha * c as f32 + (beta * row + gamma);
                    }
                }
            }
            next = start + len;
        }
        image[next..].fill(0.0);
        Ok(())
    }

    /// [`Self::render`] and the grey image (thesis eq. 3.1). With [`Normalisation::ContactMax`],
    /// K_bar is the largest reading among the map's taxels: the peak of the contact, which the
    /// interpolated image reaches only where a pixel centre falls on that taxel.
    pub fn render_grey(
        &mut self,
        pressures: &[f32],
        norm: Normalisation,
        image: &mut [f32],
        grey: &mut [u8],
    ) -> Result<()> {
        if grey.len() != image.len() {
            return Err(Error::Length {
                what: "pixels of the grey buffer for the image",
                got: grey.len(),
                expected: image.len(),
            });
        }
        self.check(pressures, image.len())?;
        let k_bar = match norm {
            Normalisation::FullScale(k) => k,
            Normalisation::ContactMax => self
                .used
                .iter()
                .map(|&t| pressures[t as usize])
                .fold(0.0f32, f32::max),
        };
        if self.weights.is_some() {
            self.render(pressures, image)?;
            let mut next = 0usize;
            for run in &self.runs {
                let (start, len) = (run.start as usize, run.len as usize);
                grey[next..start].fill(0);
                quantise(&image[start..start + len], k_bar, &mut grey[start..start + len]);
                next = start + len;
            }
            grey[next..].fill(0);
            return Ok(());
        }
        // Plane mode, fused: each run is interpolated and quantised in one pass, eight pixels at a
        // time, while its values are still in registers.
        self.planes_for(pressures);
        let gain = if k_bar > 0.0 { 255.0 / k_bar } else { 0.0 };
        let mut next = 0usize;
        for run in &self.runs {
            let (start, len, table) = (run.start as usize, run.len as usize, run.table as usize);
            image[next..start].fill(0.0);
            grey[next..start].fill(0);
            let (row, col) = ((start / self.cols) as f32, start % self.cols);
            let faces = &self.faces[table..table + len];
            let (out, levels) = (&mut image[start..start + len], &mut grey[start..start + len]);
            let columns = &self.columns[col..col + len];
            planes_to_grey(&self.coefs, faces, row, columns, gain, out, levels);
            next = start + len;
        }
        image[next..].fill(0.0);
        grey[next..].fill(0);
        Ok(())
    }

    fn check(&self, pressures: &[f32], image_len: usize) -> Result<()> {
        if pressures.len() != self.n_taxels {
            return Err(Error::Length {
                what: "values of the frame for the map's taxels",
                got: pressures.len(),
                expected: self.n_taxels,
            });
        }
        if image_len != self.len() {
            return Err(Error::Length {
                what: "pixels of the image buffer for the grid",
                got: image_len,
                expected: self.rows * self.cols,
            });
        }
        Ok(())
    }

    /// The plane coefficients (alpha, beta, gamma) of every triangle for this frame.
    fn planes_for(&mut self, pressures: &[f32]) {
        for ((c, m), t) in self.coefs.iter_mut().zip(&self.planes).zip(&self.corners) {
            let p = [
                pressures[t[0] as usize],
                pressures[t[1] as usize],
                pressures[t[2] as usize],
            ];
            *c = [
                m[0] * p[0] + m[1] * p[1] + m[2] * p[2],
                m[3] * p[0] + m[4] * p[1] + m[5] * p[2],
                m[6] * p[0] + m[7] * p[1] + m[8] * p[2],
                0.0,
            ];
        }
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

/// K = alpha c + beta r + gamma for a run of pixels of row `row` at columns `columns`, and its
/// grey levels (see [`quantise`]), eight pixels at a time.
fn planes_to_grey(
    coefs: &[[f32; 4]],
    faces: &[u32],
    row: f32,
    columns: &[f32],
    gain: f32,
    image: &mut [f32],
    grey: &mut [u8],
) {
    use wide::f32x8;
    let (zero, top, gain8) = (f32x8::splat(0.0), f32x8::splat(255.0), f32x8::splat(gain));
    let n = image.len() / 8 * 8;
    for i in (0..n).step_by(8) {
        let (mut a, mut b, mut c) = ([0.0f32; 8], [0.0f32; 8], [0.0f32; 8]);
        for j in 0..8 {
            let [alpha, beta, gamma, _] = coefs[faces[i + j] as usize];
            a[j] = alpha;
            b[j] = beta * row + gamma;
            c[j] = columns[i + j];
        }
        let v = f32x8::new(a) * f32x8::new(c) + f32x8::new(b);
        image[i..i + 8].copy_from_slice(&v.to_array());
        let g = (v * gain8)
            .fast_max(zero)
            .fast_min(top)
            .fast_trunc_int()
            .to_array();
        for (o, &x) in grey[i..i + 8].iter_mut().zip(&g) {
            *o = x as u8;
        }
    }
    for i in n..image.len() {
        let [alpha, beta, gamma, _] = coefs[faces[i] as usize];
        let v = alpha * columns[i] + (beta * row + gamma);
        image[i] = v;
        grey[i] = (v * gain) as u8;
    }
}

/// Grey levels floor(255 K / K_bar) clamped to 0..=255 (thesis eq. 3.1), eight pixels at a time;
/// all black when K_bar is not positive. The float-to-integer step is what the compiler cannot
/// vectorise on its own (Rust's `as` saturates and maps NaN to 0, which takes scalar code):
/// `wide` truncates eight lanes in one instruction once the values are clamped (NaN included) to
/// 0..=255, so the result is the same.
fn quantise(k: &[f32], k_bar: f32, grey: &mut [u8]) {
    use wide::f32x8;
    if !(k_bar > 0.0) {
        grey.fill(0);
        return;
    }
    let gain = 255.0 / k_bar;
    let (zero, top, gain8) = (f32x8::splat(0.0), f32x8::splat(255.0), f32x8::splat(gain));
    let mut chunks = k.chunks_exact(8);
    let mut out = grey.chunks_exact_mut(8);
    for (c, o) in (&mut chunks).zip(&mut out) {
        let mut a = [0.0f32; 8];
        a.copy_from_slice(c);
        let g = (f32x8::new(a) * gain8)
            .fast_max(zero)
            .fast_min(top)
            .fast_trunc_int()
            .to_array();
        for (o, &x) in o.iter_mut().zip(&g) {
            *o = x as u8;
        }
    }
    for (o, &v) in out.into_remainder().iter_mut().zip(chunks.remainder()) {
        *o = (v * gain) as u8;
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
    let n = pressure.len().min(grey.len());
    quantise(&pressure[..n], k_bar, &mut grey[..n]);
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

    /// The image a hand classifier or segmenter reads (thesis Ch. 4.5, App. C): `map` on a grid
    /// of `step_mm` millimetres (1 for the shipped models), grey by the contact's own maximum,
    /// eroded then dilated, resized to `size` (rows, cols; 68 x 100 for HandsNet).
    pub fn for_model(map: &TactileMap, step_mm: f64, size: (usize, usize)) -> Result<Self> {
        TactileImager::new(
            Rasterizer::new(map, Grid::StepMm(step_mm))?,
            Normalisation::ContactMax,
            true,
            Some(size),
        )
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
        self.raster
            .render_grey(pressures, self.norm, &mut self.pressure, &mut self.grey)?;
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

    /// The grey image [`Self::process`] last returned (black before the first frame).
    pub fn last_output(&self) -> &[u8] {
        if self.resizer.is_some() {
            &self.resized
        } else {
            &self.grey
        }
    }

    /// The pressure image K of the last processed frame (real pressures, before grey conversion).
    pub fn pressure_image(&self) -> &[f32] {
        &self.pressure
    }
}

/// Encodes a row-major 8-bit grey image of `rows x cols` pixels as PNG.
pub fn encode_png(grey: &[u8], rows: usize, cols: usize) -> Result<Vec<u8>> {
    let bad = || Error::Length {
        what: "grey values for the image's pixels",
        got: grey.len(),
        expected: rows.saturating_mul(cols),
    };
    if grey.len() != rows * cols {
        return Err(bad());
    }
    let (w, h) = (
        u32::try_from(cols).map_err(|_| bad())?,
        u32::try_from(rows).map_err(|_| bad())?,
    );
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(grey, w, h, image::ExtendedColorType::L8)
        .map_err(|e| Error::Output {
            path: "PNG".into(),
            message: e.to_string(),
        })?;
    Ok(png)
}

/// Writes a row-major 8-bit grey image of `rows x cols` pixels as a PNG file.
pub fn write_png(path: &std::path::Path, grey: &[u8], rows: usize, cols: usize) -> Result<()> {
    std::fs::write(path, encode_png(grey, rows, cols)?).map_err(|e| Error::Output {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}
