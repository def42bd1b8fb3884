//! The bootloader image.
//!
//! Phase 1 only: it proves that a second image builds and boots with the same entry layer
//! (banner, trap reports). Loading an application image over the console is phase 2 and
//! is NOT implemented; until then it reports that and halts.
#![no_std]
#![no_main]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use core::fmt::Write as _;
use gridrt_firmware::bsp::{ByteUart, UartWriter};
use gridrt_firmware_image::{board, halt, VERSION};

#[riscv_rt::entry]
fn main() -> ! {
    // SAFETY: the only console owner; trap/panic reports alias it only once we stop.
    let mut console = unsafe { board::take_console() };
    let _ = writeln!(
        UartWriter(&mut console),
        "gridrt bootloader {VERSION} on {}\r",
        board::NAME
    );
    let _ = writeln!(
        UartWriter(&mut console),
        "bootloader: image loading not implemented yet; halted\r"
    );
    let _ = nb::block!(console.flush());
    halt()
}
