//! # skin-control: skin-driven robot control
//!
//! - [`approach_press`]: the probe controller of the self-touch calibration (thesis Ch. 7.2.3):
//!   align above a target, approach along its normal until the skin reports contact, then hold
//!   the tangent position while regulating the normal force (hybrid position/force control).
//!
//! Planned: the task-priority solver with activations (thesis App. D), contact, reach and physical
//! human-robot interaction tasks (Ch. 8, 9), and kinematics from URDF.

pub mod approach_press;
