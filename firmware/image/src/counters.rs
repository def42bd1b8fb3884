//! The hart's own performance counters as a [`CycleCounter`].

use gridrt_firmware::bsp::CycleCounter;

/// `mcycle` / `minstret` through the `riscv` crate (64-bit reads that are consistent
/// across the high/low halves on riscv32).
#[derive(Clone, Copy, Debug, Default)]
pub struct CsrCounters;

impl CycleCounter for CsrCounters {
    fn cycles(&self) -> u64 {
        riscv::register::mcycle::read64()
    }
    fn instret(&self) -> u64 {
        riscv::register::minstret::read64()
    }
    #[inline(always)]
    fn cycles_lo(&self) -> u32 {
        riscv::register::mcycle::read() as u32
    }
    #[inline(always)]
    fn instret_lo(&self) -> u32 {
        riscv::register::minstret::read() as u32
    }
    #[inline(always)]
    fn instret_cycles_lo(&self) -> (u32, u32) {
        #[cfg(target_arch = "riscv32")]
        {
            let (instret, cycles): (u32, u32);
            // SAFETY: two reads of the hart's own counters; no memory, no stack.
            unsafe {
                core::arch::asm!("csrr {0}, minstret", "csrr {1}, mcycle", out(reg) instret, out(reg) cycles, options(nostack));
            }
            (instret, cycles)
        }
        #[cfg(not(target_arch = "riscv32"))]
        {
            let instret = self.instret_lo();
            (instret, self.cycles_lo())
        }
    }
}
