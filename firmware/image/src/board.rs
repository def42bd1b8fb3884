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
    /// Board id in `Msg::Version` (SPEC.md §3.2).
    pub const BOARD_ID: u8 = 1;
    /// Largest grid the app accepts (voxels): 64³. The voxel map lives on the stack, which
    /// is most of RAM here.
    pub const MAX_VOXELS: usize = 1 << 18;
    /// PEs of the virtual co-processor (GridRT had 4).
    pub const PE_COUNT: u16 = 4;
    /// Words per PE memory of the virtual co-processor: 2 MiB each, 8 MiB of .bss in all.
    /// The 69 451-triangle Stanford bunny needs 391 928 words per PE on a 4-PE grid
    /// (`bun_zipper_res4`: 8 139), so every test scene fits.
    pub const PE_MEM_WORDS: u32 = 1 << 19;
    /// Points of a point cloud the app keeps for splat frames (SPEC.md §6), 64 B each with
    /// their bucket node: 4 MiB of the stack.
    pub const MAX_POINTS: usize = 1 << 16;
    /// Words of the splat path's shape table (`TableConfig::DEVICE`: 320 KiB).
    pub const TABLE_WORDS: usize = 81_920;

    /// QEMU `virt`'s SiFive test device: a write ends the emulation.
    const SIFIVE_TEST_BASE: usize = 0x0010_0000;

    /// Ends QEMU with exit status `code` (≥ 1), so scripts and tests see a crash at once.
    /// (Returns only if the device is absent.)
    pub fn exit_failure(code: u16) {
        let value = 0x3333 | (u32::from(code) << 16);
        // SAFETY: the SiFive test device of QEMU virt; the write ends the process.
        unsafe { core::ptr::write_volatile(SIFIVE_TEST_BASE as *mut u32, value) };
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
    /// Board id in `Msg::Version` (SPEC.md §3.2).
    pub const BOARD_ID: u8 = 2;
    /// Largest grid the app accepts (voxels, e.g. 20³), sized for 128 KiB of BRAM: the
    /// voxel map lives on the stack with the rest of the device state (boards/fpga-soc.x).
    pub const MAX_VOXELS: usize = 1 << 13;
    /// PEs of the co-processor in the block design (GridRT: 4).
    pub const PE_COUNT: u16 = 4;
    /// Words per PE memory in the block design (GridRT: 8192).
    pub const PE_MEM_WORDS: u32 = 8192;

    /// Nothing to exit from on hardware: the caller halts.
    pub fn exit_failure(_code: u16) {}
}

pub use imp::*;

/// The application region the bootloader loads images into: `[start, end)` from the
/// `_gridrt_app_start` / `_gridrt_app_end` symbols of boards/<board>-bootloader.x.
/// Only meaningful in the bootloader binary (the app's memory map does not define them).
pub fn app_region() -> (usize, usize) {
    extern "C" {
        static _gridrt_app_start: u8;
        static _gridrt_app_end: u8;
    }
    // Only the addresses of the linker symbols are taken, never their contents.
    (core::ptr::addr_of!(_gridrt_app_start) as usize, core::ptr::addr_of!(_gridrt_app_end) as usize)
}

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
