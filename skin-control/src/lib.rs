//! # skin-control: skin-driven robot control
//!
//! - [`approach_press`]: the probe controller of the self-touch calibration (thesis Ch. 7.2.3):
//!   align above a target, approach along its normal until the skin reports contact, then hold
//!   the tangent position while regulating the normal force (hybrid position/force control).
//!
//! - [`task_stack`]: the task-priority solver with activations (thesis App. D), with damped and
//!   activation-aware regularised pseudo-inverses, so tasks fade in and out continuously.
//!   Example: `examples/examples/task_stack.rs`.
//!
//! - [`contact_tasks`]: the skin's tasks of Ch. 8.4, contact-force minimisation per link
//!   (Eq. 8.13-8.17) with its activation, and reaching in the null space of the end-effector's
//!   contact task (Eq. 8.18-8.26).
//! - [`controller`]: one control cycle, [`SkinController`]: contact tasks of every touched link and
//!   the reaching task, sorted by contact force, solved into joint velocities.
//! - [`hri`]: the physical human-robot interaction tasks of Ch. 9.2 (move along a push, turn a
//!   held link, bend a joint), triggered by skin contacts through a [`hri::ContactGate`].
//! - [`kinematics`]: a serial [`Chain`] from URDF, forward kinematics and geometric Jacobians.
//! - [`path_following`]: follow a polyline at a constant speed (the low-priority task of the
//!   interaction experiment, Ch. 9.3).
//! - `sim` (feature `sim`): a headless, deterministic world (skin-covered capsule links, padded
//!   obstacles, the spring contact model of Eq. 8.1) and the thesis' experiments in it: reaching
//!   through clutter (Ch. 8.5) and physical interaction (Ch. 9.3). Example:
//!   `examples/examples/reach_through_clutter.rs`.

pub mod approach_press;
pub mod contact_tasks;
pub mod controller;
pub mod hri;
pub mod kinematics;
pub mod path_following;
#[cfg(feature = "sim")]
pub mod sim;
pub mod task_stack;

pub use controller::{LinkContacts, ReachGoal, SkinController};
pub use kinematics::{Chain, KinematicsError, Posture};
pub use task_stack::{Regularisation, StackError, Task, TaskStack};
