//! How skin-learn plans a tactile image model for tract (feature `onnx`): tract's declutter,
//! the project's direct convolution where the CPU runs it (`direct_conv`, x86-64 with
//! AVX2 and FMA), tract's optimisation, then the project's 2 x 2 max-pool
//! ([`max_pool`]). The classifier and segmenter plan their models this way, and so do
//! the benches that time them.
//!
//! The plan's own operators live in this folder, and only here does skin-learn reach into
//! tract's internals (`tract_core::internal`, the fields of its `Conv` and `OptMaxPool`, the
//! names its ReLU and pools take after declutter and optimisation, `tract_linalg`'s thread
//! pool): that is why the workspace pins tract with `=` (Cargo.toml, `tract-onnx` and
//! `tract-linalg`). A new tract is taken by moving the pin and running this folder's tests,
//! which check each swapped plan against tract's own outputs.
//!
//! The files: `patch` puts an operator in place of nodes (what both swaps use); `direct_conv`
//! and `max_pool` each find what they cover and swap themselves in; this file orders the swaps
//! around tract's passes.

#[cfg(target_arch = "x86_64")]
mod direct_conv;
pub mod max_pool;
mod patch;

use tract_onnx::prelude::*;

/// The optimised plan of a typed model, with the project's own operators swapped in.
pub fn optimise(model: TypedModel) -> TractResult<TypedModel> {
    #[allow(unused_mut)]
    let mut model = model.into_decluttered()?;
    #[cfg(target_arch = "x86_64")]
    direct_conv::swap_convolutions(&mut model)?;
    let mut model = model.into_optimized()?;
    max_pool::swap_max_pools(&mut model)?;
    Ok(model)
}
