//! Resizing grey images with precomputed separable weights.
//!
//! A triangle (linear) filter whose support widens with the shrink factor, so that shrinking
//! averages every source pixel instead of skipping some (the same kernel as the `image` crate's
//! `FilterType::Triangle`). Weights are computed once per size pair; [`Resizer::resize`] allocates
//! nothing.

use crate::{Error, Result};
use skin_core::image::ImageSize;

/// Taps of one output coordinate: the first source index and its weights.
#[derive(Debug, Clone, PartialEq)]
struct Taps {
    start: Vec<usize>,
    offsets: Vec<usize>,
    weights: Vec<f32>,
}

impl Taps {
    fn new(src: usize, dst: usize) -> Taps {
        let scale = src as f64 / dst as f64;
        let support = scale.max(1.0);
        let mut t = Taps {
            start: Vec::with_capacity(dst),
            offsets: vec![0],
            weights: Vec::new(),
        };
        for o in 0..dst {
            let centre = (o as f64 + 0.5) * scale;
            let lo = ((centre - support).floor().max(0.0)) as usize;
            let hi = ((centre + support).ceil() as usize).min(src);
            let mut ws: Vec<f64> = (lo..hi)
                .map(|x| (1.0 - ((x as f64 + 0.5) - centre).abs() / support).max(0.0))
                .collect();
            let sum: f64 = ws.iter().sum();
            if sum > 0.0 {
                ws.iter_mut().for_each(|w| *w /= sum);
            }
            t.start.push(lo);
            t.weights.extend(ws.iter().map(|&w| w as f32));
            t.offsets.push(t.weights.len());
        }
        t
    }

    fn apply(&self, o: usize) -> (usize, &[f32]) {
        (self.start[o], &self.weights[self.offsets[o]..self.offsets[o + 1]])
    }
}

/// A precomputed resize from one image size to another (grey, row-major).
#[derive(Debug, Clone, PartialEq)]
pub struct Resizer {
    src: (usize, usize),
    dst: (usize, usize),
    horizontal: Taps,
    vertical: Taps,
    /// Source rows resized horizontally: src rows x dst cols.
    tmp: Vec<f32>,
    /// One output row being accumulated.
    row: Vec<f32>,
}

impl Resizer {
    /// A resize from `src_rows x src_cols` to `dst_rows x dst_cols`.
    pub fn new(src_rows: usize, src_cols: usize, dst_rows: usize, dst_cols: usize) -> Result<Resizer> {
        if src_rows == 0 || src_cols == 0 || dst_rows == 0 || dst_cols == 0 {
            let (rows, cols) = if src_rows == 0 || src_cols == 0 {
                (src_rows, src_cols)
            } else {
                (dst_rows, dst_cols)
            };
            return Err(Error::ImageSize {
                rows,
                cols,
                why: "no pixel to resize from or to",
            });
        }
        Ok(Resizer {
            src: (src_rows, src_cols),
            dst: (dst_rows, dst_cols),
            horizontal: Taps::new(src_cols, dst_cols),
            vertical: Taps::new(src_rows, dst_rows),
            tmp: vec![0.0; src_rows * dst_cols],
            row: vec![0.0; dst_cols],
        })
    }

    /// Output size.
    pub fn output_size(&self) -> ImageSize {
        ImageSize {
            rows: self.dst.0,
            cols: self.dst.1,
        }
    }

    /// Resizes `src` (input size) into `dst` (output size). The lengths are checked: a buffer of
    /// the wrong size leaves `dst` untouched.
    pub fn resize(&mut self, src: &[u8], dst: &mut [u8]) {
        let ((sr, sc), (dr, dc)) = (self.src, self.dst);
        if src.len() != sr * sc || dst.len() != dr * dc {
            return;
        }
        for y in 0..sr {
            let row = &src[y * sc..(y + 1) * sc];
            for x in 0..dc {
                let (start, w) = self.horizontal.apply(x);
                let acc: f32 = w.iter().zip(&row[start..]).map(|(w, &p)| w * f32::from(p)).sum();
                self.tmp[y * dc + x] = acc;
            }
        }
        for y in 0..dr {
            let (start, w) = self.vertical.apply(y);
            let acc = &mut self.row[..];
            acc.fill(0.0);
            for (k, &wk) in w.iter().enumerate() {
                let src_row = &self.tmp[(start + k) * dc..(start + k + 1) * dc];
                for (a, &v) in acc.iter_mut().zip(src_row) {
                    *a += wk * v;
                }
            }
            for (o, &a) in dst[y * dc..(y + 1) * dc].iter_mut().zip(acc.iter()) {
                *o = (a + 0.5).clamp(0.0, 255.0) as u8;
            }
        }
    }
}
