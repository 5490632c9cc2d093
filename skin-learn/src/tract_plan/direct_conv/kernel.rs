//! The SIMD kernel of a direct convolution: one block of output channels over the whole flat
//! run of a padded image, in 8-lane vectors, on tract's threads where it has several.

use super::geometry::{BLOCK, CHANNEL_CHUNK, Geometry, LANES, TILE, VECTORS};
use std::cell::RefCell;
use tract_linalg::multithread::par_chunks_mut;
use tract_onnx::prelude::*;
use tract_onnx::tract_core::internal::*;

/// Convolves one image `[c_in, h, w]` into `out` `[c_out, ho, wo]`, with `weights` and `bias`
/// packed per block of [`BLOCK`] output channels, and the ReLU after it if `relu`.
pub(super) fn convolve(
    simd: pulp::x86::V3,
    g: &Geometry,
    weights: &[f32],
    bias: &[f32],
    relu: bool,
    image: &[f32],
    out: &mut [f32],
) -> TractResult<()> {
    with_scratch(&PADDED, |padded| {
        g.pad(image, padded);
        let padded = &padded[..];
        let per_block = BLOCK * g.ho * g.wo;
        let block_weights = g.c_in * g.offsets.len() * BLOCK;
        let work = |first: usize, out: &mut [f32]| -> TractResult<()> {
            with_scratch(&TILES, |tiles| {
                // Grown once; the kernel writes every value before it reads one.
                if tiles.len() < BLOCK * g.flat {
                    tiles.resize(BLOCK * g.flat, 0.0);
                }
                for (k, out) in out.chunks_mut(per_block).enumerate() {
                    let b = first + k;
                    let weights = &weights[b * block_weights..(b + 1) * block_weights];
                    let bias = &bias[b * BLOCK..(b + 1) * BLOCK];
                    let ran = pulp::Simd::vectorize(
                        simd,
                        Kernel {
                            g,
                            padded,
                            weights,
                            bias,
                            relu,
                            out: tiles,
                        },
                    );
                    if !ran {
                        bail!("DirectConv's kernel does not fit {g:?}");
                    }
                    // The valid columns of each row.
                    for (channel, plane) in out.chunks_mut(g.ho * g.wo).enumerate() {
                        let flat = &tiles[channel * g.flat..];
                        for (y, row) in plane.chunks_exact_mut(g.wo).enumerate() {
                            row.copy_from_slice(&flat[y * g.row..y * g.row + g.wo]);
                        }
                    }
                }
                Ok(())
            })
        };
        if g.c_out.is_multiple_of(BLOCK) {
            // Blocks on tract's threads when its executor has several.
            let macs = g.c_out * g.c_in * g.offsets.len() * g.ho * g.wo;
            par_chunks_mut(out, per_block, macs, work)
        } else {
            work(0, out)
        }
    })
}

thread_local! {
    /// The padded copy of the image being convolved on this thread.
    static PADDED: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
    /// The kernel's output for one block, junk columns included.
    static TILES: RefCell<Vec<f32>> = const { RefCell::new(Vec::new()) };
}

/// Runs `f` on this thread's buffer `key`, kept from run to run (no allocation once grown), or
/// on a fresh one if that buffer is in use.
fn with_scratch<R>(
    key: &'static std::thread::LocalKey<RefCell<Vec<f32>>>,
    f: impl FnOnce(&mut Vec<f32>) -> R,
) -> R {
    key.with(|cell| match cell.try_borrow_mut() {
        Ok(mut buffer) => f(&mut buffer),
        Err(_) => f(&mut Vec::new()),
    })
}

/// One block of [`BLOCK`] output channels over the whole flat run: `out` gets `BLOCK` runs of
/// `g.flat` values.
struct Kernel<'a> {
    g: &'a Geometry,
    padded: &'a [f32],
    weights: &'a [f32],
    bias: &'a [f32],
    relu: bool,
    out: &'a mut [f32],
}

impl pulp::WithSimd for Kernel<'_> {
    /// Whether the kernel ran: false, and nothing written, where the vectors or buffers do
    /// not fit the geometry (never, as planned).
    type Output = bool;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> bool {
        let Kernel {
            g,
            padded,
            weights,
            bias,
            relu,
            out,
        } = self;
        // This kernel is planned for 8-lane vectors (the geometry's tiles); nothing else runs.
        if S::F32_LANES != LANES || bias.len() != BLOCK || out.len() < BLOCK * g.flat {
            return false;
        }
        let taps = g.offsets.len();
        let zero = simd.splat_f32s(0.0);
        let bias = [
            simd.splat_f32s(bias[0]),
            simd.splat_f32s(bias[1]),
            simd.splat_f32s(bias[2]),
            simd.splat_f32s(bias[3]),
        ];
        // Input channels a chunk at a time, so that the planes a tile reads stay in the L1
        // cache from one tile to the next (64 channels of 3 x 3 taps would not); the partial
        // sums wait in `out` between chunks.
        let chunks = g.c_in.div_ceil(CHANNEL_CHUNK);
        let per_chunk =
            (padded.chunks(CHANNEL_CHUNK * g.plane)).zip(weights.chunks(CHANNEL_CHUNK * taps * BLOCK));
        for (chunk, (planes, w_chunk)) in per_chunk.enumerate() {
            let (first, last) = (chunk == 0, chunk + 1 == chunks);
            for base in (0..g.flat).step_by(TILE) {
                let mut acc = [[zero; VECTORS]; BLOCK];
                if !first {
                    for (k, acc) in acc.iter_mut().enumerate() {
                        let at = k * g.flat + base;
                        let (src, _) = S::as_simd_f32s(&out[at..at + TILE]);
                        for (acc, &src) in acc.iter_mut().zip(src) {
                            *acc = src;
                        }
                    }
                }
                for (plane, w_c) in planes
                    .chunks_exact(g.plane)
                    .zip(w_chunk.chunks_exact(taps * BLOCK))
                {
                    let window = &plane[base..];
                    for (&offset, w) in g.offsets.iter().zip(w_c.chunks_exact(BLOCK)) {
                        let (x, _) = S::as_simd_f32s(&window[offset..offset + TILE]);
                        let (&[x0, x1], &[w0, w1, w2, w3]) = (x, w) else {
                            continue;
                        };
                        for (acc, w) in acc.iter_mut().zip([w0, w1, w2, w3]) {
                            let w = simd.splat_f32s(w);
                            acc[0] = simd.mul_add_f32s(x0, w, acc[0]);
                            acc[1] = simd.mul_add_f32s(x1, w, acc[1]);
                        }
                    }
                }
                for (k, (acc, bias)) in acc.iter().zip(bias).enumerate() {
                    let at = k * g.flat + base;
                    let (dst, _) = S::as_mut_simd_f32s(&mut out[at..at + TILE]);
                    for (dst, &acc) in dst.iter_mut().zip(acc) {
                        *dst = if !last {
                            acc
                        } else if relu {
                            simd.max_f32s(simd.add_f32s(acc, bias), zero)
                        } else {
                            simd.add_f32s(acc, bias)
                        };
                    }
                }
            }
        }
        true
    }
}
