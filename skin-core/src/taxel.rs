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
