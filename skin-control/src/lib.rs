//! # skin-control: skin-driven robot control
//!
//! Each control cycle, the skin's contacts (per link: where, which way, how hard) become tasks,
//! and a stack of tasks becomes joint velocities:
//!
//! ```text
//! contacts per link --contact_tasks (Eq. 8.13-8.17)--> one task per touched link, activation by force
//!                   --hri (Ch. 9.2), through a ContactGate--> one interaction task, when a hand may lead
//! goal --ReachGoal (Eq. 8.18-8.26)--> reaching, in the null space of the contact tasks
//! tasks --TaskStack (App. D)--> joint velocities
//! ```
//! [`SkinController`] runs that cycle for a [`Chain`] read from URDF. A hand classifier decides
//! through [`hri::ClassGate`] whether contacts may lead the arm. A 2-joint arm whose forearm is
//! pushed moves away from the push:
//!
//! ```
//! use nalgebra::{Point3, Unit, Vector3};
//! use skin_control::contact_tasks::{Contact, Gains};
//! use skin_control::{Chain, LinkContacts, Regularisation, SkinController};
//!
//! let urdf = r#"<robot name="arm">
//!   <link name="base"/><link name="upper"/><link name="fore"/><link name="tool"/>
//!   <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
//!     <origin xyz="0 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
//!   <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
//!     <origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
//!   <joint name="wrist" type="fixed"><parent link="fore"/><child link="tool"/><origin xyz="0.3 0 0" rpy="0 0 0"/></joint>
//! </robot>"#;
//! let chain = Chain::from_urdf_str(urdf, "base", "tool")?;
//! let mut controller = SkinController::new(chain, "tool", Regularisation::default(), Gains::default(), 15.0)?;
//! // The forearm (along x at q = 0) is pushed from +y, 10 N at 0.15 m along it.
//! let q = [0.0, 0.0];
//! let push = LinkContacts {
//!     link: "fore".into(),
//!     contacts: vec![Contact {
//!         point: Point3::new(0.45, 0.0, 0.0),
//!         normal: Unit::new_normalize(Vector3::y()),
//!         force: 10.0,
//!         stiffness: 2000.0,
//!     }],
//! };
//! let qdot = controller.step(&q, &[push], None)?;
//! // Both joints turn the arm away from the push (towards -y: clockwise about z).
//! assert!(qdot[0] < 0.0 && qdot.iter().all(|v| v.is_finite()));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! - [`approach_press`]: the probe controller of the self-touch calibration (thesis Ch. 7.2.3):
//!   align above a target, approach along its normal until the skin reports contact, then hold
//!   the tangent position while regulating the normal force (hybrid position/force control).
//!
//! - `task_stack`: the task-priority solver with activations (thesis App. D), with damped and
//!   activation-aware regularised pseudo-inverses, so tasks fade in and out continuously.
//!   Example: `examples/examples/task_stack.rs`.
//!
//! - [`contact_tasks`]: the skin's tasks of Ch. 8.4, contact-force minimisation per link
//!   (Eq. 8.13-8.17) with its activation, and reaching in the null space of the end-effector's
//!   contact task (Eq. 8.18-8.26).
//! - `controller`: one control cycle, [`SkinController`]: contact tasks of every touched link and
//!   the reaching task, sorted by contact force, solved into joint velocities; optionally a
//!   [`ForceGuard`] that slows the reach as a contact force nears F_thresh (not in the thesis).
//! - [`escape`]: a way out of the local minima between obstacles (not in the thesis): when the
//!   hand stops getting closer, a via point across the obstacle that holds it.
//! - [`hri`]: the physical human-robot interaction tasks of Ch. 9.2 (move along a push, turn a
//!   held link, bend a joint), triggered by skin contacts through a [`hri::ContactGate`].
//! - `kinematics`: a serial [`Chain`] from URDF, forward kinematics and geometric Jacobians.
//! - [`path_following`]: follow a polyline at a constant speed (the low-priority task of the
//!   interaction experiment, Ch. 9.3).
//! - `sim` (feature `sim`): a headless, deterministic world (skin-covered capsule links, padded
//!   obstacles, the spring contact model of Eq. 8.1) and the thesis' experiments in it: reaching
//!   through clutter (Ch. 8.5) and physical interaction (Ch. 9.3). Example:
//!   `examples/examples/reach_through_clutter.rs`.

pub mod approach_press;
pub mod contact_tasks;
mod controller;
pub mod escape;
pub mod hri;
mod kinematics;
pub mod path_following;
#[cfg(feature = "sim")]
pub mod sim;
mod task_stack;

pub use controller::{ForceGuard, JOINT_LIMIT_MARGIN, LinkContacts, ReachGoal, SkinController};
pub use kinematics::{Chain, ChainJoint, JointKind, KinematicsError, Posture};
pub use task_stack::{Regularisation, StackError, Task, TaskStack, pseudo_inverse};
