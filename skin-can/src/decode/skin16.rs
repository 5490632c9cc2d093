//! `skin16`, the project's 16-bit wire format.
//!
//! - Sync: standard id 0x080, one data byte: the cycle counter modulo 256. The master sends it on
//!   every bus at the start of each period (50 ms for Cyskin hubs); all modules then convert.
//! - Module data: 12 taxels as u16 little-endian in three 8-byte frames with standard id
//!   0x200 | (module_on_bus << 2) | chunk; chunk 0, 1, 2 carries taxels 4 chunk .. 4 chunk + 3.
//!   At most 128 modules per bus (ids 0x200..=0x3FE).
//!
//! Taxel ids follow the Cyskin convention, module_id << 4 | index, through the bus map.

use super::{Decoded, Decoder};
use crate::candump::CanFrame;

/// Standard id of the sync frame.
pub const SYNC_ID: u32 = 0x080;
/// First standard id of module data.
pub const DATA_BASE: u32 = 0x200;

/// The `skin16` decoder (stateless).
#[derive(Debug, Clone, Copy, Default)]
pub struct Skin16;

impl Decoder for Skin16 {
    fn decode(&mut self, f: &CanFrame) -> Decoded {
        if f.extended || f.remote {
            return Decoded::Ignored;
        }
        if f.id == SYNC_ID {
            return match f.data() {
                [counter] => Decoded::Sync { counter: *counter },
                _ => Decoded::Malformed("sync frame without exactly one byte"),
            };
        }
        if !(DATA_BASE..DATA_BASE + 0x200).contains(&f.id) {
            return Decoded::Ignored;
        }
        let chunk = (f.id & 3) as u8;
        if chunk == 3 {
            return Decoded::Malformed("data frame with chunk 3 (only 0..2 exist)");
        }
        let d = f.data();
        if d.len() != 8 {
            return Decoded::Malformed("data frame without 8 bytes");
        }
        let mut values = [0u16; 8];
        for (k, v) in values.iter_mut().take(4).enumerate() {
            *v = u16::from_le_bytes([d[2 * k], d[2 * k + 1]]);
        }
        Decoded::Values {
            address: (f.id - DATA_BASE) >> 2,
            first_slot: 4 * chunk,
            count: 4,
            values,
        }
    }
}

/// The three frames that carry a module's 12 readings (for writers and tests).
pub fn encode_module(module_on_bus: u32, readings: &[u16; 12], time_us: u64, bus: u16) -> [CanFrame; 3] {
    [0u32, 1, 2].map(|chunk| {
        let mut bytes = [0u8; 8];
        for k in 0..4 {
            bytes[2 * k..2 * k + 2].copy_from_slice(&readings[4 * chunk as usize + k].to_le_bytes());
        }
        CanFrame {
            time_us,
            bus,
            id: DATA_BASE | (module_on_bus << 2) | chunk,
            extended: false,
            remote: false,
            len: 8,
            bytes,
            direction: None,
        }
    })
}

/// The sync frame for cycle `counter`.
pub fn encode_sync(counter: u8, time_us: u64, bus: u16) -> CanFrame {
    let mut bytes = [0u8; 8];
    bytes[0] = counter;
    CanFrame {
        time_us,
        bus,
        id: SYNC_ID,
        extended: false,
        remote: false,
        len: 1,
        bytes,
        direction: None,
    }
}
