//! What a joint solves, how long a cycle may take, and the stitcher's settings.

use std::time::Duration;

/// What is solved at a joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointMode {
    /// Rotation and translation of the child map (Eq. 6.6 in full).
    Full,
    /// Translation only, the rotation held at `angle` (maps pre-aligned, Ch. 6.4).
    TranslationOnly {
        /// The fixed rotation of the child map relative to its parent, radians.
        angle: f64,
    },
}

/// How much time a cycle's solve may take.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Deadline {
    /// At most this many solver iterations per joint.
    Iterations(u64),
    /// At most this long per joint (checked between iterations).
    Time(Duration),
}

/// Settings of a [`Stitcher`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StitchOptions {
    /// Cross-boundary edges longer than this (3D, metres) are dropped (default 0.03, as Ch. 6.4).
    pub max_edge: f64,
    /// Boundary taxels: those within this distance (metres) of the other link at the reference
    /// posture (default 0.03).
    pub boundary_distance: f64,
    /// The solver has converged when the norm of the gradient of Eq. 6.6 (in mm^2 per mm) is under
    /// this (default 1e-2: with tens of edges, a placement within about a micrometre of the
    /// optimum).
    pub tolerance: f64,
}

impl Default for StitchOptions {
    fn default() -> Self {
        StitchOptions {
            max_edge: 0.03,
            boundary_distance: 0.03,
            tolerance: 1e-2,
        }
    }
}
