//! # skin-can: robot skin acquisition over CAN
//!
//! Planned: wire decoders, sync-delimited snapshot assembly with completeness per module, candump
//! record and replay, and live SocketCAN buses (thesis App. A). Nothing is implemented yet.
