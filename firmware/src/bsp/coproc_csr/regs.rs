//! Register map of the co-processor's CSR FIFOs in the LiteX SoC
//! (`soc/gridrt_soc/coproc.py`, class `GridrtCoprocCSR`), 32-bit CSRs. The image crate checks
//! these offsets and field positions at compile time against the SoC's csr.json export
//! (`litex_map.rs`).

/// 0x00, write: push a request word with control bit 0.
pub const REQ: usize = 0x00;
/// 0x04, write: push a request word with control bit 1 (the request's last word).
pub const REQ_LAST: usize = 0x04;
/// 0x08, read: the reply word at the FIFO head; the read pops it (0 when empty).
pub const RSP: usize = 0x08;
/// 0x0C, read: FIFO levels and flags (`STATUS_*`).
pub const STATUS: usize = 0x0C;
/// 0x10, write: `CTRL_RESET` resets the co-processor and both FIFOs.
pub const CTRL: usize = 0x10;
/// 0x14, read: processing elements of the co-processor (bits 7:0).
pub const PES: usize = 0x14;
/// 0x18, read: words of memory per PE.
pub const PE_MEM_WORDS: usize = 0x18;

/// `STATUS` bits 7:0: free request FIFO slots.
pub const STATUS_REQ_SPACE_OFFSET: u32 = 0;
/// `STATUS` bits 15:8: reply words waiting.
pub const STATUS_RSP_LEVEL_OFFSET: u32 = 8;
/// Width of the two level fields.
pub const STATUS_LEVEL_BITS: u32 = 8;
/// Mask of a level field after shifting it down.
pub const STATUS_LEVEL_MASK: u32 = (1 << STATUS_LEVEL_BITS) - 1;
/// `STATUS` bit 16: control bit of the head reply word.
pub const STATUS_RSP_LAST: u32 = 1 << 16;
/// `STATUS` bit 17: the co-processor waits for input with nothing to send.
pub const STATUS_IDLE: u32 = 1 << 17;
/// `STATUS` bit 18, sticky: a request word was pushed into a full FIFO and dropped.
pub const STATUS_REQ_OVERFLOW: u32 = 1 << 18;
/// `STATUS` bit 19, sticky: `RSP` was read with no reply waiting.
pub const STATUS_RSP_UNDERFLOW: u32 = 1 << 19;
/// `CTRL` bit 0: reset pulse.
pub const CTRL_RESET: u32 = 1 << 0;
