//! Per frame: the plane coefficients of every visible triangle, then one multiply-add pair per
//! pixel, and the grey levels (thesis eq. 3.1) fused into the same pass.

use super::grey::quantise;
use super::{Normalisation, PixelWeights, Rasterizer};
use crate::{Error, Result};

impl Rasterizer {
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

    pub(super) fn check(&self, pressures: &[f32], image_len: usize) -> Result<()> {
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
