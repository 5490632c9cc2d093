//! Where the direct convolution takes tract's place: each convolution of a decluttered model
//! that it covers, with the ReLU after it.

use super::geometry::Geometry;
use super::op::{DirectConv, available};
use crate::tract_plan::patch::swap_in;
use std::sync::Arc;
use tract_onnx::prelude::*;
use tract_onnx::tract_core::internal::*;
use tract_onnx::tract_core::ops::binary::TypedBinOp;
use tract_onnx::tract_core::ops::cnn::{Conv, KernelFormat};
use tract_onnx::tract_core::ops::nn::DataFormat;

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
        swap_in(model, &name, op, input, relu.unwrap_or(OutletId::new(id, 0)))?;
        swapped += 1;
    }
    if swapped > 0 {
        // Drop the convolutions, ReLUs and weights that were swapped out.
        model.compact()?;
    }
    Ok(swapped)
}
