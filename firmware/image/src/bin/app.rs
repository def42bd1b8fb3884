//! The application image: the firmware device loop of `gridrt-firmware` on the board's UART.
//!
//! Banner (text, then a `0x00` frame delimiter so a host's frame decoder drops it as noise),
//! then [`serve`]: UART bytes in → `Device::feed` → frames out. The co-processor is
//! - qemu-virt: the co-processor model linked in as a virtual co-processor, its PE memories
//!   a static array in .bss (`board::PE_COUNT` × `board::PE_MEM_WORDS`), with the model's own
//!   work excluded from the per-stage counters (`link::TimedLink`); with the feature
//!   `soft-core-only` there is no co-processor: the firmware calls the model's intersection
//!   code itself (`DirectKernel`) and every instruction of it is counted;
//! - fpga-soc: the real one behind the AXI4-Stream FIFO;
//! - litex: the RTL co-processor behind the LiteX SoC's CSR FIFOs.
//!
//! Stage counters come from `mcycle`/`minstret` (exact under QEMU's `-icount shift=0`).
#![no_std]
#![no_main]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use embedded_io::Write as _;
use gridrt_firmware::bsp::{CycleCounter, UartWriter};
use gridrt_firmware::text::TextOut;
use gridrt_firmware_image::serve::{self, serve};
use gridrt_firmware_image::{board, counters::CsrCounters, VERSION};
use gridrt_shared::msg::DeviceInfo;

#[riscv_rt::entry]
fn main() -> ! {
    // Before any f32 arithmetic: a custom instruction on a disabled CFU port traps.
    #[cfg(feature = "cfu-float")]
    gridrt_firmware::sfloat::cfu::enable();
    let counters = CsrCounters;
    let (cycles0, instret0) = (counters.cycles(), counters.instret());
    // SAFETY: the only console owner; trap/panic reports alias it only once we stop.
    let mut console = unsafe { board::take_console() };

    // Console output is best effort: a UART transmit cannot fail on these boards. Text
    // without core::fmt (`TextOut`: its `write!` machinery costs KBs of the soft-core's code
    // budget); the lines are what the `{}` formats printed before.
    let mut w = UartWriter(&mut console);
    for s in ["gridrt firmware ", VERSION, " on ", board::NAME, " (", env!("GRIDRT_APP_LAYOUT"), " layout; stages:"] {
        w.put(s);
    }
    w.put(if cfg!(feature = "shadows") { " shadows" } else { "" });
    w.put(if cfg!(feature = "reflections") { " reflections" } else { "" });
    w.put(if cfg!(feature = "textures") { " textures" } else { "" });
    w.put(if cfg!(feature = "specular") { " specular" } else { "" });
    w.put(if cfg!(feature = "cfu-float") { "; f32 add/mul on the CFU" } else { "" });
    w.put(")\r\n");
    let (cycles1, instret1) = (counters.cycles(), counters.instret());
    w.put("mcycle=");
    w.put_dec(cycles1);
    w.put(" minstret=");
    w.put_dec(instret1);
    w.put(" (banner: ");
    w.put_dec(cycles1.wrapping_sub(cycles0));
    w.put(" cycles, ");
    w.put_dec(instret1.wrapping_sub(instret0));
    w.put(" instructions)\r\n");

    #[cfg(feature = "trap-test")]
    {
        UartWriter(&mut console).put("trap-test: executing an illegal instruction\r\n");
        // SAFETY: deliberately traps; the exception handler reports and halts.
        // 0xc0001073 is `csrrw x0, cycle, x0` (a write to a read-only CSR), the 32-bit
        // canonical illegal instruction; mtval then shows its bits.
        unsafe { core::arch::asm!(".4byte 0xc0001073") };
    }
    #[allow(clippy::panic)]
    if cfg!(feature = "panic-test") {
        panic!("panic-test feature");
    }

    let (pe_count, pe_mem_words) = board::coproc_config();
    let info = DeviceInfo {
        protocol: 0, // filled in by Device::new, like max_payload, voxel_capacity, features
        firmware: serve::firmware_version(),
        board: board::BOARD_ID,
        max_payload: 0,
        pe_count,
        voxel_capacity: 0,
        pe_mem_words,
        features: 0,
    };
    let mut w = UartWriter(&mut console);
    w.put("device: ");
    w.put_dec(u64::from(pe_count));
    w.put(" PEs x ");
    w.put_dec(u64::from(pe_mem_words));
    w.put(" words, up to ");
    w.put_dec(board::MAX_VOXELS as u64);
    w.put(" voxels; speak SPEC.md frames now\r\n");
    run(&mut console, info)
}

#[cfg(feature = "board-qemu-virt")]
fn run(console: &mut board::Console, info: DeviceInfo) -> ! {
    use core::fmt::Write as _;
    use gridrt_coproc::{CoprocConfig, Coprocessor, FixedFrame, KernelKind, NumberFormat, TimingProfile, LIST_CAPACITY};

    const WORDS: usize = board::PE_COUNT as usize * board::PE_MEM_WORDS as usize;
    /// The PE memories of the virtual co-processor (zeroed .bss).
    static mut PE_MEMORY: [u32; WORDS] = [0; WORDS];

    // The same model configuration as the loopback simulator's default (`render --sim`),
    // so both render the same image and report the same kernel-true cycles; with
    // `coproc-rtl`, the RTL co-processor's kernel, number format and timing
    // (`SimConfig::RTL` of the loopback: the same image and cycles as `--coproc rtl`).
    #[cfg(not(feature = "coproc-rtl"))]
    let (kernel, format, timing) = (KernelKind::default(), NumberFormat::F32, TimingProfile::GRIDRT);
    #[cfg(feature = "coproc-rtl")]
    let (kernel, format, timing) = (KernelKind::Watertight, NumberFormat::Fixed64Q23, TimingProfile::RTL);
    let config = CoprocConfig {
        pe_count: board::PE_COUNT,
        pe_mem_words: board::PE_MEM_WORDS,
        max_list: LIST_CAPACITY as u16,
        timing: timing.for_kernel(kernel, format),
        kernel,
    };
    // SAFETY: `run` is called once and never returns: this is the only reference ever made.
    let backing: &'static mut [u32] = unsafe { &mut *core::ptr::addr_of_mut!(PE_MEMORY) };
    let mut model = match Coprocessor::new(config, backing) {
        Ok(m) => m,
        Err(e) => {
            let _ = writeln!(UartWriter(console), "\r\nFATAL: co-processor model configuration refused: {e}; halted\r");
            let _ = console.flush();
            board::exit_failure(3);
            gridrt_firmware_image::halt()
        }
    };
    // The frame itself comes with the scene (the firmware's FRAME packet).
    model.set_number_format(format, FixedFrame::IDENTITY);
    serve_model(console, info, model)
}

/// The co-processor model linked in as a virtual co-processor; its own work and the wrapper
/// that excludes it (calibrated at boot) are excluded from the stage counters and reported.
#[cfg(all(feature = "board-qemu-virt", not(feature = "soft-core-only")))]
fn serve_model(console: &mut board::Console, info: DeviceInfo, model: gridrt_coproc::Coprocessor<'static>) -> ! {
    use gridrt_firmware::device::Device;
    use gridrt_firmware::fsl::VirtualCoproc;
    use gridrt_firmware_image::link::{Excluded, ModelFreeClock, TimedLink};

    let excluded = Excluded::new();
    excluded.calibrate(CsrCounters);
    let mut w = UartWriter(console);
    w.put("co-processor: model behind the timed link, its work excluded from the stage counters\r\n");
    #[cfg(feature = "coproc-rtl")]
    w.put("co-processor kernel: the RTL's (watertight, fixed64-q23, rtl timing)\r\n");
    w.put("timed link: ");
    w.put_dec(u64::from(excluded.wrapper_per_call()));
    w.put(" instructions of the link wrapper per call into the co-processor model, excluded and reported (Stats)\r\n");
    // Ends the text for a frame decoder (it becomes one bad frame, which hosts ignore).
    let _ = console.write_all(&[0]);
    let link = TimedLink::new(VirtualCoproc { model }, CsrCounters, &excluded);
    let clock = ModelFreeClock::new(CsrCounters, &excluded);
    // On the stack, which is most of RAM here (memory.x).
    let mut device: Device<_, _, { board::MAX_VOXELS }, { board::MAX_POINTS }, { board::TABLE_WORDS }> =
        Device::new(link, clock, info);
    serve(&mut device, console)
}

/// No co-processor: the firmware calls the intersection code itself and every instruction
/// of it is counted (`gridrt bench frame`'s soft-core-only configuration).
#[cfg(all(feature = "board-qemu-virt", feature = "soft-core-only"))]
fn serve_model(console: &mut board::Console, info: DeviceInfo, model: gridrt_coproc::Coprocessor<'static>) -> ! {
    use gridrt_firmware::device::{CounterClock, Device};
    use gridrt_firmware::fsl::DirectKernel;

    UartWriter(console).put("co-processor: none, the soft-core intersects (counted in fsl_io)\r\n");
    // Ends the text for a frame decoder (it becomes one bad frame, which hosts ignore).
    let _ = console.write_all(&[0]);
    let link = DirectKernel { model };
    // On the stack, which is most of RAM here (memory.x).
    let mut device: Device<_, _, { board::MAX_VOXELS }> = Device::new(link, CounterClock(CsrCounters), info);
    serve(&mut device, console)
}

#[cfg(feature = "board-fpga-soc")]
fn run(console: &mut board::Console, info: DeviceInfo) -> ! {
    use gridrt_firmware::bsp::axis_fifo::AxisFifo;
    use gridrt_firmware::bsp::VolatileMmio;
    use gridrt_firmware::device::{CounterClock, Device};
    use gridrt_firmware_image::link::AxisLink;

    // SAFETY: STREAM_FIFO_BASE is the AXI4-Stream FIFO of this block design; owned here only.
    let mut fifo = AxisFifo::new(unsafe { VolatileMmio::new(board::STREAM_FIFO_BASE) });
    fifo.init();
    // Ends the text for a frame decoder (it becomes one bad frame, which hosts ignore).
    let _ = console.write_all(&[0]);
    let mut device: Device<_, _, { board::MAX_VOXELS }> = Device::new(AxisLink(fifo), CounterClock(CsrCounters), info);
    serve(&mut device, console)
}

/// The scene upload's window on the LiteX SoC: the data of one `SceneData` of the largest
/// payload (its offset field is 4 bytes).
#[cfg(feature = "board-litex")]
const LITEX_UPLOAD_WINDOW: u16 = (gridrt_shared::frame::MAX_PAYLOAD - 4) as u16;

#[cfg(feature = "board-litex")]
fn run(console: &mut board::Console, info: DeviceInfo) -> ! {
    use gridrt_firmware::bsp::coproc_csr::CoprocCsr;
    use gridrt_firmware::bsp::VolatileMmio;
    use gridrt_firmware::device::{CounterClock, Device};
    use gridrt_firmware_image::harts::HartFarm;
    use gridrt_firmware_image::link::CsrFifoLink;

    // SAFETY: COPROC_BASE is the co-processor's CSR FIFOs (csr.json); owned here only.
    let mut fifos = CoprocCsr::new(unsafe { VolatileMmio::new(board::COPROC_BASE) });
    fifos.init();
    // Worker harts, if the SoC has any, trace rows of each frame beside this one.
    let farm = HartFarm::start();
    let mut w = UartWriter(console);
    w.put("harts: ");
    w.put_dec(u64::from(farm.harts()));
    w.put("\r\n");
    // Ends the text for a frame decoder (it becomes one bad frame, which hosts ignore).
    let _ = console.write_all(&[0]);
    let mut device: Device<_, _, { board::MAX_VOXELS }, 0, 0, HartFarm> =
        Device::with_clock_and_farm(CsrFifoLink(fifos), CounterClock(CsrCounters), info, farm);
    // The UART holds UART_FIFO_DEPTH bytes, and parsing a data frame takes far longer than
    // that many bytes on the line (docs/bench-upload.md): one frame in flight, so that no
    // byte arrives while the device is busy and the board's line drops none.
    device.set_upload_window(LITEX_UPLOAD_WINDOW);
    serve(&mut device, console)
}
