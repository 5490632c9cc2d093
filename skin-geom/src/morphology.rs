//! Grey-level erosion and dilation with a disk (thesis Ch. 4.5: erosion r = 2, then dilation
//! r = 4, to drop isolated taxel noise and close the gaps between taxels).
//!
//! The disk is {(dx, dy) : dx^2 + dy^2 <= r^2}. Each of its rows is a horizontal span of half-width
//! w(dy) = floor(sqrt(r^2 - dy^2)), so the result is the min (max) over dy of a horizontal running
//! min (max) of width 2 w(dy) + 1 taken on row y + dy. The running min of half-width k is the one
//! of half-width k - 1 combined with the two pixels k away, so all half-widths cost one pass each,
//! and every pass is a plain element-wise min over slices that the compiler vectorises. Pixels
//! outside the image are ignored (as if padded with 255 for erosion, 0 for dilation).

/// Buffers for erosion and dilation of one image size.
#[derive(Debug, Clone)]
pub(crate) struct Morphology {
    rows: usize,
    cols: usize,
    /// Running extremum of half-width k, for k = 0..=max radius.
    spans: Vec<Vec<u8>>,
}

impl Morphology {
    pub(crate) fn new(rows: usize, cols: usize, max_radius: usize) -> Self {
        Morphology {
            rows,
            cols,
            spans: vec![vec![0; rows * cols]; max_radius + 1],
        }
    }

    pub(crate) fn erode(&mut self, src: &[u8], radius: usize, out: &mut [u8]) {
        self.apply(src, radius, out, u8::min);
    }

    pub(crate) fn dilate(&mut self, src: &[u8], radius: usize, out: &mut [u8]) {
        self.apply(src, radius, out, u8::max);
    }

    // Generic over the operation (not a `fn` pointer) so each use is inlined and vectorised.
    fn apply<F: Fn(u8, u8) -> u8 + Copy>(&mut self, src: &[u8], radius: usize, out: &mut [u8], op: F) {
        let (rows, cols) = (self.rows, self.cols);
        if self.spans.len() <= radius {
            self.spans.resize(radius + 1, vec![0; rows * cols]);
        }
        self.spans[0].copy_from_slice(src);
        for k in 1..=radius {
            let (done, rest) = self.spans.split_at_mut(k);
            let prev = &done[k - 1];
            let cur = &mut rest[0];
            cur.copy_from_slice(prev);
            if k >= cols {
                continue; // the span already covers the whole row
            }
            for y in 0..rows {
                let row = y * cols;
                let s = &src[row..row + cols];
                let c = &mut cur[row..row + cols];
                // c[x] = op(c[x], s[x + k]) for x + k < cols; c[x] = op(c[x], s[x - k]) for x >= k.
                for (cv, &sv) in c[..cols - k].iter_mut().zip(&s[k..]) {
                    *cv = op(*cv, sv);
                }
                for (cv, &sv) in c[k..].iter_mut().zip(&s[..cols - k]) {
                    *cv = op(*cv, sv);
                }
            }
        }
        let r = radius as isize;
        for y in 0..rows {
            let o = &mut out[y * cols..(y + 1) * cols];
            let mut first = true;
            for dy in -r..=r {
                let yy = y as isize + dy;
                if yy < 0 || yy >= rows as isize {
                    continue;
                }
                let w = ((radius * radius) as f64 - (dy * dy) as f64).sqrt().floor() as usize;
                let span = &self.spans[w][yy as usize * cols..(yy as usize + 1) * cols];
                if first {
                    o.copy_from_slice(span);
                    first = false;
                } else {
                    for (ov, &sv) in o.iter_mut().zip(span) {
                        *ov = op(*ov, sv);
                    }
                }
            }
        }
    }
}

/// Grey erosion of a row-major `rows x cols` image by a disk of `radius` pixels.
pub fn erode_disk(src: &[u8], rows: usize, cols: usize, radius: usize) -> Vec<u8> {
    let mut out = vec![0; rows * cols];
    if src.len() == rows * cols {
        Morphology::new(rows, cols, radius).erode(src, radius, &mut out);
    }
    out
}

/// Grey dilation of a row-major `rows x cols` image by a disk of `radius` pixels.
pub fn dilate_disk(src: &[u8], rows: usize, cols: usize, radius: usize) -> Vec<u8> {
    let mut out = vec![0; rows * cols];
    if src.len() == rows * cols {
        Morphology::new(rows, cols, radius).dilate(src, radius, &mut out);
    }
    out
}
