//! # skin-control: skin-driven prioritized robot control
//!
//! Planned: the task-priority solver with activations (thesis App. D), contact, reach and physical
//! human-robot interaction tasks (Ch. 8, 9), and kinematics from URDF. Nothing is implemented yet.
