//! LiteDRAM's DFI injector in the LiteX SoC (`soc/gridrt_soc/soc.py`: main RAM in the
//! board's SDRAM): the SDRAM chip's power-up sequence, run by the bootloader before anything
//! touches main RAM, as LiteX's BIOS does (`sdram_init` of liblitedram for an SDR PHY:
//! software control, the generated `init_sequence`, hardware control).
//!
//! The sequence itself is data, generated from the SoC (`SDRAM_INIT` in the image's
//! `litex_map.rs`, from `litedram.init` for the SoC's PHY and module), so the driver holds
//! no chip-specific constant.

pub mod regs;

use super::mmio::Mmio;

/// What one step of the sequence writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SdramAction {
    /// A `CONTROL` word (CKE, ODT, RESET_N lines; `SEL` clear).
    Control(u32),
    /// A command (`PI0_COMMAND`: CS, WE, CAS, RAS bits), issued once.
    Command(u32),
}

/// One step of the chip's power-up sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SdramStep {
    /// What the step does (LiteDRAM's comment).
    pub what: &'static str,
    /// The control word or command.
    pub action: SdramAction,
    /// The address lines with it (a mode register value, A10 for "all banks").
    pub address: u32,
    /// The bank address lines.
    pub bank: u32,
    /// Cycles to wait after it, at least.
    pub delay: u32,
}

/// The DFI injector's registers.
pub struct Dfii<M: Mmio> {
    mmio: M,
}

impl<M: Mmio> Dfii<M> {
    /// Wraps the register block.
    pub const fn new(mmio: M) -> Self {
        Self { mmio }
    }

    /// Takes the chip from the controller, runs `steps` in order, and gives it back to the
    /// controller. Blocks for the steps' delays: each waits at least `delay` register reads,
    /// so at least `delay` cycles. Main RAM must not be used until this returns.
    pub fn init(&self, steps: &[SdramStep]) {
        self.mmio.write32(regs::CONTROL, regs::CONTROL_SOFTWARE);
        for step in steps {
            self.mmio.write32(regs::PI0_ADDRESS, step.address);
            self.mmio.write32(regs::PI0_BADDRESS, step.bank);
            match step.action {
                SdramAction::Control(word) => self.mmio.write32(regs::CONTROL, word & !regs::CONTROL_SEL),
                SdramAction::Command(command) => {
                    self.mmio.write32(regs::PI0_COMMAND, command);
                    self.mmio.write32(regs::PI0_COMMAND_ISSUE, 1);
                }
            }
            for _ in 0..step.delay {
                let _ = self.mmio.read32(regs::CONTROL);
            }
        }
        self.mmio.write32(regs::CONTROL, regs::CONTROL_HARDWARE);
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing)] // tests index known-size logs
mod tests {
    use super::regs::*;
    use super::*;
    use crate::bsp::mock::{Access, MockMmio};

    const STEPS: [SdramStep; 3] = [
        SdramStep { what: "cke", action: SdramAction::Control(0x0e), address: 0, bank: 0, delay: 3 },
        SdramStep { what: "precharge all", action: SdramAction::Command(0x0b), address: 0x400, bank: 0, delay: 0 },
        SdramStep { what: "mode register", action: SdramAction::Command(0x0f), address: 0x20, bank: 2, delay: 1 },
    ];

    #[test]
    fn init_runs_every_step_in_software_control_then_hands_the_chip_to_the_controller() {
        let m = MockMmio::default();
        Dfii::new(&m).init(&STEPS);
        assert_eq!(
            m.writes(),
            [
                (CONTROL, CONTROL_SOFTWARE),
                (PI0_ADDRESS, 0),
                (PI0_BADDRESS, 0),
                (CONTROL, 0x0e),
                (PI0_ADDRESS, 0x400),
                (PI0_BADDRESS, 0),
                (PI0_COMMAND, 0x0b),
                (PI0_COMMAND_ISSUE, 1),
                (PI0_ADDRESS, 0x20),
                (PI0_BADDRESS, 2),
                (PI0_COMMAND, 0x0f),
                (PI0_COMMAND_ISSUE, 1),
                (CONTROL, CONTROL_HARDWARE),
            ]
        );
    }

    #[test]
    fn each_step_waits_its_delay_before_the_next_write() {
        let m = MockMmio::default();
        Dfii::new(&m).init(&STEPS);
        // Reads between consecutive writes: the delay of the step the earlier write belongs to.
        let mut reads = Vec::new();
        let mut n = 0;
        for a in m.log() {
            match a {
                Access::Read { .. } => n += 1,
                Access::Write { .. } => {
                    reads.push(n);
                    n = 0;
                }
            }
        }
        // After the control write of step 1: 3; after step 2's issue: 0; after step 3's: 1.
        assert_eq!(reads, [0, 0, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0, 1]);
    }

    #[test]
    fn a_control_step_never_gives_the_chip_to_the_controller_early() {
        let m = MockMmio::default();
        let step = SdramStep { what: "sel set by mistake", action: SdramAction::Control(0x0f), ..STEPS[0] };
        Dfii::new(&m).init(&[step]);
        let w = m.writes();
        assert_eq!(w[3], (CONTROL, 0x0e), "SEL cleared in a step's control word");
        assert_eq!(w.last(), Some(&(CONTROL, CONTROL_HARDWARE)));
    }
}
