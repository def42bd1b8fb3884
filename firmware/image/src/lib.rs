//! Entry layer shared by the soft-core images (`app`, `bootloader`): board constants and
//! console, RISC-V counters, the co-processor link of each board with its stage clock, the
//! UART loop, and the panic / trap handlers.
//!
//! Everything device-independent lives in the host-testable `gridrt-firmware` library;
//! this crate only knows addresses, CSRs and the riscv-rt runtime.
#![no_std]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, missing_docs)]
// UART bytes and FSL words pass through here (`serve`, `link`): no indexing or unchecked
// arithmetic, as in the firmware library's link-facing modules.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

pub mod board;
pub mod counters;
#[cfg(feature = "board-litex")]
pub mod harts;
pub mod link;
#[cfg(feature = "board-litex")]
pub mod litex_map;
pub mod serve;
pub mod trap;

/// Version of the images, printed in the banner.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// Halts the hart for good: interrupts stay as they are, `wfi` just saves power.
pub fn halt() -> ! {
    loop {
        riscv::asm::wfi();
    }
}
