//! Where each value of one image is, before and after a direct convolution, and the tile sizes
//! the kernel is planned for.

/// Output channels a kernel call computes.
pub(super) const BLOCK: usize = 4;
/// Vectors of pixels a tile holds per output channel.
pub(super) const VECTORS: usize = 2;
/// Pixels in one AVX2 vector of f32.
pub(super) const LANES: usize = 8;
/// Pixels a tile computes per output channel.
pub(super) const TILE: usize = VECTORS * LANES;
/// Input channels summed over before the next tile.
pub(super) const CHANNEL_CHUNK: usize = 16;

/// Where each value of one image is, before and after the convolution.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub(super) struct Geometry {
    pub(super) c_in: usize,
    pub(super) c_out: usize,
    pub(super) h: usize,
    pub(super) w: usize,
    pub(super) ho: usize,
    pub(super) wo: usize,
    /// Zero rows above the input, zero columns left of it.
    pub(super) top: usize,
    pub(super) left: usize,
    /// Values per row of the padded copy: `w + max(left, right)`.
    pub(super) row: usize,
    /// Values per channel of the padded copy, the reads of the last tile included.
    pub(super) plane: usize,
    /// Output values per channel the kernel computes: `ho * row`, in whole tiles.
    pub(super) flat: usize,
    /// Where each kernel tap reads, from the output position, in the padded plane.
    pub(super) offsets: Vec<usize>,
}

impl Geometry {
    /// The layout for a convolution of `[c_in, h, w]` by a `kh x kw` kernel dilated by
    /// `(dh, dw)` and padded by `(top, bottom, left, right)`, if it has any output and every
    /// buffer it sizes can be addressed (the sizes come from a model file).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        (c_in, c_out): (usize, usize),
        (h, w): (usize, usize),
        (kh, kw): (usize, usize),
        (dh, dw): (usize, usize),
        (top, bottom, left, right): (usize, usize, usize, usize),
    ) -> Option<Geometry> {
        if c_in == 0 || c_out == 0 || h == 0 || w == 0 {
            return None;
        }
        let span_h = (kh.checked_sub(1)?).checked_mul(dh)?;
        let span_w = (kw.checked_sub(1)?).checked_mul(dw)?;
        let tall = h.checked_add(top)?.checked_add(bottom)?;
        let ho = tall.checked_sub(span_h)?;
        let wo = w.checked_add(left)?.checked_add(right)?.checked_sub(span_w)?;
        let row = w.checked_add(left.max(right))?;
        // Output column wo - 1 must sit in the row (padding larger than the kernel's reach
        // would leave outputs past it): wo <= row.
        if ho == 0 || wo == 0 || wo > row {
            return None;
        }
        let flat = ho.checked_mul(row)?.checked_next_multiple_of(TILE)?;
        // The last tile reads up to flat - 1 + the largest offset.
        let plane = tall.checked_mul(row)?.checked_add(span_w)?.checked_add(TILE)?;
        // The padded copy, one block's tiles, one output image and the packed weights.
        c_in.checked_mul(plane)?;
        BLOCK.checked_mul(flat)?;
        c_out.checked_mul(ho)?.checked_mul(wo)?;
        c_out
            .checked_next_multiple_of(BLOCK)?
            .checked_mul(c_in)?
            .checked_mul(kh.checked_mul(kw)?)?;
        let offsets = (0..kh)
            .flat_map(|i| (0..kw).map(move |j| i * dh * row + j * dw))
            .collect();
        Some(Geometry {
            c_in,
            c_out,
            h,
            w,
            ho,
            wo,
            top,
            left,
            row,
            plane,
            flat,
            offsets,
        })
    }

    /// Blocks of [`BLOCK`] output channels, the last one maybe partial.
    pub(super) fn blocks(&self) -> usize {
        self.c_out.div_ceil(BLOCK)
    }

    /// Copies one image `[c_in, h, w]` into `padded`, zeros around it.
    pub(super) fn pad(&self, image: &[f32], padded: &mut Vec<f32>) {
        padded.clear();
        padded.resize(self.c_in * self.plane, 0.0);
        for (channel, plane) in image
            .chunks_exact(self.h * self.w)
            .zip(padded.chunks_exact_mut(self.plane))
        {
            for (y, src) in channel.chunks_exact(self.w).enumerate() {
                let at = (self.top + y) * self.row + self.left;
                plane[at..at + self.w].copy_from_slice(src);
            }
        }
    }
}
