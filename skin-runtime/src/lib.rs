//! # skin-runtime: the per-frame runtime of robot skin
//!
//! What a robot stack runs at every frame, and nothing it does not: no calibration, no synthetic
//! data, no model runtime. Per frame, the touch path is:
//!
//! ```text
//! pressures per link --ContactFinder--> contacts --touch tracking--> touches (appeared, released)
//!   fullest image of a touch --HandClassifier--> hand / non-hand --PartSegmenter--> hand parts
//! ```
//! ([`touch`]; the models behind the traits of [`model`]: skin-learn runs the shipped HandsNet
//! and segmenter with tract, a robot stack may bring its own), scored against a script of
//! touches with [`script`].
//!
//! [`session`] is that whole path as one value, built once from `skin run`'s configuration
//! (skin-learn's `FromConfig` opens the models it names) or from code. A robot stack's loop,
//! frames in and events out (without models here: touches are tracked, not classified):
//!
//! ```
//! use skin_core::{LinkSkin, Taxel, TaxelId};
//! use skin_geom::{FlattenOptions, TactileMap};
//! use skin_runtime::model::Models;
//! use skin_runtime::session::{Event, Session, SessionOptions};
//! use skin_runtime::touch::{TouchOptions, TouchPipeline};
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
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! - [`session`]: the whole per-frame runtime (CAN frames or readings in, typed events out,
//!   sinks that write them), what `skin run` drives; its settings written once
//!   ([`session::SessionSettings`]: run.toml's defaults and bounds).
//! - [`touch`]: the per-frame path of a whole skin, from pressures to contacts, touches and their
//!   hand / non-hand decisions and hand parts.
//! - [`model`]: what the touch path asks of its models ([`model::HandClassifier`],
//!   [`model::PartSegmenter`]), the classes a model card names, and the bundle a pipeline takes;
//!   [`card`]: the model card beside a model.
//! - [`parts`]: per-part contact properties after segmentation (Fig. 4.9).
//! - [`script`]: scoring a run against a script of touches (found, right class, extra).

pub mod card;
pub mod model;
pub mod parts;
pub mod script;
pub mod session;
pub mod touch;
