//! Board constants and the console, selected by the `board-*` feature.

#[cfg(all(feature = "board-qemu-virt", feature = "board-fpga-soc"))]
compile_error!("enable exactly one board-* feature");

#[cfg(feature = "board-qemu-virt")]
mod imp {
    use gridrt_firmware::bsp::{ns16550::Ns16550, VolatileMmio};

    /// Board name, as printed in the banner and accepted by `cargo xtask --board`.
    pub const NAME: &str = "qemu-virt";
    /// NS16550A UART of QEMU `virt`.
    pub const CONSOLE_BASE: usize = 0x1000_0000;

    /// The console UART type of this board.
    pub type Console = Ns16550<VolatileMmio>;

    /// A handle on the console registers, without touching the device.
    ///
    /// # Safety
    ///
    /// Creates an alias of the console: only use it where the owner cannot run any more
    /// (trap and panic reports), or create it once at start-up.
    pub unsafe fn console_unchecked() -> Console {
        // SAFETY: CONSOLE_BASE is the UART of this board (QEMU virt memory map).
        Ns16550::new(unsafe { VolatileMmio::new(CONSOLE_BASE) })
    }

    /// Puts the console in its polled 8N1 mode; QEMU ignores the baud divisor.
    pub fn init_console(console: &mut Console) {
        console.init(None);
    }
}

#[cfg(feature = "board-fpga-soc")]
mod imp {
    use gridrt_firmware::bsp::{uartlite::UartLite, VolatileMmio};

    /// Board name, as printed in the banner and accepted by `cargo xtask --board`.
    pub const NAME: &str = "fpga-soc";
    /// AXI UART Lite (Vivado's default address; baud rate fixed in the IP).
    pub const CONSOLE_BASE: usize = 0x4060_0000;
    /// AXI4-Stream FIFO to the co-processor (Vivado's default address).
    pub const STREAM_FIFO_BASE: usize = 0x44A0_0000;

    /// The console UART type of this board.
    pub type Console = UartLite<VolatileMmio>;

    /// A handle on the console registers, without touching the device.
    ///
    /// # Safety
    ///
    /// Creates an alias of the console: only use it where the owner cannot run any more
    /// (trap and panic reports), or create it once at start-up.
    pub unsafe fn console_unchecked() -> Console {
        // SAFETY: CONSOLE_BASE is the UART Lite of this block design (boards/fpga-soc.x).
        UartLite::new(unsafe { VolatileMmio::new(CONSOLE_BASE) })
    }

    /// Empties the console FIFOs.
    pub fn init_console(console: &mut Console) {
        console.init();
    }
}

pub use imp::*;

/// Takes the console at start-up and initialises it.
///
/// # Safety
///
/// Call once; see [`console_unchecked`].
pub unsafe fn take_console() -> Console {
    // SAFETY: forwarded to the caller.
    let mut console = unsafe { console_unchecked() };
    init_console(&mut console);
    console
}
