//! What [`Rasterizer::new`] computes once per map and grid: the grid's size and place, which
//! triangle covers each pixel, the runs of covered pixels, and per visible triangle the inverse
//! corner matrix M_t (or, on a coarse grid, each pixel's barycentric weights).

use super::{Grid, PixelWeights, Rasterizer, Run, barycentric, clamped_weights, pixel_centre};
use crate::tactile_map::TactileMap;
use crate::{Error, Result};
use nalgebra::Point2;
use skin_core::image::ImageSize;

/// No triangle covers the pixel.
const NONE: u32 = u32::MAX;

/// The grid laid on a map: its size, pixel side (metres) and the map point of the top-left corner
/// of pixel (0, 0).
#[derive(Debug, Clone, Copy)]
struct Layout {
    rows: usize,
    cols: usize,
    step: f64,
    corner: Point2<f64>,
}

/// See [`Rasterizer::new`].
pub(super) fn build(map: &TactileMap, grid: Grid) -> Result<Rasterizer> {
    if map.faces.is_empty() {
        return Err(Error::NoTriangle {
            map: map.name.clone(),
        });
    }
    let at = Layout::new(map, grid)?;
    let owner = at.owners(map);
    let (runs, mut faces) = runs_of(&owner, at.cols);
    let visible = renumber(&mut faces, map.faces.len());
    // Blind spots: a zeroed taxel's column of every plane matrix (and its pixel weights) is zero,
    // so its readings never reach the image, at no cost per frame.
    let mut dead = vec![false; map.ids.len()];
    for &z in &map.zeroed {
        if let Some(d) = dead.get_mut(z) {
            *d = true;
        }
    }
    let corners: Vec<[u32; 3]> = visible.iter().map(|&f| map.faces[f].map(|t| t as u32)).collect();
    let planes = at.planes(map, &visible, &corners, &dead);
    let weights =
        (faces.len() < 2 * visible.len()).then(|| at.pixel_weights(map, &visible, (&runs, &faces), &dead));
    let mut used: Vec<u32> = map.faces.iter().flatten().map(|&t| t as u32).collect();
    used.sort_unstable();
    used.dedup();
    used.retain(|&t| !dead[t as usize]);
    Ok(Rasterizer {
        rows: at.rows,
        cols: at.cols,
        step: at.step,
        corner: at.corner,
        n_taxels: map.ids.len(),
        runs,
        faces,
        planes,
        corners,
        used,
        coefs: vec![[0.0; 4]; visible.len()],
        weights,
        columns: (0..at.cols).map(|c| c as f32).collect(),
        map_faces: visible.iter().map(|&f| map.faces[f]).collect(),
        map_face_ids: visible,
        points: map.points.clone(),
        positions: map.positions.clone(),
    })
}

impl Layout {
    /// `grid` centred on the map's bounding box.
    fn new(map: &TactileMap, grid: Grid) -> Result<Layout> {
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
        // 4096 x 4096 is 16.7 million pixels, about 300 MB of per-pixel tables.
        if rows > ImageSize::MAX_SIDE || cols > ImageSize::MAX_SIDE {
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
        Ok(Layout {
            rows,
            cols,
            step,
            corner,
        })
    }

    fn pixel_centre(&self, row: usize, col: usize) -> Point2<f64> {
        pixel_centre(self.corner, self.step, row, col)
    }

    /// Per pixel, the first triangle that contains its centre (or [`NONE`]).
    fn owners(&self, map: &TactileMap) -> Vec<u32> {
        let (lo, hi) = map.bounds();
        let (w, h) = (hi.x - lo.x, hi.y - lo.y);
        let (rows, cols, step, corner) = (self.rows, self.cols, self.step, self.corner);
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
                    let (l0, l1) = barycentric(&p, area2, self.pixel_centre(r, c));
                    let l2 = 1.0 - l0 - l1;
                    let tol = -1e-9;
                    if l0 >= tol && l1 >= tol && l2 >= tol {
                        owner[i] = f as u32;
                    }
                }
            }
        }
        owner
    }

    /// Per visible triangle, M_t (row-major 3 x 3): the inverse of the matrix of its corners'
    /// [c r 1] in pixel coordinates, with a dead taxel's column zero.
    fn planes(
        &self,
        map: &TactileMap,
        visible: &[usize],
        corners: &[[u32; 3]],
        dead: &[bool],
    ) -> Vec<[f32; 9]> {
        let (corner, step) = (self.corner, self.step);
        let to_pixel = |p: Point2<f64>| ((p.x - corner.x) / step - 0.5, (corner.y - p.y) / step - 0.5);
        let mut planes: Vec<[f32; 9]> = visible
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
        for (a, c) in planes.iter_mut().zip(corners) {
            for (j, &t) in c.iter().enumerate() {
                if dead[t as usize] {
                    a[j] = 0.0;
                    a[3 + j] = 0.0;
                    a[6 + j] = 0.0;
                }
            }
        }
        planes
    }

    /// Per covered pixel (in table order), its three taxels and barycentric weights, a dead
    /// taxel's weight zero.
    fn pixel_weights(
        &self,
        map: &TactileMap,
        visible: &[usize],
        (runs, faces): (&[Run], &[u32]),
        dead: &[bool],
    ) -> PixelWeights {
        let mut taxels = Vec::with_capacity(faces.len());
        let mut w = Vec::with_capacity(faces.len());
        for run in runs {
            for i in run.start as usize..(run.start + run.len) as usize {
                let f = map.faces[visible[faces[run.table as usize + i - run.start as usize] as usize]];
                let p = f.map(|t| map.points[t]);
                let x = self.pixel_centre(i / self.cols, i % self.cols);
                let area2 = (p[1] - p[0]).perp(&(p[2] - p[0]));
                taxels.push(f.map(|t| t as u32));
                let mut weights = clamped_weights(&p, area2, x).map(|l| l as f32);
                for (wk, &t) in weights.iter_mut().zip(&f) {
                    if dead[t] {
                        *wk = 0.0;
                    }
                }
                w.push(weights);
            }
        }
        PixelWeights { taxels, weights: w }
    }
}

/// The runs of consecutive covered pixels in raster order (a run never crosses a row end), and
/// the triangle of each covered pixel.
fn runs_of(owner: &[u32], cols: usize) -> (Vec<Run>, Vec<u32>) {
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
    (runs, faces)
}

/// Numbers the triangles in the order the raster scan meets them, rewriting `faces`: the
/// per-frame tables then hold only triangles that cover a pixel, and neighbouring pixels read
/// neighbouring coefficients. Returns the map index of each visible triangle.
fn renumber(faces: &mut [u32], map_faces: usize) -> Vec<usize> {
    let mut visible: Vec<usize> = Vec::new();
    let mut renumber = vec![NONE; map_faces];
    for f in faces.iter_mut() {
        let old = *f as usize;
        if renumber[old] == NONE {
            renumber[old] = visible.len() as u32;
            visible.push(old);
        }
        *f = renumber[old];
    }
    visible
}
