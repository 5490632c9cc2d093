//! A direct 2-D convolution for tract plans (feature `onnx`), on x86-64 CPUs with AVX2 and FMA
//! (x86-64-v3).
//!
//! tract 0.23.9 runs a convolution as a patch gather (its "lazy im2col") feeding its matrix
//! product: 1.5-2.5x onnxruntime's time on the layers of the project's models, the more so
//! the fewer the channels (BENCHMARKS.md). This op computes each output tile straight from a
//! zero-padded copy of the input, as onnxruntime's own x86 kernels do: four output channels by
//! two vectors of pixels held in eight registers, each input vector loaded once for the four
//! channels, each weight broadcast once for all the tile's pixels, over every input channel and
//! kernel tap. No patch matrix is built.
//!
//! The padded copy has rows of `W + max(left, right)` values, so that the right padding of one
//! row is the left padding of the next. Output row `y` then reads the padded plane from
//! `y * row` on, for every tap at its fixed offset, and all output rows with the few junk
//! columns between them are one contiguous run: the kernel walks that run in whole tiles and the
//! valid columns are copied out.
//!
//! [`swap_convolutions`] puts the op in place of each convolution it covers, in a decluttered
//! model before tract's optimisation: stride 1, one group, f32 `[N, C, H, W]` with C, H and W
//! fixed, constant weights and bias, any kernel size, dilation and padding. A ReLU that reads
//! only the convolution is taken in. Other convolutions, and every convolution on a CPU without
//! AVX2 and FMA, stay with tract. The SIMD code is safe Rust through `pulp`, the crate faer's
//! kernels are written with.

mod geometry;
mod kernel;
mod op;
mod swap;
#[cfg(test)]
mod tests;

pub(crate) use swap::swap_convolutions;
