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
//! It also decodes the project's `skin16` wire format ([`decode::Skin16`]) and assembles
//! sync-delimited snapshots of the whole skin from several buses ([`Assembler`]) through a
//! [`BusMap`], reporting per frame the modules that were missing or sent data twice.
//!
//! Planned (thesis App. A): the iCub `icub8` decoder, baselines, `skin replay`/`record`/`live`, and
//! live SocketCAN input.

mod assembler;
pub mod busmap;
pub mod candump;
pub mod decode;
mod error;

pub use assembler::{AssembledFrame, Assembler, AssemblyStats, ModuleRef};
pub use busmap::{BusMap, WireFormat};
pub use error::{Error, Result};
