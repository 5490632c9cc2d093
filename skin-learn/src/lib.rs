//! # skin-learn: touch understanding for robot skin
//!
//! What the skin's pressures mean: where each taxel sits (calibration, Ch. 7), and who or what is
//! touching (Ch. 4). Per frame, the touch path is:
//!
//! ```text
//! pressures per link --ContactFinder--> contacts --touch tracking--> touches (appeared, released)
//!   fullest image of a touch --HandClassifier--> hand / non-hand --PartSegmenter--> hand parts
//! ```
//! ([`touch`]; the models behind the traits of [`model`], HandsNet and the shipped segmenter
//! run by tract with feature `onnx`), scored against a script of touches with [`script`].
//!
//! [`session`] is that whole path as one value, built once from `skin run`'s configuration or
//! from code. A robot stack's loop, frames in and events out (without models here: touches are
//! tracked, not classified):
//!
//! ```
//! use skin_core::{LinkSkin, Taxel, TaxelId};
//! use skin_geom::{FlattenOptions, TactileMap};
//! use skin_learn::model::Models;
//! use skin_learn::session::{Event, Session, SessionOptions};
//! use skin_learn::touch::{TouchOptions, TouchPipeline};
//! use nalgebra::{Point3, Unit, Vector3};
//!
//! // A 10 x 10 patch of taxels 5 mm apart, and its tactile map.
//! let taxels = (0..100u32).map(|i| Taxel {
//!     id: TaxelId(i),
//!     position: Point3::new(f64::from(i % 10) * 0.005, f64::from(i / 10) * 0.005, 0.0),
//!     normal: Unit::new_normalize(Vector3::z()),
//! }).collect();
//! let patch = LinkSkin::new("patch", taxels);
//! let map = TactileMap::flatten(&patch, &FlattenOptions::default())?;
//! let options = TouchOptions { threshold: 5.0, ..TouchOptions::default() };
//! let pipeline = TouchPipeline::new(vec![map], Models::none(), options)?;
//! let mut session = Session::new(vec![patch], pipeline, SessionOptions::default())?;
//!
//! // 50 Hz frames: 20 untouched ones teach the baseline, then a press on four taxels.
//! let mut events: Vec<Event> = Vec::new();
//! for k in 0..40u64 {
//!     let mut readings = vec![100.0f32; 100];
//!     if (25..30).contains(&k) {
//!         for i in [44, 45, 54, 55] { readings[i] = 180.0; }
//!     }
//!     session.push(k * 20_000, k, &[readings], &mut events)?;
//! }
//! session.finish(&mut events)?;
//! let appeared = events.iter().filter(|e| matches!(e, Event::Appeared { .. })).count();
//! let released: Vec<_> = events.iter().filter_map(|e| match e {
//!     Event::Released { touch, .. } => Some(((touch.duration * 1e3).round(), touch.peak.taxels)),
//!     _ => None,
//! }).collect();
//! // Pressed in 5 frames: 80 ms from the first to the last, 4 taxels at the peak.
//! assert_eq!((appeared, released), (1, vec![(80.0, 4)]));
//! assert_eq!(session.stats().touches, 1);
//! # Ok::<(), skin_learn::Error>(())
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
//! - [`parts`]: per-part contact properties after segmentation (Fig. 4.9).
//! - [`script`]: scoring a run against a script of touches (found, right class, extra).
//! - [`synth`]: labelled synthetic contacts (hands of many subjects in the actions of Ch. 4.5,
//!   objects and other body parts) imaged by the real pipeline, with hand-part masks.
//! - [`model`]: what the touch path asks of its models ([`model::HandClassifier`],
//!   [`model::PartSegmenter`]), the classes a model card names, and the bundle a pipeline takes.
//! - [`session`]: the whole per-frame runtime (CAN frames or readings in, typed events out,
//!   sinks that write them), what `skin run` drives; its models need feature `onnx` or are
//!   brought by the caller.
//! - [`touch`]: the per-frame path of a whole skin, from pressures to contacts,
//!   touches and their hand / non-hand decisions and hand parts (what `skin run` drives; a
//!   complete example: `examples/examples/classify_touch.rs`).
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
