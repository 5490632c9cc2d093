use nalgebra::{Point3, Unit, Vector3};
use std::fmt;

/// The identifier of a taxel, as the skin electronics report it.
///
/// Cyskin numbers a taxel `module << 4 | index`: the module (a triangular board) in the high bits
/// and the channel (0..=11) in the low four bits. iCub files have no ids; their readers use the row
/// index. Any `u32` is accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize)]
#[serde(transparent)]
pub struct TaxelId(pub u32);

impl TaxelId {
    /// The Cyskin module number (`id >> 4`).
    pub fn module(self) -> u32 {
        self.0 >> 4
    }

    /// The Cyskin channel within its module (`id & 0xF`).
    pub fn channel(self) -> u32 {
        self.0 & 0xF
    }

    /// The id of channel `channel` (0..=15) of Cyskin module `module`.
    pub fn cyskin(module: u32, channel: u32) -> Self {
        TaxelId(module << 4 | (channel & 0xF))
    }

    /// Ids from here up are placeholders: taxels without a known sensor.
    const PLACEHOLDER_BASE: u32 = 0xFFFF_0000;

    /// The `k`-th placeholder id (`k` below 65,536): an id of its own for a taxel whose file
    /// gives none that tells it apart (Cyskin files repeat 0 or 1 on mesh vertices without a
    /// known sensor). No recording column or bus slot carries it, so the taxel is dead. Ids
    /// count down from `u32::MAX`, far above any id the electronics report (Cyskin module
    /// numbers reach 2^16 at most).
    pub fn placeholder(k: u16) -> Self {
        TaxelId(u32::MAX - u32::from(k))
    }

    /// Whether this is a [`placeholder`](Self::placeholder) id.
    pub fn is_placeholder(self) -> bool {
        self.0 >= Self::PLACEHOLDER_BASE
    }
}

impl fmt::Display for TaxelId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// One pressure sensor on a link.
#[derive(Debug, Clone, PartialEq)]
pub struct Taxel {
    /// Identifier reported by the electronics.
    pub id: TaxelId,
    /// Centre of the sensing pad in the link frame, metres.
    pub position: Point3<f64>,
    /// Outward unit normal of the skin at the taxel, in the link frame.
    pub normal: Unit<Vector3<f64>>,
}
