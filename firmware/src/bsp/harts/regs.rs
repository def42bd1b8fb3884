//! Register map of the worker harts' block in the LiteX SoC (`soc/gridrt_soc/harts.py`,
//! class `GridrtHarts`), 32-bit CSRs. The image crate checks these offsets at compile time
//! against the SoC's csr.json export (`litex_map.rs`).

/// 0x00, read: harts of this build, the first included (bits 7:0).
pub const COUNT: usize = 0x00;
/// 0x04, read/write: the first worker's reset vector; worker k starts
/// [`ENTRY_STRIDE`]·(k − 1) bytes later.
pub const ENTRY: usize = 0x04;
/// 0x08, read/write: bit 0 set, the workers run; clear, they are held in reset.
pub const RUN: usize = 0x08;
/// 0x0C, read/write, written by the first hart only: the workers' job ([`super::Job`]).
pub const JOB: usize = 0x0C;
/// 0x10: a read returns the ticket counter and adds 1 to it; a write sets it (bits 15:0).
pub const TICKET: usize = 0x10;
/// 0x14, read/write, written by the first hart only: rows of the frame it has sent.
pub const SENT: usize = 0x14;
/// 0x18, read: bit s, row slot s holds a traced row not yet sent.
pub const READY: usize = 0x18;
/// 0x1C, write: sets the bits written as 1 in `READY`.
pub const READY_SET: usize = 0x1C;
/// 0x20, write: clears the bits written as 1 in `READY`.
pub const READY_CLR: usize = 0x20;
/// 0x24 + 4·(k − 1), read/write, written by worker k only: its state ([`super::Done`]).
pub const DONE1: usize = 0x24;

/// Bytes between two workers' entry points.
pub const ENTRY_STRIDE: u32 = 8;
/// Row slots `READY` tracks.
pub const SLOTS: u16 = 16;
/// Harts the block serves, the first included (workers 1..=3).
pub const MAX_HARTS: u32 = 4;
