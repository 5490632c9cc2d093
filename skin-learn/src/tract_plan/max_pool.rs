//! A 2 x 2, stride 2 max-pool for tract plans (feature `onnx`).
//!
//! Every model of the project halves its images with 2 x 2 max-pools (HandsNet has four, the
//! segmenter two). tract 0.23.9 runs those through a per-output scalar walk with bounds checks
//! (its vectorised 2 x 2 path is for stride 1 only): 0.68 ms of Table 4.1's HandsNet's 3.84 ms
//! on one core, as much as its third convolution. This op does the same reduction
//! row pair by row pair over contiguous planes, which the compiler vectorises, and
//! [`swap_max_pools`] puts it in place of each such pool of an optimised plan. Where a pool
//! has another shape, padding, a ceil mode or an index output, tract's op stays.
//!
//! Every block of those models ends convolution, ReLU, pool. tract runs the ReLU as a pass of
//! its own over the full-size activations (0.065 ms of the lean HandsNet's 0.67 ms); since
//! max(0, max(a, b, c, d)) = max(max(0, a), ..., max(0, d)), the pool takes the ReLU in, on a
//! quarter of the values, where the ReLU feeds nothing else.

use tract_onnx::prelude::*;
use tract_onnx::tract_core::internal::*;
use tract_onnx::tract_core::ops::binary::OptBinByScalar;
use tract_onnx::tract_core::ops::cnn::{OptMaxPool, PaddingSpec};
use tract_onnx::tract_core::ops::nn::DataFormat;

/// Max over each 2 x 2 block of an `[N, C, H, W]` f32 tensor: `[N, C, H / 2, W / 2]`, a last
/// odd row or column dropped (ONNX MaxPool, kernel 2, stride 2, no padding, floor mode); with
/// `relu`, no less than 0 (a ReLU before the pool, taken in).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct MaxPool2x2 {
    /// Whether the ReLU before the pool is taken in (outputs no less than 0).
    pub relu: bool,
}

impl Op for MaxPool2x2 {
    fn name(&self) -> StaticName {
        if self.relu { "ReluMaxPool2x2" } else { "MaxPool2x2" }.into()
    }

    op_as_typed_op!();
}

impl EvalOp for MaxPool2x2 {
    op_out_of_plan!();

    fn eval(&self, _ctx: &EvalContext, inputs: TVec<TValue>) -> TractResult<TVec<TValue>> {
        let input = args_1!(inputs);
        let &[n, c, h, w] = input.shape() else {
            bail!("MaxPool2x2 takes [N, C, H, W], got {:?}", input.shape());
        };
        let mut output = Tensor::zero::<f32>(&[n, c, h / 2, w / 2])?;
        {
            let ram = input.try_as_plain_ram()?;
            let mut out = output.try_as_plain_ram_mut()?;
            let floor = if self.relu { 0.0 } else { f32::NEG_INFINITY };
            pool(ram.as_slice::<f32>()?, out.as_slice_mut::<f32>()?, h, w, floor);
        }
        Ok(tvec!(output.into_tvalue()))
    }
}

impl TypedOp for MaxPool2x2 {
    fn output_facts(&self, inputs: &[&TypedFact]) -> TractResult<TVec<TypedFact>> {
        let shape = &inputs[0].shape;
        if shape.rank() != 4 {
            bail!("MaxPool2x2 takes [N, C, H, W], got {shape:?}");
        }
        let dims: TVec<TDim> = tvec!(
            shape[0].clone(),
            shape[1].clone(),
            shape[2].clone() / 2,
            shape[3].clone() / 2
        );
        Ok(tvec!(f32::fact(dims)))
    }

    as_op!();
}

/// The reduction itself: `input` is whole planes of `h` x `w`, `output` as many planes of
/// `h / 2` x `w / 2`, none below `floor`.
fn pool(input: &[f32], output: &mut [f32], h: usize, w: usize, floor: f32) {
    let (oh, ow) = (h / 2, w / 2);
    if oh == 0 || ow == 0 {
        return;
    }
    // `if a > b` rather than f32::max: a plain vector max, without f32::max's NaN handling
    // (a NaN in a tactile image model's activations is already a failure).
    let max = |a: f32, b: f32| if a > b { a } else { b };
    for (plane, out_plane) in input.chunks_exact(h * w).zip(output.chunks_exact_mut(oh * ow)) {
        for (pair, out_row) in plane.chunks_exact(2 * w).zip(out_plane.chunks_exact_mut(ow)) {
            let (top, bottom) = pair.split_at(w);
            for ((o, t), b) in out_row
                .iter_mut()
                .zip(top.chunks_exact(2))
                .zip(bottom.chunks_exact(2))
            {
                *o = max(max(max(t[0], t[1]), max(b[0], b[1])), floor);
            }
        }
    }
}

/// Whether tract's pool is exactly what [`MaxPool2x2`] computes.
fn is_plain_2x2(op: &OptMaxPool, input: &TypedFact) -> bool {
    let spec = &op.pool_spec;
    let no_padding = match &spec.padding {
        PaddingSpec::Valid => true,
        PaddingSpec::Explicit(before, after) => before.iter().chain(after).all(|&p| p == 0),
        PaddingSpec::ExplicitOnnxPool(before, after, ceil) => {
            !ceil && before.iter().chain(after).all(|&p| p == 0)
        }
        _ => false,
    };
    op.with_index_outputs.is_none()
        && spec.data_format == DataFormat::NCHW
        && spec.kernel_shape[..] == [2, 2]
        && spec.strides()[..] == [2, 2]
        && spec.dilations()[..] == [1, 1]
        && no_padding
        && input.datum_type == f32::datum_type()
        && input.shape.rank() == 4
}

/// The input of the ReLU feeding `outlet` and nothing else (tract's plan writes a ReLU as the
/// max of its input and a constant 0), if there is one.
fn relu_input(model: &TypedModel, outlet: OutletId) -> TractResult<Option<OutletId>> {
    let node = &model.nodes[outlet.node];
    let Some(op) = node.op_as::<OptBinByScalar>() else {
        return Ok(None);
    };
    if op.binop.name() != "Max" || node.inputs.len() != 2 || node.outputs.len() != 1 {
        return Ok(None);
    }
    let only_successor = node.outputs[0].successors.len() == 1 && !model.outputs.contains(&outlet);
    let zero = model
        .outlet_fact(node.inputs[1])?
        .konst
        .as_ref()
        .is_some_and(|k| {
            k.len() == 1
                && k.datum_type() == f32::datum_type()
                && k.cast_to_scalar::<f32>().is_ok_and(|v| v == 0.0)
        });
    let same_shape = model.outlet_fact(node.inputs[0])?.shape == model.outlet_fact(outlet)?.shape;
    Ok((only_successor && zero && same_shape).then_some(node.inputs[0]))
}

/// Replaces each plain 2 x 2, stride 2 f32 max-pool of an optimised plan by [`MaxPool2x2`],
/// taking in the ReLU before it where that ReLU feeds only the pool; returns how many pools.
pub fn swap_max_pools(model: &mut TypedModel) -> TractResult<usize> {
    let mut swapped = 0;
    for id in model.eval_order()? {
        let node = &model.nodes[id];
        let Some(op) = node.op_as::<OptMaxPool>() else {
            continue;
        };
        if !is_plain_2x2(op, model.outlet_fact(node.inputs[0])?) {
            continue;
        }
        match relu_input(model, node.inputs[0])? {
            Some(input) => {
                let name = node.name.clone();
                super::patch::swap_in(model, &name, MaxPool2x2 { relu: true }, input, id.into())?;
            }
            None => {
                TypedModelPatch::replace_single_op(model, node, &node.inputs, MaxPool2x2 { relu: false })?
                    .apply(model)?;
            }
        }
        swapped += 1;
    }
    if swapped > 0 {
        // Drop the pools that were swapped out.
        model.compact()?;
    }
    Ok(swapped)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// The definition, one output at a time.
    fn reference(input: &[f32], n_planes: usize, h: usize, w: usize) -> Vec<f32> {
        let (oh, ow) = (h / 2, w / 2);
        let mut out = Vec::new();
        for p in 0..n_planes {
            for y in 0..oh {
                for x in 0..ow {
                    let at = |dy: usize, dx: usize| input[p * h * w + (2 * y + dy) * w + 2 * x + dx];
                    out.push(at(0, 0).max(at(0, 1)).max(at(1, 0)).max(at(1, 1)));
                }
            }
        }
        out
    }

    #[test]
    fn matches_the_definition_on_odd_and_even_sides() {
        for (planes, h, w) in [(3, 6, 8), (2, 7, 9), (1, 1, 5), (4, 68, 100), (1, 2, 2)] {
            // Distinct values in a scrambled order, so each block has one clear maximum.
            let input: Vec<f32> = (0..planes * h * w)
                .map(|i| ((i * 7919) % 1009) as f32 - 500.0)
                .collect();
            let mut out = vec![0.0; planes * (h / 2) * (w / 2)];
            pool(&input, &mut out, h, w, f32::NEG_INFINITY);
            assert_eq!(out, reference(&input, planes, h, w), "{planes} x {h} x {w}");
        }
    }

    #[test]
    fn with_the_relu_taken_in_no_output_is_below_zero() {
        // Blocks all negative, mixed, all positive.
        let input = [-3.0, -1.0, -2.0, 5.0, 1.0, 2.0, -4.0, -2.0, -5.0, -6.0, 3.0, 4.0];
        let mut out = [9.0; 3];
        pool(&input, &mut out, 2, 6, 0.0);
        assert_eq!(out, [0.0, 5.0, 4.0]);
        let relu_first: Vec<f32> = input.iter().map(|v| v.max(0.0)).collect();
        assert_eq!(out.to_vec(), reference(&relu_first, 1, 2, 6));
    }

    #[test]
    fn the_op_gives_the_shape_and_values_of_onnx_max_pool() {
        let input =
            Tensor::from_shape(&[1, 2, 3, 5], &(0..30).map(|i| i as f32).collect::<Vec<_>>()).unwrap();
        let out = MaxPool2x2 { relu: false }
            .eval(&EvalContext::out_of_plan(), tvec!(input.into_tvalue()))
            .unwrap();
        assert_eq!(out[0].shape(), &[1, 2, 1, 2]);
        let ram = out[0].try_as_plain_ram().unwrap();
        assert_eq!(ram.as_slice::<f32>().unwrap(), &[6.0, 8.0, 21.0, 23.0]);
    }
}
