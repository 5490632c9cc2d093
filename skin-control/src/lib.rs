//! # skin-control: skin-driven robot control
//!
//! - [`approach_press`]: the probe controller of the self-touch calibration (thesis Ch. 7.2.3):
//!   align above a target, approach along its normal until the skin reports contact, then hold
//!   the tangent position while regulating the normal force (hybrid position/force control).
//!
//! - [`task_stack`]: the task-priority solver with activations (thesis App. D), with damped and
//!   activation-aware regularised pseudo-inverses, so tasks fade in and out continuously.
//!
//! - [`kinematics`]: a serial [`Chain`] from URDF, forward kinematics and geometric Jacobians.
//!
//! Planned: contact, reach and physical human-robot interaction tasks (Ch. 8, 9), and the
//! reach-through-clutter simulation.

pub mod approach_press;
pub mod kinematics;
pub mod task_stack;

pub use kinematics::{Chain, KinematicsError};
pub use task_stack::{Regularisation, StackError, Task, TaskStack};
