//! Several harts per frame on the LiteX SoC built with `--harts N` (`soc/gridrt_soc/harts.py`):
//! every hart claims rows of the frame and traces them on its own port to the co-processor
//! (`coproc`, `coproc1..3`); the first hart sends every row in order, as the device loop
//! does, and traces a row itself whenever the next one is not ready ([`HartFarm`], a
//! [`RowFarm`]), so the harts share the frame as their speeds allow. Each pixel is a pure
//! function of the frame, the scene and the co-processor's memories, so the bytes on the
//! UART are those of one hart.
//!
//! The registers and the protocol are `gridrt_firmware::bsp::harts`'s. The memory the harts
//! share: the frame's [`Rows`] (the first hart's stack: the scene, the frame's context) and
//! [`EXCHANGE`] (the row slots). VexRiscv's data caches are write-through and not coherent,
//! so a hart invalidates its own ([`invalidate_dcache`]) before it reads what another wrote,
//! and sets a register only after a `fence`.
//!
//! If a worker traps or the workers stop answering, the first hart holds them in reset,
//! traces the rest of the frame itself and renders alone from then on. (A worker stopped in
//! the middle of a request leaves the co-processor waiting for the rest of it: the first
//! hart's requests then time out, and the frame fails with a link error.)

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::ops::ControlFlow;
use core::sync::atomic::{fence, Ordering};

use gridrt_firmware::bsp::coproc_csr::CoprocCsr;
use gridrt_firmware::bsp::harts::{regs, Done, HartCsr, Job};
use gridrt_firmware::bsp::VolatileMmio;
use gridrt_firmware::device::{FrameStats, RowDone, RowFarm, RowFault, RowTracer, Rows, MAX_IMAGE_DIM};
use gridrt_firmware::interp::Sample;

use crate::board::MAX_VOXELS;
use crate::link::CsrFifoLink;
use crate::litex_map as map;

/// The widest row (the widest frame).
const MAX_ROW: usize = MAX_IMAGE_DIM as usize;
/// Row slots: row k of a frame goes into slot k mod RING (`READY` bit k mod RING).
const RING: u16 = regs::SLOTS;
/// Polls of the registers before the first hart gives up on the workers: a CSR read each,
/// far more than any row's time (a row of 4096 pixels at 10⁵ cycles per pixel is 4·10⁸
/// cycles).
const WORKER_POLLS: u32 = 1 << 30;
/// `nop`s between two polls of a register.
const PAUSE_NOPS: u32 = 32;
/// Frames are numbered 1..=MAX_SEQ (15 bits, so that a `DONE` word is never `TRAPPED`).
const MAX_SEQ: u16 = 0x7FFF;

/// A row handed over by a worker.
struct Slot {
    y: u16,
    samples: [Sample; MAX_ROW],
    fault: Option<RowFault>,
    stats: Option<FrameStats>,
}

/// What the harts share in memory.
struct Exchange {
    /// The frame's rows (the first hart writes it before posting the job).
    rows: *const Rows<'static, MAX_VOXELS>,
    slots: [Slot; RING as usize],
    /// The first hart's own row (its stack has no room for one).
    own: [Sample; MAX_ROW],
}

struct Shared(UnsafeCell<MaybeUninit<Exchange>>);

// SAFETY: the harts touch disjoint parts of it at any time, in the order the protocol sets
// (`gridrt_firmware::bsp::harts`).
unsafe impl Sync for Shared {}

/// In `.uninit` (riscv-rt neither loads nor zeroes it: zeroing 1 MiB would hold up every
/// boot, with workers or not); [`HartFarm::start`] initialises it before the workers run.
#[link_section = ".uninit.gridrt_exchange"]
static EXCHANGE: Shared = Shared(UnsafeCell::new(MaybeUninit::uninit()));

fn exchange() -> *mut Exchange {
    EXCHANGE.0.get().cast()
}

fn slot(k: u16) -> *mut Slot {
    // SAFETY: a field of the static (k mod RING is in bounds); no reference is made.
    unsafe { core::ptr::addr_of_mut!((*exchange()).slots).cast::<Slot>().add(usize::from(k % RING)) }
}

/// Gives [`EXCHANGE`] its first value, field by field (it is larger than the stack).
fn init_exchange() {
    let ex = exchange();
    // SAFETY: no worker runs yet; all-zero bytes are valid samples, the other fields are
    // written whole.
    unsafe {
        core::ptr::addr_of_mut!((*ex).rows).write(core::ptr::null());
        core::ptr::addr_of_mut!((*ex).own).write_bytes(0, 1);
        for k in 0..RING {
            let s = slot(k);
            core::ptr::addr_of_mut!((*s).y).write(0);
            core::ptr::addr_of_mut!((*s).samples).write_bytes(0, 1);
            core::ptr::addr_of_mut!((*s).fault).write(None);
            core::ptr::addr_of_mut!((*s).stats).write(None);
        }
    }
}

/// The top of a hart's private RAM (`soc/gridrt_soc/harts.py`), at the same addresses for
/// every hart and reached only by its own data bus, so the stack traffic there stays off the
/// bus the harts share: every worker's stack, and the one the first hart traces its rows on
/// ([`on_private_stack`]).
const PRIVATE_STACK_TOP: usize = map::HART_RAM_BASE + map::HART_RAM_SIZE;

// The workers' reset vectors: worker k starts at `_gridrt_worker_start` + 8·(k − 1)
// (`regs::ENTRY_STRIDE`; the stubs are uncompressed so that each is 8 bytes), with its number
// in a0. riscv-rt's start-up is the first hart's (it zeroes .bss and copies .data before
// the workers start), so a worker only sets its global pointer, stack and trap vector.
// Its trap handler reports `Done::TRAPPED` in its own `DONE` word and stops.
core::arch::global_asm!(
    ".section .text.gridrt_worker, \"ax\"",
    ".balign 4",
    ".option push",
    ".option norvc",
    ".global _gridrt_worker_start",
    "_gridrt_worker_start:",
    "li a0, 1",
    "j 1f",
    "li a0, 2",
    "j 1f",
    "li a0, 3",
    "j 1f",
    ".option pop",
    "1:",
    ".option push",
    ".option norelax",
    "la gp, __global_pointer$",
    ".option pop",
    "csrw mscratch, a0",
    "li sp, {stack_top}",
    "csrw mie, zero",
    "la t0, 2f",
    "csrw mtvec, t0",
    "j {main}",
    ".balign 4",
    "2:",
    "csrr t0, mscratch",
    "addi t0, t0, -1",
    "slli t0, t0, 2",
    "li t1, {done1}",
    "add t0, t0, t1",
    "li t1, -1",
    "sw t1, 0(t0)",
    "3:",
    "wfi",
    "j 3b",
    stack_top = const PRIVATE_STACK_TOP,
    main = sym worker_main,
    done1 = const map::harts::DONE1,
);
const _: () = assert!(regs::ENTRY_STRIDE == 8 && PRIVATE_STACK_TOP.is_multiple_of(16));

extern "C" {
    fn _gridrt_worker_start();
}

/// Drops this hart's data-cache lines (VexRiscv's `0x500F`): the next loads read memory,
/// where the other harts' stores are (write-through).
#[inline(always)]
fn invalidate_dcache() {
    fence(Ordering::SeqCst);
    // SAFETY: VexRiscv's data-cache invalidation; the cache is write-through, so no store
    // is lost. The asm is a compiler barrier (it may touch memory).
    unsafe { core::arch::asm!(".4byte 0x0000500F") };
}

/// Waits a little without touching the bus: a hart that polls a register back to back would
/// take bus cycles from the others' co-processor and UART accesses.
#[inline(always)]
fn pause() {
    for _ in 0..PAUSE_NOPS {
        // SAFETY: a `nop`.
        unsafe { core::arch::asm!("nop", options(nomem, nostack)) };
    }
}

/// This hart's `mcycle`, low word (a row or a wait is far below 2^32 cycles: differences
/// wrap correctly).
#[inline(always)]
fn cycles() -> u32 {
    riscv::register::mcycle::read() as u32
}

/// Counts one row that took `busy` cycles, after `wait` cycles of waiting, to hart `hart`
/// in `stats` (the row's counters, which the first hart adds to the frame's).
fn charge(stats: &mut FrameStats, hart: u32, busy: u32, wait: u32) {
    if let Some(w) = stats.harts.get_mut(hart as usize) {
        w.rows = w.rows.wrapping_add(1);
        w.busy_cycles = w.busy_cycles.wrapping_add(u64::from(busy));
        w.wait_cycles = w.wait_cycles.wrapping_add(u64::from(wait));
    }
}

/// Adds the first hart's uncharged `waited` cycles to a row's counters.
fn charge_wait(stats: &mut FrameStats, waited: &mut u32) {
    if let Some(w) = stats.harts.first_mut() {
        w.wait_cycles = w.wait_cycles.wrapping_add(u64::from(core::mem::take(waited)));
    }
}

fn hart_csr() -> HartCsr<VolatileMmio> {
    // SAFETY: the SoC's `harts` block (csr.json); its registers are plain words.
    HartCsr::new(unsafe { VolatileMmio::new(map::harts::BASE) })
}

/// Hart `hart`'s port on the co-processor (0: `coproc`, k: `coproc{k}`), not reset.
fn port(hart: u32) -> CsrFifoLink<VolatileMmio> {
    let base = match hart {
        1 => map::coproc1::BASE,
        2 => map::coproc2::BASE,
        3 => map::coproc3::BASE,
        _ => map::coproc::BASE,
    };
    // SAFETY: a port's CSR FIFOs; each hart uses its own, and the device loop leaves the
    // first one alone while the farm renders.
    CsrFifoLink(CoprocCsr::new(unsafe { VolatileMmio::new(base) }))
}

/// The frame's rows: `(first y, count)`.
fn extent<const N: usize>(rows: &Rows<'_, N>) -> (u16, u16) {
    let ys = rows.ys();
    (ys.start, ys.end.saturating_sub(ys.start))
}

/// A worker's main loop: waits for a job, traces rows, reports, forever.
extern "C" fn worker_main(worker: u32) -> ! {
    // Before any f32 arithmetic: a custom instruction on a disabled CFU port traps.
    #[cfg(feature = "cfu-float")]
    gridrt_firmware::sfloat::cfu::enable();
    let csr = hart_csr();
    let mut last = 0u16;
    loop {
        let job = csr.job();
        if job.seq == 0 || job.seq == last || job.cancel {
            pause();
            continue;
        }
        last = job.seq;
        invalidate_dcache();
        // SAFETY: the first hart wrote the pointer before posting the job, and the rows,
        // scene and frame context it points at stay as they are until every worker reports
        // `finished` (protocol step 4).
        let rows = unsafe { &*(*exchange()).rows };
        let traced = trace_rows(&csr, worker, job, rows);
        fence(Ordering::SeqCst);
        csr.report(worker, Done::Rows { seq: job.seq, rows: traced, finished: true });
    }
}

/// A worker's part of a frame: claims rows until none is left or the frame ends; returns
/// how many it traced.
fn trace_rows(csr: &HartCsr<VolatileMmio>, worker: u32, job: Job, rows: &Rows<'_, MAX_VOXELS>) -> u16 {
    let (y0, n) = extent(rows);
    let mut tracer = RowTracer::new(rows, port(worker));
    let mut traced = 0u16;
    while csr.job() == job {
        let k = csr.claim();
        if k >= n {
            break;
        }
        // Slot k mod RING is free once row k − RING is sent.
        let waited = cycles();
        while k >= csr.sent().saturating_add(RING) {
            if csr.job() != job {
                return traced;
            }
            pause();
        }
        let started = cycles();
        // SAFETY: the first hart reads this slot only after its READY bit is set below, and
        // row k − RING, its last occupant, is sent (the wait above).
        let s = unsafe { &mut *slot(k) };
        s.y = y0.wrapping_add(k);
        s.fault = tracer.row(rows, s.y, &mut s.samples).err();
        let mut stats = tracer.take_stats();
        charge(&mut stats, worker, cycles().wrapping_sub(started), started.wrapping_sub(waited));
        s.stats = Some(stats);
        traced = traced.wrapping_add(1);
        fence(Ordering::SeqCst);
        csr.set_ready(k);
        if s.fault.is_some() {
            break;
        }
    }
    traced
}

/// The first hart's side: a [`RowFarm`] that shares each frame with the workers, when the
/// SoC has any.
pub struct HartFarm {
    csr: HartCsr<VolatileMmio>,
    /// The last frame's number.
    seq: u16,
    /// Workers that run and answer (0: the first hart renders alone).
    workers: u32,
}

impl HartFarm {
    /// Starts the workers the SoC was built with.
    pub fn start() -> Self {
        let csr = hart_csr();
        let workers = csr.count().saturating_sub(1);
        if workers > 0 {
            init_exchange();
            csr.start(_gridrt_worker_start as *const () as usize as u32);
        }
        Self { csr, seq: 0, workers }
    }

    /// Harts that render a frame (1 when there are no workers or they were stopped).
    pub fn harts(&self) -> u32 {
        self.workers.saturating_add(1)
    }

    /// Whether a worker trapped.
    fn trapped(&self) -> bool {
        (1..=self.workers).any(|w| self.csr.done(w) == Done::Trapped)
    }

    /// Ends frame `seq` for the workers and waits until each has stopped using the frame's
    /// memory; workers that do not are held in reset.
    fn end(&mut self, seq: u16) {
        self.csr.post(Job { seq, cancel: true });
        let finished = |w| matches!(self.csr.done(w), Done::Rows { seq: s, finished: true, .. } if s == seq);
        for _ in 0..WORKER_POLLS {
            if (1..=self.workers).all(finished) {
                return;
            }
            if self.trapped() {
                break;
            }
            pause();
        }
        self.give_up();
    }

    /// Holds the workers in reset for good.
    fn give_up(&mut self) {
        self.csr.stop();
        self.workers = 0;
    }
}

impl<L> RowFarm<L> for HartFarm {
    fn render<const N: usize>(
        &mut self,
        _link: &L,
        rows: &Rows<'_, N>,
        sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>,
    ) -> bool {
        if self.workers == 0 || N != MAX_VOXELS || rows.width() > MAX_ROW {
            return false;
        }
        self.seq = if self.seq >= MAX_SEQ { 1 } else { self.seq.wrapping_add(1) };
        let seq = self.seq;
        let ex = exchange();
        // SAFETY: the workers read the pointer only after the job below is posted, and use
        // it only until they report `finished` (`end`, before this function returns). N is
        // MAX_VOXELS (checked above): the cast changes only the lifetime.
        unsafe { (*ex).rows = (rows as *const Rows<'_, N>).cast() };
        fence(Ordering::SeqCst);
        self.csr.open(seq);
        // The frame's loop runs on this hart's private RAM (the row tracer and every spill of
        // the walk stay off the shared bus, as a worker's do); the device state stays where
        // it is, in main RAM.
        on_private_stack(&mut || self.share(rows, sink, seq));
        true
    }
}

impl HartFarm {
    /// The first hart's part of frame `seq`: sends every row in order, tracing one itself
    /// whenever the next is not ready.
    fn share<const N: usize>(
        &mut self,
        rows: &Rows<'_, N>,
        sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>,
        seq: u16,
    ) {
        let ex = exchange();
        let (y0, n) = extent(rows);
        let mut tracer = RowTracer::new(rows, port(0));
        // SAFETY: only this hart touches `own`.
        let own = unsafe { &mut *core::ptr::addr_of_mut!((*ex).own) };
        // The row in `own`, with what tracing it found.
        let mut mine: Option<(u16, Option<RowFault>, FrameStats)> = None;
        let mut claims_left = true;
        let mut next = 0u16;
        let mut polls = 0u32;
        // This hart's waits for the next row: since when (`None`: not waiting), and the cycles
        // not yet charged to a row's counters.
        let mut wait_start: Option<u32> = None;
        let mut waited = 0u32;
        while next < n {
            let y = y0.wrapping_add(next);
            if let Some(w) =
                wait_start.take_if(|_| mine.as_ref().is_some_and(|m| m.0 == next) || self.csr.is_ready(next))
            {
                waited = waited.wrapping_add(cycles().wrapping_sub(w));
            }
            let (flow, fault) = if let Some((_, fault, mut stats)) = mine.take_if(|m| m.0 == next) {
                charge_wait(&mut stats, &mut waited);
                (sink(RowDone { y, samples: own, fault, stats }), fault)
            } else if self.workers > 0 && self.csr.is_ready(next) {
                invalidate_dcache();
                // SAFETY: the worker that traced row `next` set its READY bit after writing
                // the slot, and writes it again only after SENT passes it.
                let s = unsafe { &*slot(next) };
                let (fault, mut stats) = (s.fault, s.stats.unwrap_or_default());
                charge_wait(&mut stats, &mut waited);
                let flow = sink(RowDone { y, samples: &s.samples, fault, stats });
                self.csr.clear_ready(next);
                (flow, fault)
            } else if mine.is_none() && (claims_left || self.workers == 0) {
                // The next row is not ready: trace one here meanwhile.
                let k = if self.workers > 0 { self.csr.claim() } else { next };
                if k < n {
                    let started = cycles();
                    if let Some(w) = wait_start.take() {
                        waited = waited.wrapping_add(started.wrapping_sub(w));
                    }
                    let fault = tracer.row(rows, y0.wrapping_add(k), own).err();
                    let mut stats = tracer.take_stats();
                    if self.workers > 0 {
                        charge(&mut stats, 0, cycles().wrapping_sub(started), 0);
                    }
                    mine = Some((k, fault, stats));
                } else {
                    claims_left = false;
                }
                polls = 0;
                continue;
            } else {
                wait_start.get_or_insert_with(cycles);
                pause();
                polls = polls.wrapping_add(1);
                if polls >= WORKER_POLLS || (polls.is_multiple_of(256) && self.trapped()) {
                    // The workers failed: every row from `next` on is traced here.
                    self.give_up();
                    mine = None;
                }
                continue;
            };
            next = next.wrapping_add(1);
            if self.workers > 0 {
                self.csr.set_sent(next);
            }
            polls = 0;
            if flow.is_break() || fault.is_some() {
                break;
            }
        }
        if self.workers > 0 {
            self.end(seq);
        }
    }
}

/// Runs `f` with the stack pointer at the top of this hart's private RAM, then returns to
/// the stack it was called on. Only on a SoC with workers: the first hart has that RAM then
/// (`soc/gridrt_soc/soc.py`). What `f` borrows stays where it is. The frame's loop needs
/// about 27.5 KB of the 32 KiB (read from the disassembly of the litex image: the loop's own
/// frame, 23 KB with its row tracer, then `RayPath::new`'s 4.4 KB; a worker's is alike).
fn on_private_stack(f: &mut dyn FnMut()) {
    extern "C" fn call(f: *mut &mut dyn FnMut()) {
        // SAFETY: the pointer below, to a live `&mut dyn FnMut()`, used once.
        unsafe { (*f)() }
    }
    let mut f = f;
    let arg: *mut &mut dyn FnMut() = &mut f;
    // SAFETY: the RAM is this hart's alone and nothing else lives in it while the first hart
    // runs (a worker's RAM is its own, at the same addresses); s2 is callee-saved, so `call`
    // gives back the caller's stack pointer in it; every caller-saved register is declared
    // clobbered. A trap taken inside `f` runs on the private stack, as a worker's does.
    unsafe {
        core::arch::asm!(
            "mv s2, sp",
            "mv sp, {top}",
            "jalr {call}",
            "mv sp, s2",
            top = in(reg) PRIVATE_STACK_TOP,
            call = in(reg) call as extern "C" fn(*mut &mut dyn FnMut()),
            in("a0") arg,
            out("s2") _,
            clobber_abi("C"),
        );
    }
}
