//! Register map of the worker harts' block in the LiteX SoC (`soc/gridrt_soc/harts.py`,
//! class `GridrtHarts`), 32-bit CSRs. The image crate checks these offsets at compile time
//! against the SoC's csr.json export (`litex_map.rs`).

/// 0x00, read: harts of this build, the first included (bits 7:0).
pub const COUNT: usize = 0x00;
/// 0x04, read/write: the workers' reset vector.
pub const ENTRY: usize = 0x04;
/// 0x08, read/write: bit 0 set, the workers run; clear, they are held in reset.
pub const RUN: usize = 0x08;
/// 0x0C, read/write, written by the first hart only: the worker's job ([`super::Job`]).
pub const JOB: usize = 0x0C;
/// 0x10, read/write, written by the first hart only: the worker's rows it has sent.
pub const TAKEN: usize = 0x10;
/// 0x14, read/write, written by the worker only: its progress ([`super::Done`]).
pub const DONE: usize = 0x14;
