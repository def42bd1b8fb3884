//! Register map of LiteDRAM's DFI injector (`litedram/dfii.py`, CSR block `sdram` of the
//! LiteX SoC), 32-bit CSRs, phase 0 (a 1:1 SDR PHY has one). The image crate checks these
//! offsets and field positions at compile time against the SoC's csr.json export
//! (`litex_map.rs`).

/// 0x00: who drives the DFI (`CONTROL_SEL`: the controller) and the chip's CKE, ODT and
/// RESET_N lines while software does.
pub const CONTROL: usize = 0x00;
/// 0x04: the command of the next issue (`COMMAND_*`: CS, WE, CAS, RAS as bits).
pub const PI0_COMMAND: usize = 0x04;
/// 0x08: writing 1 issues `PI0_COMMAND` with `PI0_ADDRESS` and `PI0_BADDRESS` for one cycle.
pub const PI0_COMMAND_ISSUE: usize = 0x08;
/// 0x0C: the address lines of the command.
pub const PI0_ADDRESS: usize = 0x0C;
/// 0x10: the bank address lines of the command.
pub const PI0_BADDRESS: usize = 0x10;

/// `CONTROL`: the memory controller drives the DFI (else software, through phase 0).
pub const CONTROL_SEL: u32 = 1 << 0;
/// `CONTROL`: clock enable of the chip.
pub const CONTROL_CKE: u32 = 1 << 1;
/// `CONTROL`: on-die termination.
pub const CONTROL_ODT: u32 = 1 << 2;
/// `CONTROL`: the chip's reset line, active low.
pub const CONTROL_RESET_N: u32 = 1 << 3;
/// Software control with the chip clocked and out of reset (LiteX's
/// `DFII_CONTROL_SOFTWARE`).
pub const CONTROL_SOFTWARE: u32 = CONTROL_CKE | CONTROL_ODT | CONTROL_RESET_N;
/// The controller in charge (LiteX's `DFII_CONTROL_HARDWARE`).
pub const CONTROL_HARDWARE: u32 = CONTROL_SEL;
