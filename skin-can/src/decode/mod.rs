//! Wire decoders: one CAN frame in, what it means for the skin out.
//!
//! A [`Decoder`] knows a wire format and nothing else (no bus map, no time): adding a hardware
//! format is implementing this trait.

pub mod icub8;
pub mod skin16;

pub use icub8::Icub8;
pub use skin16::Skin16;

use crate::candump::CanFrame;

/// What one CAN frame says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decoded {
    /// The start of an acquisition cycle; `counter` is the cycle number modulo 256.
    Sync {
        /// Cycle counter.
        counter: u8,
    },
    /// Readings of consecutive slots of one module.
    Values {
        /// Module address on its bus (the bus map's `address`).
        address: u32,
        /// Slot of `values[0]` (0..12).
        first_slot: u8,
        /// Number of values (1..=8).
        count: u8,
        /// Raw readings as on the wire.
        values: [u16; 8],
    },
    /// A frame of another protocol sharing the bus.
    Ignored,
    /// A frame in this format's id range whose content is wrong; the text says what.
    Malformed(&'static str),
}

/// A wire format.
pub trait Decoder {
    /// Decodes one frame.
    fn decode(&mut self, frame: &CanFrame) -> Decoded;
}

impl<D: Decoder + ?Sized> Decoder for Box<D> {
    fn decode(&mut self, frame: &CanFrame) -> Decoded {
        (**self).decode(frame)
    }
}

/// The decoder of a bus map's wire format.
pub fn for_format(format: crate::WireFormat) -> Box<dyn Decoder + Send> {
    match format {
        crate::WireFormat::Skin16 => Box::new(Skin16),
        crate::WireFormat::Icub8 => Box::new(Icub8),
    }
}
