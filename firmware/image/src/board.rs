//! Board constants and the console, selected by the `board-*` feature.

#[cfg(any(
    all(feature = "board-qemu-virt", feature = "board-fpga-soc"),
    all(feature = "board-qemu-virt", feature = "board-litex"),
    all(feature = "board-fpga-soc", feature = "board-litex"),
))]
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
    /// Largest grid the app accepts (voxels): 64³. The voxel map and its occupancy-ahead
    /// table (a byte per voxel each) live on the stack, which is most of RAM here.
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

    /// The co-processor's configuration, `(PEs, words per PE)`.
    pub fn coproc_config() -> (u16, u32) {
        (PE_COUNT, PE_MEM_WORDS)
    }

    /// QEMU `virt`'s SiFive test device: a write ends the emulation.
    const SIFIVE_TEST_BASE: usize = 0x0010_0000;

    /// Ends QEMU with exit status `code` (≥ 1), so scripts and tests see a crash at once.
    /// (Returns only if the device is absent.)
    pub fn exit_failure(code: u16) {
        let value = 0x3333 | (u32::from(code) << 16);
        // SAFETY: the SiFive test device of QEMU virt; the write ends the process.
        unsafe { core::ptr::write_volatile(SIFIVE_TEST_BASE as *mut u32, value) };
    }

    /// Main RAM needs no set-up on this board.
    pub fn init_main_ram() -> Result<(), usize> {
        Ok(())
    }

    /// What main RAM is, for the bootloader's banner.
    pub const MAIN_RAM: &str = "RAM";
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
    /// voxel map and its occupancy-ahead table (8 KiB each) live on the stack with the rest
    /// of the device state (boards/fpga-soc.x).
    pub const MAX_VOXELS: usize = 1 << 13;
    /// PEs of the co-processor in the block design (GridRT: 4).
    pub const PE_COUNT: u16 = 4;
    /// Words per PE memory in the block design (GridRT: 8192).
    pub const PE_MEM_WORDS: u32 = 8192;

    /// The co-processor's configuration, `(PEs, words per PE)`.
    pub fn coproc_config() -> (u16, u32) {
        (PE_COUNT, PE_MEM_WORDS)
    }

    /// Nothing to exit from on hardware: the caller halts.
    pub fn exit_failure(_code: u16) {}

    /// Main RAM needs no set-up on this board.
    pub fn init_main_ram() -> Result<(), usize> {
        Ok(())
    }

    /// What main RAM is, for the bootloader's banner.
    pub const MAIN_RAM: &str = "RAM";
}

#[cfg(feature = "board-litex")]
mod imp {
    use crate::litex_map as map;
    use gridrt_firmware::bsp::coproc_csr::{regs as coproc_regs, CoprocCsr};
    use gridrt_firmware::bsp::litedram::{regs as dfii_regs, Dfii};
    use gridrt_firmware::bsp::litex_uart::{regs as uart_regs, LitexUart};
    use gridrt_firmware::bsp::VolatileMmio;

    /// Board name, as printed in the banner and accepted by `cargo xtask --board`.
    pub const NAME: &str = "litex";
    /// The LiteX UART (csr.json `uart`; baud rate fixed in the gateware).
    pub const CONSOLE_BASE: usize = map::uart::BASE;
    /// The co-processor's CSR FIFOs (csr.json `coproc`).
    pub const COPROC_BASE: usize = map::coproc::BASE;

    /// True when the register at absolute address `addr` sits at `offset` from `base`.
    const fn at(addr: usize, base: usize, offset: usize) -> bool {
        addr.wrapping_sub(base) == offset
    }

    // The drivers address registers by offset from the base; the SoC's csr.json says where
    // each register is. Disagreement (a changed LiteX core, a changed SoC) fails the build.
    const _: () = {
        use map::{coproc, uart};
        assert!(at(uart::RXTX, uart::BASE, uart_regs::RXTX), "LiteX UART: RXTX");
        assert!(at(uart::TXFULL, uart::BASE, uart_regs::TXFULL), "LiteX UART: TXFULL");
        assert!(at(uart::RXEMPTY, uart::BASE, uart_regs::RXEMPTY), "LiteX UART: RXEMPTY");
        assert!(at(uart::EV_PENDING, uart::BASE, uart_regs::EV_PENDING), "LiteX UART: EV_PENDING");
        assert!(at(uart::EV_ENABLE, uart::BASE, uart_regs::EV_ENABLE), "LiteX UART: EV_ENABLE");
        assert!(at(uart::TXEMPTY, uart::BASE, uart_regs::TXEMPTY), "LiteX UART: TXEMPTY");
        assert!(1 << uart::EV_PENDING_RX_OFFSET == uart_regs::EV_RX, "LiteX UART: EV_RX");
        assert!(1 << uart::EV_PENDING_TX_OFFSET == uart_regs::EV_TX, "LiteX UART: EV_TX");
        // Every port's FIFO registers (the first hart's `coproc`, the workers' `coproc1..3`).
        macro_rules! port {
            ($p:ident) => {
                assert!(at($p::REQ, $p::BASE, coproc_regs::REQ), "co-processor port: REQ");
                assert!(at($p::REQ_LAST, $p::BASE, coproc_regs::REQ_LAST), "co-processor port: REQ_LAST");
                assert!(at($p::RSP, $p::BASE, coproc_regs::RSP), "co-processor port: RSP");
                assert!(at($p::STATUS, $p::BASE, coproc_regs::STATUS), "co-processor port: STATUS");
                assert!($p::STATUS_REQ_SPACE_OFFSET == coproc_regs::STATUS_REQ_SPACE_OFFSET);
                assert!($p::STATUS_RSP_LEVEL_OFFSET == coproc_regs::STATUS_RSP_LEVEL_OFFSET);
                assert!(1 << $p::STATUS_RSP_LAST_OFFSET == coproc_regs::STATUS_RSP_LAST);
                assert!(1 << $p::STATUS_REQ_OVERFLOW_OFFSET == coproc_regs::STATUS_REQ_OVERFLOW);
                assert!(1 << $p::STATUS_RSP_UNDERFLOW_OFFSET == coproc_regs::STATUS_RSP_UNDERFLOW);
            };
        }
        port!(coproc);
        assert!(at(coproc::CTRL, coproc::BASE, coproc_regs::CTRL), "co-processor: CTRL");
        assert!(at(coproc::PES, coproc::BASE, coproc_regs::PES), "co-processor: PES");
        assert!(at(coproc::PE_MEM_WORDS, coproc::BASE, coproc_regs::PE_MEM_WORDS), "co-processor: PE_MEM_WORDS");
        assert!(coproc::STATUS_REQ_SPACE_SIZE == coproc_regs::STATUS_LEVEL_BITS);
        assert!(coproc::STATUS_RSP_LEVEL_SIZE == coproc_regs::STATUS_LEVEL_BITS);
        assert!(1 << coproc::STATUS_IDLE_OFFSET == coproc_regs::STATUS_IDLE);
        assert!(1 << coproc::CTRL_RESET_OFFSET == coproc_regs::CTRL_RESET);
        use gridrt_firmware::bsp::harts::regs as harts_regs;
        use map::{coproc1, coproc2, coproc3, harts};
        port!(coproc1);
        port!(coproc2);
        port!(coproc3);
        assert!(at(harts::COUNT, harts::BASE, harts_regs::COUNT), "harts: COUNT");
        assert!(at(harts::ENTRY, harts::BASE, harts_regs::ENTRY), "harts: ENTRY");
        assert!(at(harts::RUN, harts::BASE, harts_regs::RUN), "harts: RUN");
        assert!(at(harts::JOB, harts::BASE, harts_regs::JOB), "harts: JOB");
        assert!(at(harts::TICKET, harts::BASE, harts_regs::TICKET), "harts: TICKET");
        assert!(at(harts::SENT, harts::BASE, harts_regs::SENT), "harts: SENT");
        assert!(at(harts::READY, harts::BASE, harts_regs::READY), "harts: READY");
        assert!(at(harts::READY_SET, harts::BASE, harts_regs::READY_SET), "harts: READY_SET");
        assert!(at(harts::READY_CLR, harts::BASE, harts_regs::READY_CLR), "harts: READY_CLR");
        assert!(at(harts::DONE1, harts::BASE, harts_regs::DONE1), "harts: DONE1");
        assert!(at(harts::DONE2, harts::DONE1, 4) && at(harts::DONE3, harts::DONE2, 4), "harts: DONE2, DONE3");
        use map::sdram;
        assert!(at(sdram::DFII_CONTROL, sdram::BASE, dfii_regs::CONTROL), "LiteDRAM: DFII_CONTROL");
        assert!(at(sdram::DFII_PI0_COMMAND, sdram::BASE, dfii_regs::PI0_COMMAND), "LiteDRAM: PI0_COMMAND");
        assert!(at(sdram::DFII_PI0_COMMAND_ISSUE, sdram::BASE, dfii_regs::PI0_COMMAND_ISSUE), "LiteDRAM: ISSUE");
        assert!(at(sdram::DFII_PI0_ADDRESS, sdram::BASE, dfii_regs::PI0_ADDRESS), "LiteDRAM: PI0_ADDRESS");
        assert!(at(sdram::DFII_PI0_BADDRESS, sdram::BASE, dfii_regs::PI0_BADDRESS), "LiteDRAM: PI0_BADDRESS");
        assert!(1 << sdram::DFII_CONTROL_SEL_OFFSET == dfii_regs::CONTROL_SEL);
        assert!(1 << sdram::DFII_CONTROL_CKE_OFFSET == dfii_regs::CONTROL_CKE);
        assert!(1 << sdram::DFII_CONTROL_ODT_OFFSET == dfii_regs::CONTROL_ODT);
        assert!(1 << sdram::DFII_CONTROL_RESET_N_OFFSET == dfii_regs::CONTROL_RESET_N);
    };

    /// Main RAM is the board's SDRAM: runs the chip's power-up sequence (csr.json's
    /// `SDRAM_INIT`) and hands it to LiteDRAM's controller. The bootloader calls it before
    /// anything touches main RAM; the application, which runs from main RAM, never does.
    /// Then writes a pattern into words [`PROBE_STRIDE`] apart and into the last word, and
    /// reads them back: `Err(address)` at the first word that does not hold what was written.
    pub fn init_main_ram() -> Result<(), usize> {
        // SAFETY: the SoC's LiteDRAM DFII registers (csr.json, through litex_map); nothing
        // else drives them, and main RAM is not in use yet.
        Dfii::new(unsafe { VolatileMmio::new(map::sdram::BASE) }).init(&map::SDRAM_INIT);
        let last = map::MAIN_RAM_BASE + map::MAIN_RAM_SIZE - 4;
        let words = (0..PROBES).map(|k| map::MAIN_RAM_BASE.wrapping_add(k.wrapping_mul(PROBE_STRIDE))).chain([last]);
        let pattern = |a: usize| 0x5A5A_0F0F ^ a as u32;
        for a in words.clone() {
            // SAFETY: word-aligned addresses inside main RAM, which nothing uses yet.
            unsafe { core::ptr::write_volatile(a as *mut u32, pattern(a)) };
        }
        for a in words {
            // SAFETY: as above.
            if unsafe { core::ptr::read_volatile(a as *const u32) } != pattern(a) {
                return Err(a);
            }
        }
        Ok(())
    }

    /// The main-RAM check's stride: the largest L2 cache a build may have (`--l2-kib` 256).
    /// LiteX's L2 is direct-mapped, so each probe evicts the one before it to the chip and
    /// the reads come from the chip, not only from the L2.
    const PROBE_STRIDE: usize = 256 << 10;
    /// Probes at that stride (plus the last word).
    const PROBES: usize = 4;
    const _: () = assert!(PROBES * PROBE_STRIDE < map::MAIN_RAM_SIZE);

    /// What main RAM is, for the bootloader's banner.
    pub const MAIN_RAM: &str = "SDRAM (LiteDRAM)";

    /// The console UART type of this board.
    pub type Console = LitexUart<VolatileMmio>;

    /// A handle on the console registers, without touching the device.
    ///
    /// # Safety
    ///
    /// Creates an alias of the console: only use it where the owner cannot run any more
    /// (trap and panic reports), or create it once at start-up.
    pub unsafe fn console_unchecked() -> Console {
        // SAFETY: CONSOLE_BASE is the SoC's UART (csr.json, through litex_map).
        LitexUart::new(unsafe { VolatileMmio::new(CONSOLE_BASE) })
    }

    /// Turns the UART's interrupts off; bytes already received stay.
    pub fn init_console(console: &mut Console) {
        console.init();
    }
    /// Board id in `Msg::Version` (SPEC.md §3.2).
    pub const BOARD_ID: u8 = 3;
    /// Largest grid the app accepts (voxels): 64³, as on QEMU, for scenes like stanford-bunny
    /// (45×45×35) whose PE images are in SDRAM. The voxel map and its occupancy-ahead table
    /// (a byte per voxel each, 256 KiB each) live on the stack in main RAM with the rest of the device state (boards/litex.x),
    /// never on a hart's own 32 KiB stack.
    pub const MAX_VOXELS: usize = 1 << 18;

    /// The co-processor's configuration, `(PEs, words per PE)`, as the SoC was built: read
    /// from its CSRs, so one image serves every build of the SoC.
    pub fn coproc_config() -> (u16, u32) {
        // SAFETY: two read-only configuration registers of the co-processor's CSR block;
        // reading them has no side effect on the FIFOs.
        CoprocCsr::new(unsafe { VolatileMmio::new(COPROC_BASE) }).config()
    }

    /// Nothing to exit from on hardware or in the simulation: the caller halts.
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
