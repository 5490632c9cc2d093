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

use std::cell::RefCell;
use std::sync::Arc;
use tract_linalg::multithread::par_chunks_mut;
use tract_onnx::prelude::*;
use tract_onnx::tract_core::internal::*;
use tract_onnx::tract_core::ops::binary::TypedBinOp;
use tract_onnx::tract_core::ops::cnn::{Conv, KernelFormat};
use tract_onnx::tract_core::ops::nn::DataFormat;

/// Output channels a kernel call computes.
const BLOCK: usize = 4;
/// Vectors of pixels a tile holds per output channel.
const VECTORS: usize = 2;
/// Pixels in one AVX2 vector of f32.
const LANES: usize = 8;
/// Pixels a tile computes per output channel.
const TILE: usize = VECTORS * LANES;
/// Input channels summed over before the next tile.
const CHANNEL_CHUNK: usize = 16;

/// Where each value of one image is, before and after the convolution.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
struct Geometry {
    c_in: usize,
    c_out: usize,
    h: usize,
    w: usize,
    ho: usize,
    wo: usize,
    /// Zero rows above the input, zero columns left of it.
    top: usize,
    left: usize,
    /// Values per row of the padded copy: `w + max(left, right)`.
    row: usize,
    /// Values per channel of the padded copy, the reads of the last tile included.
    plane: usize,
    /// Output values per channel the kernel computes: `ho * row`, in whole tiles.
    flat: usize,
    /// Where each kernel tap reads, from the output position, in the padded plane.
    offsets: Vec<usize>,
}

impl Geometry {
    /// The layout for a convolution of `[c_in, h, w]` by a `kh x kw` kernel dilated by
    /// `(dh, dw)` and padded by `(top, bottom, left, right)`, if it has any output and every
    /// buffer it sizes can be addressed (the sizes come from a model file).
    #[allow(clippy::too_many_arguments)]
    fn new(
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
    fn blocks(&self) -> usize {
        self.c_out.div_ceil(BLOCK)
    }

    /// Copies one image `[c_in, h, w]` into `padded`, zeros around it.
    fn pad(&self, image: &[f32], padded: &mut Vec<f32>) {
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

/// A stride-1, one-group f32 convolution of `[N, C, H, W]` with its weights packed for
/// the kernel, and the ReLU after it if taken in.
#[derive(Debug, Clone)]
pub struct DirectConv {
    geometry: Arc<Geometry>,
    /// Per block of [`BLOCK`] output channels, per input channel, per tap: the block's
    /// [`BLOCK`] weights (0 for channels past `c_out`).
    weights: Arc<[f32]>,
    /// [`BLOCK`] biases per block.
    bias: Arc<[f32]>,
    /// Whether outputs are no less than 0 (a ReLU after the convolution, taken in).
    relu: bool,
}

impl PartialEq for DirectConv {
    fn eq(&self, other: &Self) -> bool {
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        self.geometry == other.geometry
            && self.relu == other.relu
            && bits(&self.weights) == bits(&other.weights)
            && bits(&self.bias) == bits(&other.bias)
    }
}

impl Eq for DirectConv {}

impl DirectConv {
    /// The op for `weights` `[c_out, c_in, kh, kw]` (OIHW) and `bias` (one per output channel,
    /// or one for all), if the geometry has an output.
    fn new(geometry: Geometry, weights: &[f32], bias: &[f32], relu: bool) -> Option<DirectConv> {
        let taps = geometry.offsets.len();
        let (c_in, c_out) = (geometry.c_in, geometry.c_out);
        // Geometry::new checked that these products fit.
        if weights.len() != c_out * c_in * taps || !(bias.len() == c_out || bias.len() == 1) {
            return None;
        }
        let blocks = geometry.blocks();
        let mut packed = vec![0.0; blocks * c_in * taps * BLOCK];
        let mut biases = vec![0.0; blocks * BLOCK];
        for o in 0..c_out {
            let (b, k) = (o / BLOCK, o % BLOCK);
            biases[b * BLOCK + k] = if bias.len() == 1 { bias[0] } else { bias[o] };
            for c in 0..c_in {
                for t in 0..taps {
                    packed[((b * c_in + c) * taps + t) * BLOCK + k] = weights[(o * c_in + c) * taps + t];
                }
            }
        }
        Some(DirectConv {
            geometry: Arc::new(geometry),
            weights: packed.into(),
            bias: biases.into(),
            relu,
        })
    }

    /// Convolves one image `[c_in, h, w]` into `out` `[c_out, ho, wo]`.
    fn run_image(&self, simd: pulp::x86::V3, image: &[f32], out: &mut [f32]) -> TractResult<()> {
        let g = &*self.geometry;
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
                        let weights = &self.weights[b * block_weights..(b + 1) * block_weights];
                        let bias = &self.bias[b * BLOCK..(b + 1) * BLOCK];
                        let ran = pulp::Simd::vectorize(
                            simd,
                            Kernel {
                                g,
                                padded,
                                weights,
                                bias,
                                relu: self.relu,
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

impl Op for DirectConv {
    fn name(&self) -> StaticName {
        if self.relu { "DirectConvRelu" } else { "DirectConv" }.into()
    }

    fn info(&self) -> TractResult<Vec<String>> {
        let g = &self.geometry;
        Ok(vec![format!(
            "{} -> {} channels, {} taps, {}x{} -> {}x{}",
            g.c_in,
            g.c_out,
            g.offsets.len(),
            g.h,
            g.w,
            g.ho,
            g.wo
        )])
    }

    op_as_typed_op!();
}

impl EvalOp for DirectConv {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let g = &*self.geometry;
        let &[n, c, h, w] = input.shape() else {
            bail!("DirectConv takes [N, C, H, W], got {:?}", input.shape());
        };
        if (c, h, w) != (g.c_in, g.h, g.w) {
            bail!(
                "DirectConv planned for [N, {}, {}, {}], got {:?}",
                g.c_in,
                g.h,
                g.w,
                input.shape()
            );
        }
        let Some(simd) = pulp::x86::V3::try_new() else {
            bail!("DirectConv needs AVX2 and FMA");
        };
        let mut output = Tensor::zero::<f32>(&[n, g.c_out, g.ho, g.wo])?;
        {
            let ram = input.try_as_plain_ram()?;
            let mut out = output.try_as_plain_ram_mut()?;
            let images = ram.as_slice::<f32>()?.chunks_exact(c * h * w);
            for (image, out) in images.zip(out.as_slice_mut::<f32>()?.chunks_exact_mut(g.c_out * g.ho * g.wo))
            {
                self.run_image(simd, image, out)?;
            }
        }
        Ok(tvec!(output.into_tvalue()))
    }
}

impl TypedOp for DirectConv {
    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let shape = &inputs[0].shape;
        if shape.rank() != 4 {
            bail!("DirectConv takes [N, C, H, W], got {shape:?}");
        }
        let g = &self.geometry;
        let planned = [g.c_in, g.h, g.w];
        if shape
            .iter()
            .skip(1)
            .zip(planned)
            .any(|(d, p)| d.to_usize().is_ok_and(|d| d != p))
        {
            bail!(
                "DirectConv planned for [N, {}, {}, {}], got {shape:?}",
                g.c_in,
                g.h,
                g.w
            );
        }
        let dims: TVec<TDim> = tvec!(shape[0].clone(), g.c_out.into(), g.ho.into(), g.wo.into());
        Ok(tvec!(f32::fact(dims)))
    }

    as_op!();
}

/// The op for tract's convolution `conv` at `node`, if it is one [`DirectConv`] covers.
fn direct_conv_for(model: &TypedModel, node: &TypedNode, conv: &Conv) -> TractResult<Option<DirectConv>> {
    let spec = &conv.pool_spec;
    let input = model.outlet_fact(node.inputs[0])?;
    if conv.q_params.is_some()
        || conv.group != 1
        || conv.kernel_fmt != KernelFormat::OIHW
        || spec.data_format != DataFormat::NCHW
        || spec.kernel_shape.len() != 2
        || spec.strides().iter().any(|&s| s != 1)
        || input.datum_type != f32::datum_type()
        || input.shape.rank() != 4
        || node.inputs.len() != 3
    {
        return Ok(None);
    }
    let dims: Option<Vec<usize>> = input.shape.iter().skip(1).map(|d| d.to_usize().ok()).collect();
    let Some(&[c_in, h, w]) = dims.as_deref() else {
        return Ok(None);
    };
    let konst = |i: usize| -> TractResult<Option<Arc<Tensor>>> {
        let fact = model.outlet_fact(node.inputs[i])?;
        Ok(fact.konst.clone().filter(|k| k.datum_type() == f32::datum_type()))
    };
    let (Some(weights), Some(bias)) = (konst(1)?, konst(2)?) else {
        return Ok(None);
    };
    let (kh, kw) = (spec.kernel_shape[0], spec.kernel_shape[1]);
    let &[c_out, kc_in, wkh, wkw] = weights.shape() else {
        return Ok(None);
    };
    if (kc_in, wkh, wkw) != (c_in, kh, kw) {
        return Ok(None);
    }
    let padding = spec.computed_padding(&[h, w]);
    let dilations = spec.dilations();
    let Some(geometry) = Geometry::new(
        (c_in, c_out),
        (h, w),
        (kh, kw),
        (dilations[0], dilations[1]),
        (
            padding[0].pad_before,
            padding[0].pad_after,
            padding[1].pad_before,
            padding[1].pad_after,
        ),
    ) else {
        return Ok(None);
    };
    if (padding[0].convoluted, padding[1].convoluted) != (geometry.ho, geometry.wo) {
        return Ok(None);
    }
    let weights = weights.try_as_plain_ram()?;
    let bias = bias.try_as_plain_ram()?;
    Ok(DirectConv::new(
        geometry,
        weights.as_slice::<f32>()?,
        bias.as_slice::<f32>()?,
        false,
    ))
}

/// The ReLU reading `outlet` and nothing else (tract writes one as the max of its input and a
/// constant 0), if there is one.
fn relu_after(model: &TypedModel, outlet: OutletId) -> TractResult<Option<OutletId>> {
    let node = &model.nodes[outlet.node];
    let successors = &node.outputs[outlet.slot].successors;
    if successors.len() != 1 || model.outputs.contains(&outlet) {
        return Ok(None);
    }
    let next = &model.nodes[successors[0].node];
    let Some(op) = next.op_as::<TypedBinOp>() else {
        return Ok(None);
    };
    if op.0.name() != "Max" || next.inputs.len() != 2 || next.outputs.len() != 1 {
        return Ok(None);
    }
    let other = next.inputs[1 - successors[0].slot];
    let zero = model.outlet_fact(other)?.konst.as_ref().is_some_and(|k| {
        k.datum_type() == f32::datum_type()
            && k.try_as_plain_ram()
                .ok()
                .and_then(|r| r.as_slice::<f32>().ok().map(|v| v.iter().all(|&x| x == 0.0)))
                .unwrap_or(false)
    });
    let relu = OutletId::new(next.id, 0);
    let same_shape = model.outlet_fact(relu)?.shape == model.outlet_fact(outlet)?.shape;
    Ok((zero && same_shape).then_some(relu))
}

/// Whether this CPU runs [`DirectConv`]: x86-64-v3, that is AVX2 and FMA with the BMI and
/// LZCNT instructions that come with them (every x86-64 CPU since 2013-2015).
pub fn available() -> bool {
    pulp::x86::V3::try_new().is_some()
}

/// Replaces each convolution of a decluttered model that [`DirectConv`] covers, taking in the
/// ReLU after it where that ReLU reads only it; returns how many. Nothing changes on a CPU
/// without AVX2 and FMA.
pub fn swap_convolutions(model: &mut TypedModel) -> TractResult<usize> {
    if !available() {
        return Ok(0);
    }
    let mut swapped = 0;
    for id in model.eval_order()? {
        let node = &model.nodes[id];
        let Some(conv) = node.op_as::<Conv>() else {
            continue;
        };
        let Some(mut op) = direct_conv_for(model, node, conv)? else {
            continue;
        };
        let relu = relu_after(model, OutletId::new(id, 0))?;
        op.relu = relu.is_some();
        let (name, input) = (node.name.clone(), node.inputs[0]);
        crate::tract_plan::swap_in(model, &name, op, input, relu.unwrap_or(OutletId::new(id, 0)))?;
        swapped += 1;
    }
    if swapped > 0 {
        // Drop the convolutions, ReLUs and weights that were swapped out.
        model.compact()?;
    }
    Ok(swapped)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use proptest::prelude::*;
    use tract_onnx::tract_core::ops::cnn::{PaddingSpec, PoolSpec};

    /// A stride-1 convolution's shape and parameters, as ONNX states them.
    struct Spec {
        c_in: usize,
        c_out: usize,
        h: usize,
        w: usize,
        kh: usize,
        kw: usize,
        dh: usize,
        dw: usize,
        /// Top, bottom, left, right.
        pads: [usize; 4],
    }

    impl Spec {
        /// Output height and width, by ONNX's formula.
        fn output(&self) -> (usize, usize) {
            let [top, bottom, left, right] = self.pads;
            (
                self.h + top + bottom - (self.kh - 1) * self.dh,
                self.w + left + right - (self.kw - 1) * self.dw,
            )
        }
    }

    /// The definition of a stride-1 convolution (ONNX Conv, one group), one output at a time,
    /// in f64, from the parameters alone (not the op's geometry).
    fn reference(input: &[f32], weights: &[f32], bias: &[f32], s: &Spec, relu: bool) -> Vec<f32> {
        let (ho, wo) = s.output();
        let [top, _, left, _] = s.pads;
        let mut out = Vec::new();
        for o in 0..s.c_out {
            for y in 0..ho {
                for x in 0..wo {
                    let mut sum = f64::from(if bias.len() == 1 { bias[0] } else { bias[o] });
                    for c in 0..s.c_in {
                        for i in 0..s.kh {
                            for j in 0..s.kw {
                                let (r, q) = (
                                    (y + i * s.dh) as isize - top as isize,
                                    (x + j * s.dw) as isize - left as isize,
                                );
                                if r < 0 || q < 0 || r >= s.h as isize || q >= s.w as isize {
                                    continue;
                                }
                                let v = input[(c * s.h + r as usize) * s.w + q as usize];
                                let k = weights[((o * s.c_in + c) * s.kh + i) * s.kw + j];
                                sum += f64::from(v) * f64::from(k);
                            }
                        }
                    }
                    out.push(if relu { sum.max(0.0) } else { sum } as f32);
                }
            }
        }
        out
    }

    /// The op's output for `n` images `[c_in, h, w]`: its shape and values.
    fn run(op: &DirectConv, n: usize, input: &[f32]) -> (Vec<usize>, Vec<f32>) {
        let g = &op.geometry;
        let input = Tensor::from_shape(&[n, g.c_in, g.h, g.w], input).unwrap();
        let out = op
            .eval(&EvalContext::out_of_plan(), tvec!(input.into_tvalue()))
            .unwrap();
        let values = out[0]
            .try_as_plain_ram()
            .unwrap()
            .as_slice::<f32>()
            .unwrap()
            .to_vec();
        (out[0].shape().to_vec(), values)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// Any channel counts (blocks of four or not, one chunk of input channels or several), image and kernel sizes, dilations,
        /// asymmetric padding, bias and ReLU: the definition's values.
        #[test]
        fn matches_the_definition(
            c_in in prop_oneof![1usize..5, 15usize..40], c_out in 1usize..10, h in 1usize..12, w in 1usize..14,
            kh in 1usize..6, kw in 1usize..6, dh in 1usize..4, dw in 1usize..4,
            pads in prop::array::uniform4(0usize..6), relu: bool, one_bias: bool, seed: u64,
        ) {
            if !available() {
                // tract keeps its convolutions on this CPU (`swap_convolutions` swaps none).
                return Ok(());
            }
            let [top, bottom, left, right] = pads;
            let Some(g) = Geometry::new((c_in, c_out), (h, w), (kh, kw), (dh, dw), (top, bottom, left, right)) else {
                // No output, or padding past the kernel's reach: tract keeps such convolutions.
                let no_output = h + top + bottom <= (kh - 1) * dh || w + left + right <= (kw - 1) * dw;
                prop_assert!(no_output || left.min(right) > (kw - 1) * dw, "refused {pads:?}");
                return Ok(());
            };
            let spec = Spec { c_in, c_out, h, w, kh, kw, dh, dw, pads };
            let mut state = seed | 1;
            let mut next = move || {
                state ^= state << 13; state ^= state >> 7; state ^= state << 17;
                (state % 2001) as f32 / 1000.0 - 1.0
            };
            let n = 2;
            let input: Vec<f32> = (0..n * c_in * h * w).map(|_| next()).collect();
            let weights: Vec<f32> = (0..c_out * c_in * kh * kw).map(|_| next()).collect();
            let bias: Vec<f32> = (0..if one_bias { 1 } else { c_out }).map(|_| next()).collect();
            let op = DirectConv::new(g.clone(), &weights, &bias, relu).unwrap();
            let (shape, got) = run(&op, n, &input);
            let (ho, wo) = spec.output();
            prop_assert_eq!(shape, vec![n, c_out, ho, wo]);
            let per_image = c_in * h * w;
            let want: Vec<f32> = input
                .chunks_exact(per_image)
                .flat_map(|image| reference(image, &weights, &bias, &spec, relu))
                .collect();
            prop_assert_eq!(got.len(), want.len());
            for (i, (a, b)) in got.iter().zip(&want).enumerate() {
                prop_assert!((a - b).abs() <= 1e-4 * (1.0 + b.abs()), "output {i}: {a} against {b}");
            }
        }
    }

    /// Each shipped model gives tract's own outputs with its convolutions swapped, and the swap
    /// covers all of its 3 x 3 and 5 x 5 convolutions.
    #[test]
    fn shipped_models_give_tracts_outputs() {
        if !available() {
            eprintln!("skipped: this CPU has no AVX2 and FMA, tract keeps its convolutions");
            return;
        }
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/models");
        for (name, convolutions) in [("handsnet", 4), ("handseg", 13), ("handseg_wide", 13)] {
            let model = tract_onnx::onnx()
                .model_for_path(root.join(format!("{name}.onnx")))
                .unwrap()
                .with_input_fact(0, f32::fact([1, 1, 68, 100]).into())
                .unwrap()
                .into_typed()
                .unwrap()
                .into_decluttered()
                .unwrap();
            let mut swapped = model.clone();
            assert_eq!(swap_convolutions(&mut swapped).unwrap(), convolutions, "{name}");
            let input = tract_ndarray::Array4::from_shape_fn((1, 1, 68, 100), |(_, _, r, c)| {
                ((r * 7 + c * 13) % 17) as f32 / 17.0
                    * f32::from(u8::from((r as f32 - 34.0).hypot(c as f32 - 50.0) < 20.0))
            });
            let input: Tensor = input.into();
            let outputs = |m: TypedModel| {
                let out = m
                    .into_optimized()
                    .unwrap()
                    .into_runnable()
                    .unwrap()
                    .run(tvec!(input.clone().into()))
                    .unwrap();
                out[0]
                    .try_as_plain_ram()
                    .unwrap()
                    .as_slice::<f32>()
                    .unwrap()
                    .to_vec()
            };
            let (want, got) = (outputs(model), outputs(swapped));
            assert_eq!(want.len(), got.len(), "{name}");
            let worst = want
                .iter()
                .zip(&got)
                .map(|(a, b)| (a - b).abs() / (1.0 + a.abs()))
                .fold(0.0f32, f32::max);
            assert!(worst < 1e-4, "{name}: outputs differ by up to {worst}");
        }
    }

    /// A decluttered model of one convolution of a `[1, c_in, h, w]` input; a ReLU after it
    /// where `relu` is set; the convolution's own output a model output too where `keep` is.
    fn one_convolution(conv: Conv, (h, w): (usize, usize), relu: bool, keep: bool) -> TypedModel {
        use tract_onnx::tract_core::ops::change_axes::wire_with_rank_broadcast;
        let spec = &conv.pool_spec;
        let (c_in, c_out) = (spec.input_channels, spec.output_channels);
        let (kh, kw) = (spec.kernel_shape[0], spec.kernel_shape[1]);
        let per_group = c_in / conv.group;
        let values = |n: usize, step: usize| -> Vec<f32> {
            (0..n).map(|k| (k * step % 101) as f32 / 50.0 - 1.0).collect()
        };
        let mut model = TypedModel::default();
        let x = model.add_source("x", f32::fact([1, c_in, h, w])).unwrap();
        let weights = Tensor::from_shape(
            &[c_out, per_group, kh, kw],
            &values(c_out * per_group * kh * kw, 37),
        );
        let bias = Tensor::from_shape(&[c_out], &values(c_out, 13));
        let weights = model.add_const("weights", weights.unwrap()).unwrap();
        let bias = model.add_const("bias", bias.unwrap()).unwrap();
        let y = model.wire_node("conv", conv, &[x, weights, bias]).unwrap()[0];
        let mut outputs = vec![];
        if relu {
            let zero = model.add_const("zero", tensor0(0f32)).unwrap();
            let max = tract_onnx::tract_core::ops::math::max();
            outputs.push(wire_with_rank_broadcast("relu", &mut model, max, &[y, zero]).unwrap()[0]);
        }
        if keep || !relu {
            outputs.push(y);
        }
        model.select_output_outlets(&outputs).unwrap();
        model.into_decluttered().unwrap()
    }

    /// An f32 convolution of `c.0` into `c.1` channels by a `k` kernel, dilated by (1, 2).
    fn conv(c: (usize, usize), k: (usize, usize), padding: PaddingSpec, stride: usize, group: usize) -> Conv {
        Conv {
            pool_spec: PoolSpec {
                data_format: DataFormat::NCHW,
                kernel_shape: tvec![k.0, k.1],
                padding,
                dilations: Some(tvec![1, 2]),
                strides: Some(tvec![stride, stride]),
                input_channels: c.0,
                output_channels: c.1,
            },
            kernel_fmt: KernelFormat::OIHW,
            group,
            q_params: None,
        }
    }

    /// Every output of `model` run by tract as it is, and with its convolutions swapped:
    /// how many were swapped, which of them took in a ReLU, and the largest difference.
    fn swapped_against_tract(model: TypedModel, (c, h, w): (usize, usize, usize)) -> (usize, Vec<bool>, f32) {
        let mut swapped = model.clone();
        let count = swap_convolutions(&mut swapped).unwrap();
        let fused = swapped
            .nodes
            .iter()
            .filter_map(|n| n.op_as::<DirectConv>().map(|op| op.relu))
            .collect();
        let input: Tensor = tract_ndarray::Array4::from_shape_fn((1, c, h, w), |(_, k, r, q)| {
            ((k * 31 + r * 7 + q * 13) % 17) as f32 / 8.0 - 1.0
        })
        .into();
        let outputs = |m: TypedModel| {
            let runnable = m.into_optimized().unwrap().into_runnable().unwrap();
            let out = runnable.run(tvec!(input.clone().into())).unwrap();
            out.iter()
                .map(|t| t.try_as_plain_ram().unwrap().as_slice::<f32>().unwrap().to_vec())
                .collect::<Vec<_>>()
        };
        let (want, got) = (outputs(model), outputs(swapped));
        assert_eq!(want.len(), got.len());
        let mut worst = 0.0f32;
        for (want, got) in want.iter().zip(&got) {
            assert_eq!(want.len(), got.len());
            for (a, b) in want.iter().zip(got) {
                worst = worst.max((a - b).abs() / (1.0 + a.abs()));
            }
        }
        (count, fused, worst)
    }

    /// Built models, against tract on the same input: asymmetric padding of each kind reaches
    /// the right sides; a ReLU is taken in only where nothing else reads the convolution; the
    /// strided and grouped convolutions stay with tract.
    #[test]
    fn swaps_only_what_it_covers_and_keeps_tracts_outputs() {
        if !available() {
            eprintln!("skipped: this CPU has no AVX2 and FMA, tract keeps its convolutions");
            return;
        }
        let (c_in, h, w) = (5, 9, 11);
        // Two rows above and none below, none left and one right.
        let explicit = || PaddingSpec::Explicit(tvec![2, 0], tvec![0, 1]);
        let cases = [
            (
                "explicit, ReLU",
                conv((c_in, 6), (3, 3), explicit(), 1, 1),
                true,
                false,
                1,
                vec![true],
            ),
            (
                "explicit, ReLU, convolution read too",
                conv((c_in, 6), (3, 3), explicit(), 1, 1),
                true,
                true,
                1,
                vec![false],
            ),
            (
                "same lower, even kernel",
                conv((c_in, 8), (4, 2), PaddingSpec::SameLower, 1, 1),
                false,
                false,
                1,
                vec![false],
            ),
            (
                "same upper, even kernel, ReLU",
                conv((c_in, 3), (2, 4), PaddingSpec::SameUpper, 1, 1),
                true,
                false,
                1,
                vec![true],
            ),
            (
                "stride 2",
                conv((c_in, 6), (3, 3), explicit(), 2, 1),
                true,
                false,
                0,
                vec![],
            ),
            (
                "two groups",
                conv((4, 6), (3, 3), explicit(), 1, 2),
                true,
                false,
                0,
                vec![],
            ),
        ];
        for (name, conv, relu, keep, count, fused) in cases {
            let c = conv.pool_spec.input_channels;
            let model = one_convolution(conv, (h, w), relu, keep);
            let (swapped, took_in, worst) = swapped_against_tract(model, (c, h, w));
            assert_eq!((swapped, took_in), (count, fused), "{name}");
            assert!(worst < 1e-4, "{name}: outputs differ by up to {worst}");
        }
    }

    /// Shapes a model file may declare that leave nothing to compute or overflow a buffer's
    /// size are tract's to handle (or refuse), never a panic here.
    #[test]
    fn refuses_empty_and_unaddressable_shapes() {
        let pads = (2, 2, 2, 2);
        assert!(Geometry::new((1, 1), (0, 5), (3, 3), (1, 1), pads).is_none());
        assert!(Geometry::new((1, 1), (5, 0), (3, 3), (1, 1), pads).is_none());
        assert!(Geometry::new((0, 1), (5, 5), (3, 3), (1, 1), pads).is_none());
        assert!(Geometry::new((1, 1), (5, 5), (0, 3), (1, 1), pads).is_none());
        let huge = usize::MAX / 2;
        assert!(Geometry::new((1, 1), (huge, huge), (3, 3), (1, 1), pads).is_none());
        assert!(Geometry::new((huge, 1), (5, 5), (3, 3), (1, 1), pads).is_none());
        assert!(Geometry::new((1, 1), (5, 5), (3, 3), (huge, 1), (huge, huge, 1, 1)).is_none());
        assert!(Geometry::new((1, 1), (5, 5), (3, 3), (1, 1), pads).is_some());
    }
}
