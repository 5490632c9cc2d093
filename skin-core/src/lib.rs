//! # skin-core: the data model of a robot skin
//!
//! A robot skin is a set of pressure sensors (taxels) glued over the links of a robot. This crate
//! holds what every other `skin` crate agrees on, with no heavy dependency:
//!
//! - [`Taxel`]: one sensor, with its [`TaxelId`], its position and outward normal in the frame of the
//!   link it is glued to (metres);
//! - [`LinkSkin`]: the taxels of one link, optionally with triangles between them;
//! - [`SkinLayout`]: the skins of all links of a robot;
//! - [`Frame`] and [`Recording`]: synchronous snapshots of one value per taxel, in layout order;
//! - [`Baseline`]: raw readings to pressures, per-taxel noise thresholds, drift tracking, and the
//!   dead or stuck taxels found while learning it;
//! - [`ContactFinder`] and [`Contact`]: the connected patches of pressed taxels in a frame;
//! - [`force`]: newtons from counts (a response curve, per-taxel gains and areas) and a link's
//!   [`Wrench`](force::Wrench);
//! - [`image`]: tactile images as the crates hand them to each other (one size type with its
//!   parser and limit, a borrowed row-major view).
//!
//! In a frame's path (ARCHITECTURE.md at the repository's root) this crate is the step after
//! acquisition: readings in layout order become pressures through the [`Baseline`], and pressures
//! become contacts, which skin-learn tracks into touches.
//!
//! [`output`] writes a user's outputs without putting their files at risk: an input is never
//! overwritten, files and folders are built aside and moved into place when complete, a folder
//! holding other files is left alone.
//!
//! File formats live in [`format`]: the project's own JSON layout, Cyskin calibration JSON (read and
//! write), iCub `positions/*.txt` taxel files, and Cyskin raw recordings (read and write).
//!
//! ```
//! use skin_core::format::native;
//!
//! let json = r#"{
//!   "format": "skin-layout/1", "units": "m",
//!   "links": [{ "name": "patch", "taxels": [
//!     { "id": 16, "position": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0] },
//!     { "id": 17, "position": [0.008, 0.0, 0.0], "normal": [0.0, 0.0, 1.0] },
//!     { "id": 18, "position": [0.0, 0.008, 0.0], "normal": [0.0, 0.0, 1.0] }
//!   ], "faces": [[0, 1, 2]] }]
//! }"#;
//! let layout = native::parse_layout(json, "example.json".as_ref())?;
//! assert_eq!(layout.links[0].taxels.len(), 3);
//! assert_eq!(layout.links[0].taxels[1].id.module(), 1);
//! # Ok::<(), skin_core::Error>(())
//! ```
//!
//! Units: metres for positions, unit vectors for normals, seconds for times. Pressure values are
//! whatever the sensor reports (raw capacitance counts for Cyskin) unless a crate says otherwise.

mod baseline;
mod by_name;
mod contact;
mod contact_peaks;
mod error;
pub mod force;
pub mod format;
mod frame;
pub mod image;
mod layout;
pub mod normals;
pub mod output;
mod taxel;
pub mod text;

pub use baseline::{
    Baseline, BaselineLearner, BaselineOptions, IdleStats, Polarity, TaxelHealth, UnknownPolarity,
};
pub use contact::{Contact, ContactFinder};
pub use contact_peaks::Separation;
pub use error::{Error, Result};
pub use frame::{Columns, Frame, Recording};
pub use layout::{LinkSkin, SkinLayout};
pub use taxel::{Taxel, TaxelId};

/// Re-exported so users name the same `nalgebra` version as this crate.
pub use nalgebra;
