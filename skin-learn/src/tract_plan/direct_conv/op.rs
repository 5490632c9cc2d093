//! The direct convolution as a tract operator: its packed weights, its evaluation and the
//! shapes it gives.

use super::geometry::{BLOCK, Geometry};
use super::kernel::convolve;
use std::sync::Arc;
use tract_onnx::prelude::*;
use tract_onnx::tract_core::internal::*;

/// A stride-1, one-group f32 convolution of `[N, C, H, W]` with its weights packed for
/// the kernel, and the ReLU after it if taken in.
#[derive(Debug, Clone)]
pub struct DirectConv {
    pub(super) geometry: Arc<Geometry>,
    /// Per block of [`BLOCK`] output channels, per input channel, per tap: the block's
    /// [`BLOCK`] weights (0 for channels past `c_out`).
    pub(super) weights: Arc<[f32]>,
    /// [`BLOCK`] biases per block.
    pub(super) bias: Arc<[f32]>,
    /// Whether outputs are no less than 0 (a ReLU after the convolution, taken in).
    pub(super) relu: bool,
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
    pub(super) fn new(geometry: Geometry, weights: &[f32], bias: &[f32], relu: bool) -> Option<DirectConv> {
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
        convolve(
            simd,
            &self.geometry,
            &self.weights,
            &self.bias,
            self.relu,
            image,
            out,
        )
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

/// Whether this CPU runs [`DirectConv`]: x86-64-v3, that is AVX2 and FMA with the BMI and
/// LZCNT instructions that come with them (every x86-64 CPU since 2013-2015).
pub fn available() -> bool {
    pulp::x86::V3::try_new().is_some()
}
