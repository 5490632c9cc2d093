//! How skin-learn plans a tactile image model for tract (feature `onnx`): tract's declutter,
//! the project's direct convolution where the CPU runs it (`direct_conv`, x86-64 with
//! AVX2 and FMA), tract's optimisation, then the project's 2 x 2 max-pool
//! ([`crate::max_pool`]). The classifier and segmenter plan their models this way, and so do
//! the benches that time them.

use tract_onnx::prelude::*;

/// The optimised plan of a typed model, with the project's own operators swapped in.
pub fn optimise(model: TypedModel) -> TractResult<TypedModel> {
    #[allow(unused_mut)]
    let mut model = model.into_decluttered()?;
    #[cfg(target_arch = "x86_64")]
    crate::direct_conv::swap_convolutions(&mut model)?;
    let mut model = model.into_optimized()?;
    crate::max_pool::swap_max_pools(&mut model)?;
    Ok(model)
}

/// Puts `op`, named `name` and reading `input`, in place of the nodes from `input`'s reader
/// through `last` (an operator and the ReLU it takes in, say).
pub(crate) fn swap_in(
    model: &mut TypedModel,
    name: &str,
    op: impl Into<Box<dyn TypedOp>>,
    input: OutletId,
    last: OutletId,
) -> TractResult<()> {
    let mut patch = TypedModelPatch::default();
    let tapped = patch.tap_model(model, input)?;
    let out = patch.wire_node(name, op, &[tapped])?;
    patch.shunt_outside(model, last, out[0])?;
    patch.apply(model)
}
