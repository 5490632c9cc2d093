//! Putting one of the plan's operators in place of nodes of a tract model.

use tract_onnx::prelude::*;

/// Puts `op`, named `name` and reading `input`, in place of the nodes from `input`'s reader
/// through `last` (an operator and the ReLU it takes in, say).
pub(super) fn swap_in(
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
