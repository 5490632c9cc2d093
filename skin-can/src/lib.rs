//! # skin-can: robot skin acquisition over CAN
//!
//! A skin answers over one or more CAN buses; this crate turns that traffic into frames. So far it
//! reads and writes **candump logs** ([`candump`]), the text format of can-utils' `candump -l` and
//! python-can's `CanutilsLogWriter`, which is how skin traffic is recorded and replayed:
//!
//! ```
//! use skin_can::candump::CandumpLog;
//!
//! let text = "(1700000000.000000) can0 080#05\n(1700000000.000150) can0 201#E803D007B80BA00F\n";
//! let log = CandumpLog::parse(text, "session.log".as_ref())?;
//! assert_eq!(log.interfaces, ["can0"]);
//! assert_eq!(log.frames[1].id, 0x201);
//! assert_eq!(log.frames[1].data(), &[0xE8, 0x03, 0xD0, 0x07, 0xB8, 0x0B, 0xA0, 0x0F]);
//! assert_eq!(log.to_text(), text); // byte for byte
//! # Ok::<(), skin_can::Error>(())
//! ```
//!
//! Planned (thesis App. A): the `skin16` and iCub wire decoders, bus maps, sync-delimited snapshot
//! assembly with completeness per module, and live SocketCAN input.

pub mod candump;
mod error;

pub use error::{Error, Result};
