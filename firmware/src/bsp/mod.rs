//! Board support: register access, byte UARTs, the co-processor links (AXI4-Stream FIFO,
//! LiteX CSR FIFOs), the SDRAM's power-up, counters.
//!
//! Every driver here is generic over [`Mmio`], so the same code runs on the soft-core
//! (through [`VolatileMmio`]) and in host unit tests (through the register-level mock in
//! `mock`, which records every access and plays back scripted register values).
//!
//! | driver | IP | used on |
//! | --- | --- | --- |
//! | [`ns16550::Ns16550`] | NS16550A UART | QEMU `virt` (0x1000_0000) |
//! | [`uartlite::UartLite`] | Xilinx AXI UART Lite (PG142) | FPGA SoC console/host link |
//! | [`axis_fifo::AxisFifo`] | Xilinx AXI4-Stream FIFO (PG080) | FPGA SoC FSL-style link to the co-processor |
//! | [`litex_uart::LitexUart`] | LiteX UART (`litex/soc/cores/uart.py`) | LiteX SoC (`soc/`) console/host link |
//! | [`coproc_csr::CoprocCsr`] | the co-processor's CSR FIFOs (`soc/gridrt_soc/coproc.py`) | LiteX SoC FSL-style link to the co-processor |
//! | [`litedram::Dfii`] | LiteDRAM's DFI injector (`litedram/dfii.py`) | LiteX SoC: the SDRAM chip's power-up sequence (bootloader) |
//! | [`harts::HartCsr`] | the worker harts' block (`soc/gridrt_soc/harts.py`) | LiteX SoC with `--harts 2`: starting the worker, the frame's mailbox words |
//!
//! Register offsets and bit values live only in each driver's `regs.rs`; above that
//! layer no magic numbers appear.
//!
//! # Execution model
//!
//! Two layers. The drivers' primitives follow the [`nb`] crate: [`ByteUart`]'s
//! `write_byte`/`read_byte`/`nflush` and the stream FIFO's `n*` calls never wait and return
//! `Err(nb::Error::WouldBlock)` when the hardware is not ready. On top of them the UARTs
//! implement the ecosystem's blocking byte-stream traits, [`embedded_io::Read`],
//! [`embedded_io::ReadReady`] and [`embedded_io::Write`] (module [`uart_io`], which states
//! exactly when each call blocks), so any embedded-io consumer (the device loop, the
//! bootloader, the images' console) takes these drivers as they are. Nothing here uses
//! interrupts.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

pub mod axis_fifo;
pub mod coproc_csr;
pub mod harts;
pub mod litedram;
pub mod litex_uart;
pub mod mmio;
#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
pub(crate) mod mock;
pub mod ns16550;
pub mod uart_io;
pub mod uartlite;

pub use mmio::{Mmio, VolatileMmio};

/// The non-blocking primitives of a byte-oriented serial port (console or host link); the
/// blocking API is [`embedded_io`]'s, implemented on each driver by [`uart_io`].
///
/// None of these calls waits.
pub trait ByteUart {
    /// Receive-side error (overrun, framing, parity, ...). Transmit never fails on
    /// the UARTs we have, but the type is shared.
    type Error: core::fmt::Debug;

    /// Queues one byte for transmission if the transmitter has room, else
    /// `Err(WouldBlock)` and nothing is written.
    fn write_byte(&mut self, byte: u8) -> nb::Result<(), Self::Error>;

    /// Takes one received byte, `Err(WouldBlock)` if none is waiting, or a line error.
    ///
    /// After a line error the next call goes on with the following byte: errors are
    /// reported once and are not sticky.
    fn read_byte(&mut self) -> nb::Result<u8, Self::Error>;

    /// `Ok(())` once the transmitter has sent everything queued (shift register empty, or as
    /// close as the IP tells), else `Err(WouldBlock)`: the step that
    /// [`embedded_io::Write::flush`] spins on, e.g. before halting or resetting.
    fn nflush(&mut self) -> nb::Result<(), Self::Error>;
}

/// `core::fmt::Write` (and [`crate::text::TextOut`]) over any [`embedded_io::Write`], for
/// console output.
///
/// A transmit error becomes `core::fmt::Error` (its detail is lost, as fmt allows no more).
pub struct UartWriter<'a, U: embedded_io::Write + ?Sized>(pub &'a mut U);

impl<U: embedded_io::Write + ?Sized> core::fmt::Write for UartWriter<'_, U> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.0.write_all(s.as_bytes()).map_err(|_| core::fmt::Error)
    }
}

/// The same console output without `core::fmt` (`crate::text`): the images' banner and
/// reports. Best effort: a transmit error drops the piece (console text has no reader to
/// tell; the frames the device sends count their write errors, see `crate::pixels::FrameTx`).
impl<U: embedded_io::Write + ?Sized> crate::text::TextOut for UartWriter<'_, U> {
    fn put(&mut self, s: &str) {
        let _ = self.0.write_all(s.as_bytes());
    }
}

/// Free-running performance counters of the hart (RISC-V `mcycle`/`minstret`, or a
/// board timer). Both count up from an arbitrary origin; take differences.
pub trait CycleCounter {
    /// Clock cycles elapsed (`mcycle`).
    fn cycles(&self) -> u64;
    /// Instructions retired (`minstret`; exact under QEMU `-icount shift=0`).
    fn instret(&self) -> u64;
    /// The low 32 bits of [`cycles`](Self::cycles) (on RV32 one CSR read instead of a
    /// consistent 64-bit read).
    #[inline(always)]
    fn cycles_lo(&self) -> u32 {
        self.cycles() as u32
    }
    /// The low 32 bits of [`instret`](Self::instret).
    #[inline(always)]
    fn instret_lo(&self) -> u32 {
        self.instret() as u32
    }
    /// [`instret_lo`](Self::instret_lo) then [`cycles_lo`](Self::cycles_lo), read back to
    /// back: a counter whose two reads are separate instructions reads them in one block, so
    /// the compiler cannot schedule other instructions between them (where it did, `mcycle`
    /// and `minstret` differed by those instructions at that read point under QEMU's
    /// `-icount`).
    #[inline(always)]
    fn instret_cycles_lo(&self) -> (u32, u32) {
        let instret = self.instret_lo();
        (instret, self.cycles_lo())
    }
}
