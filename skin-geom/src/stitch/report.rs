//! What a cycle's solve gives back.

use super::Placement;

/// One joint's result for a cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointSolve {
    /// The child map's placement relative to the parent map.
    pub placement: Placement,
    /// Eq. 6.6 at the returned placement, square metres.
    pub cost: f64,
    /// Eq. 6.6 at the start (the warm start), square metres.
    pub start_cost: f64,
    /// Solver iterations spent.
    pub iterations: u64,
    /// The solver met its tolerance before the deadline.
    pub converged: bool,
    /// Edges in E this cycle.
    pub edges: usize,
    /// No edge joined the links this cycle: the last placement was kept.
    pub kept_last: bool,
}

/// Per-link poses in, placements of every map out.
#[derive(Debug, Clone, PartialEq)]
pub struct StitchReport {
    /// Placement of every link's map in the stitched plane (link 0 at the identity).
    pub placements: Vec<Placement>,
    /// One entry per joint (joint j joins link j and link j + 1).
    pub joints: Vec<JointSolve>,
    /// The triangles across the joints this cycle (every edge under `max_edge`), each corner a
    /// (link, taxel index) pair: the skin between two links' maps, which a stitched image fills
    /// by interpolating across them.
    pub bridges: Vec<BridgeTriangle>,
}

/// A taxel of a chain of links: its link (chain order) and its index in that link's map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ChainTaxel {
    /// The link, in chain order.
    pub link: usize,
    /// The taxel's index in the link's map.
    pub taxel: usize,
}

/// A triangle of skin across a joint, its corners on the maps of two adjacent links: the skin
/// between the maps, which a stitched image fills by interpolating across it and which joins a
/// contact across the joint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BridgeTriangle {
    /// Its three corners.
    pub corners: [ChainTaxel; 3],
}

impl BridgeTriangle {
    /// The triangle of three (link, taxel index) corners.
    pub fn new(corners: [(usize, usize); 3]) -> BridgeTriangle {
        BridgeTriangle {
            corners: corners.map(|(link, taxel)| ChainTaxel { link, taxel }),
        }
    }
}

impl std::fmt::Display for BridgeTriangle {
    /// As (link, taxel) pairs: `[(0, 3), (1, 0), (0, 7)]`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, b, c] = self.corners;
        write!(
            f,
            "[({}, {}), ({}, {}), ({}, {})]",
            a.link, a.taxel, b.link, b.taxel, c.link, c.taxel
        )
    }
}
