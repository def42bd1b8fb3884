//! The application image: banner, counter readings, then a byte echo over the console.
//!
//! Phase 1 of "Real soft-core firmware": the device loop of `gridrt-firmware` (frames in,
//! pixels out over the FSL link) replaces the echo once it is wired in.
#![no_std]
#![no_main]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use core::fmt::Write as _;
use gridrt_firmware::bsp::{ByteUart, CycleCounter, UartWriter};
use gridrt_firmware_image::{board, counters::CsrCounters, VERSION};

#[riscv_rt::entry]
fn main() -> ! {
    let counters = CsrCounters;
    let (cycles0, instret0) = (counters.cycles(), counters.instret());
    // SAFETY: the only console owner; trap/panic reports alias it only once we stop.
    let mut console = unsafe { board::take_console() };

    // Console output is best effort: a UART transmit cannot fail on these boards.
    let _ = writeln!(
        UartWriter(&mut console),
        "gridrt firmware {VERSION} on {}\r",
        board::NAME
    );
    let (cycles1, instret1) = (counters.cycles(), counters.instret());
    let _ = writeln!(
        UartWriter(&mut console),
        "mcycle={cycles1} minstret={instret1} (banner: {} cycles, {} instructions)\r",
        cycles1.wrapping_sub(cycles0),
        instret1.wrapping_sub(instret0),
    );

    #[cfg(feature = "trap-test")]
    {
        let _ = writeln!(
            UartWriter(&mut console),
            "trap-test: executing an illegal instruction\r"
        );
        // SAFETY: deliberately traps; the exception handler reports and halts.
        // 0xc0001073 is `csrrw x0, cycle, x0` (a write to a read-only CSR), the 32-bit
        // canonical illegal instruction; mtval then shows its bits.
        unsafe { core::arch::asm!(".4byte 0xc0001073") };
    }
    #[allow(clippy::panic)]
    if cfg!(feature = "panic-test") {
        panic!("panic-test feature");
    }

    let _ = writeln!(UartWriter(&mut console), "echo: ready\r");
    loop {
        match console.read_byte() {
            Ok(byte) => {
                let _ = console.write_all(&[byte]);
            }
            Err(nb::Error::WouldBlock) => {}
            Err(nb::Error::Other(e)) => {
                let _ = writeln!(UartWriter(&mut console), "\r\necho: receive error: {e}\r");
            }
        }
    }
}
