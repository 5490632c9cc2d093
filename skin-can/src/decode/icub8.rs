//! `icub8`, the iCub skin's periodic message (robotology firmware, skin boards).
//!
//! - Identifier: (class << 8) | (board << 4) | triangle, standard 11-bit, class 4 (3 on older
//!   firmware). The bus map's `address` is board << 4 | triangle.
//! - Two 8-byte frames per 12-taxel triangle: `[0x40, t0 .. t6]` then
//!   `[0xC0, t7 .. t11, oor >> 4, (oor & 0xF) << 4 | err]`: a 12-bit out-of-range mask and error
//!   bits (bit 0 no acknowledge, bit 1 not connected).
//! - Values are 8-bit, 255 = no load; pressure rises as the value falls. They are passed on as on
//!   the wire (no inversion).
//! - No sync frame: boards free-run at about 40-50 ms, so frames are grouped by time window.

use super::{Decoded, Decoder};
use crate::candump::CanFrame;

/// The `icub8` decoder; accepts class 4 and the legacy class 3.
#[derive(Debug, Clone, Copy, Default)]
pub struct Icub8;

impl Decoder for Icub8 {
    fn decode(&mut self, f: &CanFrame) -> Decoded {
        if f.extended || f.remote {
            return Decoded::Ignored;
        }
        let class = f.id >> 8;
        if class != 4 && class != 3 {
            return Decoded::Ignored;
        }
        let d = f.data();
        if d.len() != 8 {
            return Decoded::Malformed("iCub skin frame without 8 bytes");
        }
        let address = f.id & 0xFF;
        let mut values = [0u16; 8];
        match d[0] {
            0x40 => {
                for (v, &b) in values.iter_mut().zip(&d[1..8]) {
                    *v = u16::from(b);
                }
                Decoded::Values {
                    address,
                    first_slot: 0,
                    count: 7,
                    values,
                }
            }
            0xC0 => {
                for (v, &b) in values.iter_mut().zip(&d[1..6]) {
                    *v = u16::from(b);
                }
                Decoded::Values {
                    address,
                    first_slot: 7,
                    count: 5,
                    values,
                }
            }
            _ => Decoded::Malformed("iCub skin frame whose first byte is neither 0x40 nor 0xC0"),
        }
    }
}

/// Out-of-range mask (12 bits, bit k = taxel k) and error bits of a second (0xC0) frame.
pub fn status(f: &CanFrame) -> Option<(u16, u8)> {
    let d = f.data();
    (d.len() == 8 && d[0] == 0xC0).then(|| ((u16::from(d[6]) << 4) | u16::from(d[7] >> 4), d[7] & 0x0F))
}

/// The two frames of one triangle (for writers and tests).
pub fn encode_triangle(
    address: u32,
    readings: &[u8; 12],
    oor: u16,
    err: u8,
    time_us: u64,
    bus: u16,
) -> [CanFrame; 2] {
    let frame = |bytes: [u8; 8]| CanFrame {
        time_us,
        bus,
        id: (4 << 8) | (address & 0xFF),
        extended: false,
        remote: false,
        len: 8,
        bytes,
        direction: None,
    };
    let mut a = [0x40u8; 8];
    a[1..8].copy_from_slice(&readings[..7]);
    let mut b = [0xC0u8; 8];
    b[1..6].copy_from_slice(&readings[7..]);
    b[6] = (oor >> 4) as u8;
    b[7] = ((oor & 0xF) as u8) << 4 | (err & 0xF);
    [frame(a), frame(b)]
}
