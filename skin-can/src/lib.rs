//! # skin-can: robot skin acquisition over CAN
//!
//! A skin answers over one or more CAN buses; this crate turns that traffic, live or recorded,
//! into frames of the whole skin, one value per taxel in the layout's order:
//!
//! ```text
//! CAN frames (live: a reader per interface | a candump log)
//!   --decode::Decoder (skin16 | icub8)--> module readings
//!   --Assembler + BusMap--> one AssembledFrame per cycle (missing / duplicate modules flagged)
//!   --LayoutFrames--> readings per link, in layout order
//! ```
//!
//! What it does not do: baselines, contacts and touches are skin-core's and skin-learn's (the
//! session takes this crate's assembled frames).
//!
//! Recorded traffic is a **candump log** ([`candump`]), the text format of can-utils'
//! `candump -l` and python-can's `CanutilsLogWriter`: read whole or streamed line by line, and
//! written back byte for byte:
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
//! It decodes two wire formats behind one [`decode::Decoder`] trait: the project's `skin16`
//! ([`decode::skin16`], 16-bit readings, broadcast sync) and the iCub skin message
//! ([`decode::icub8`], 8-bit readings, no sync). The [`Assembler`] turns the traffic of several
//! buses into one frame of the whole skin per cycle through a [`BusMap`]: per sync for `skin16`,
//! per time window for `icub8` ([`Assembler::for_map`] picks). It reports per frame the modules
//! that were missing or sent data twice: a partial frame is delivered flagged, never dropped.
//! [`LayoutFrames`] puts each assembled frame's readings into the layout's order, link by link,
//! holding a missing module's last readings (or NaN, [`Missing`]).
//!
//! Live input goes through [`live::Acquisition`]: a reader thread per interface, the `skin16` sync
//! sent when this side is bus master, an interface that goes down reported and reopened. Linux
//! SocketCAN ports come with the `socketcan` feature; any other transport implements
//! [`live::CanPort`]; [`recorder`] holds the one loop of a live run and a recorder of its
//! traffic (candump log, frames CSV, module tally); [`replay()`] runs a whole log through a bus
//! map, a frame at a time. A complete replay: `examples/examples/replay_can_log.rs`.

mod assembler;
mod busmap;
pub mod candump;
pub mod decode;
pub mod encode;
mod error;
mod layout_frames;
pub mod live;
pub mod recorder;
mod replay;
mod tally;
mod traffic;

pub use assembler::{
    AssembledFrame, Assembler, AssemblyStats, CounterReset, DEFAULT_WINDOW_US, FRAMES_CSV_HEADER, ModuleRef,
};
pub use busmap::{BusMap, BusSpec, MAX_BUSES, ModuleMap, SLOTS, SplitError, WireFormat};
pub use error::{Error, Result};
pub use layout_frames::{LayoutFrames, Missing};
pub use replay::{Replay, replay};
pub use tally::{ModuleTally, TallyReport};
pub use traffic::{Traffic, TrafficError};
