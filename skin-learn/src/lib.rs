//! # skin-learn: touch understanding for robot skin
//!
//! What the skin's pressures mean, learned and judged: where each taxel sits (calibration,
//! Ch. 7), and who or what is touching (Ch. 4): hand / non-hand classification and hand-part
//! segmentation by ONNX models run in tract (feature `onnx`), the synthetic data they are trained
//! on, their datasets, metrics and evaluation.
//!
//! The per-frame runtime those models serve (the session, touch tracking, events, sinks, the
//! `HandClassifier` and `PartSegmenter` traits) is skin-runtime's, which a robot stack can link
//! alone; skin-learn re-exports its modules at the paths they had here ([`session`], [`touch`],
//! [`model`], [`parts`], [`script`], [`card`]: one definition, two paths) and adds
//! [`session::FromConfig`]: `Session::from_config` opens the models a `run.toml` names with tract
//! ([`session::TractRuntime`]). Code written against `skin_learn::session` keeps compiling once
//! it imports `FromConfig` for `from_config`. A robot stack's loop, frames in and events out, is
//! the example on skin-runtime's first page; with the shipped models:
//!
//! ```no_run
//! use skin_learn::session::{Event, FromConfig, Session, SessionConfig};
//!
//! let config = SessionConfig::read("fixtures/session/run.toml".as_ref())?;
//! let mut session = Session::from_config(&config)?; // layout, bus map, models, maps (cached)
//! let path = std::path::Path::new("fixtures/session/session.candump.log");
//! let log = skin_can::candump::CandumpLog::read(path)?;
//! let mut events: Vec<Event> = Vec::new();
//! session.run_log(&log, path, &mut events, &mut |_, _| {})?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! Calibration fits each taxel from a probe's presses. A simulated probe on a flat patch gives
//! every taxel back within a millimetre (0.2 mm on average; the thesis' bound on a real patch is
//! 1.9 mm):
//!
//! ```
//! use nalgebra::{Point3, Unit, Vector3};
//! use skin_core::{LinkSkin, Taxel, TaxelId};
//! use skin_learn::calibration::{CalibrationErrors, CalibrationOptions, ProbeSimulator, calibrate};
//!
//! // 25 taxels, 8 mm apart.
//! let taxels = (0..25u32)
//!     .map(|i| Taxel {
//!         id: TaxelId(i),
//!         position: Point3::new(f64::from(i % 5) * 0.008, f64::from(i / 5) * 0.008, 0.0),
//!         normal: Unit::new_normalize(Vector3::z()),
//!     })
//!     .collect();
//! let patch = LinkSkin::new("patch", taxels);
//! let presses = ProbeSimulator::default().run(&patch, 300, 1);
//! let report = calibrate(&presses, &CalibrationOptions::default());
//! let errors = CalibrationErrors::compare(&report, &patch);
//! assert!(errors.compared == 25 && errors.max_mm < 1.0, "{errors:?}");
//! ```
//!
//! - [`calibration`]: where each taxel sits, fitted from a probe pressing the skin (thesis Ch. 7):
//!   probe datasets and their CSV form, the per-taxel Gaussian fit, a probe simulator, and the
//!   error metrics and convergence curve of the thesis. Example:
//!   `examples/examples/calibrate_patch.rs`.
//! - `classify` (feature `onnx`): tactile image classification (hand / non-hand, HandsNet,
//!   Ch. 4.3) with any ONNX classifier of grey images, run by tract; `segment` (feature `onnx`):
//!   hand-part segmentation (Ch. 4.4) the same way. [`card`]: the model card beside a model.
//!   `tract_plan` (feature `onnx`): how both plan a model for tract, with the project's own
//!   operators: `direct_conv` (x86-64), a convolution without tract's patch matrix, and
//!   `max_pool`, the vectorised 2 x 2 max-pool.
//! - [`metrics`]: confusion matrices, accuracy, and the segmentation scores of Table 4.8;
//!   [`segmentation_diagnostics`]: where a segmenter goes wrong (seams, misnamed parts, mirror).
//! - [`synth`]: labelled synthetic contacts (hands of many subjects in the actions of Ch. 4.5,
//!   objects and other body parts) imaged by the real pipeline, with hand-part masks; and
//!   [`synth::arm`], the thesis' full arm (three links, a hand held on the middle one) that the
//!   benches time the per-frame path on.
//! - [`session`], [`touch`], [`model`], [`parts`], [`script`], [`card`]: skin-runtime's, re-exported;
//!   [`session::FromConfig`] and [`session::TractRuntime`] are skin-learn's own.
//! - `evaluation` (feature `onnx`): a model's scores on a dataset (Tables 4.3-4.9) and the
//!   robustness study of Ch. 5 (Test A: blind spots; Test B: removed taxels).
//! - [`dataset`]: the on-disk dataset layout that `skin synth` writes and `skin eval` reads.
//! - [`Error`]: every error of the crate in one type, for `?` in a robot stack's code.

pub mod calibration;
#[cfg(feature = "onnx")]
pub mod classify;
pub mod dataset;
mod error;
#[cfg(feature = "onnx")]
pub mod evaluation;
pub mod force_calibration;
#[cfg(feature = "onnx")]
mod image_model;
// The 2 x 2 max-pool sits with the other operators of the tract plan; its path stays.
#[cfg(feature = "onnx")]
pub use tract_plan::max_pool;
pub mod metrics;
#[cfg(feature = "onnx")]
pub mod segment;
pub mod segmentation_diagnostics;
pub mod session;
pub mod synth;
#[cfg(feature = "onnx")]
pub mod tract_plan;

pub use error::{Error, Result};
// The runtime's modules, at the paths they had here before skin-runtime held them: one
// definition, two paths.
pub use skin_runtime::{card, model, parts, script, touch};
