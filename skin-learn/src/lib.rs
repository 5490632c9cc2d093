//! # skin-learn: touch understanding for robot skin
//!
//! - [`calibration`]: where each taxel sits, fitted from a probe pressing the skin (thesis Ch. 7):
//!   probe datasets and their CSV form, the per-taxel Gaussian fit, a probe simulator, and the
//!   error metrics and convergence curve of the thesis.
//! - `classify` (feature `onnx`): tactile image classification (hand / non-hand, HandsNet,
//!   Ch. 4.3) with any ONNX classifier of grey images, run by tract.
//!
//! Planned: hand-part segmentation, its metrics, and synthetic contact data on a skin layout.

pub mod calibration;
#[cfg(feature = "onnx")]
pub mod classify;
