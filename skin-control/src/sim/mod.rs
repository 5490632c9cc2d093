//! Headless, deterministic simulations of a skin-covered arm (feature `sim`).
//!
//! - [`scene`]: the JSON scene format (obstacles, goals, starting postures) and the default
//!   scene modelled on the thesis' Fig. 8.4.
//! - [`world`]: the arm's links as skin-covered capsules, obstacles as padded solids, contact
//!   forces by the linear spring model of Eq. 8.1, collision queries by parry.
//! - [`reach`]: the reach-through-clutter experiment of Ch. 8.5, one trial at a time.
//! - [`stats`]: its tables (Tables 8.1 and 8.2) with 95% confidence intervals.
//! - [`phri`]: Experiment 2 of Ch. 9.3: path following, an accidental bump the gate ignores, a
//!   hand push that takes over; its timeline in words, as CSV and (feature `plot`) as SVG.

pub mod phri;
mod phri_report;
pub mod reach;
pub mod scene;
pub mod stats;
pub mod world;

#[cfg(feature = "plot")]
pub use phri_report::PlotError;
pub use phri_report::{PHRI_CSV_HEADER, PhriReport};
pub use reach::{Outcome, ReachExperiment, ReachOptions, Trial};
pub use scene::{Obstacle, Scene, SceneError};
pub use world::{Sensing, Solid, World};
