//! Two harts per frame on the LiteX SoC built with `--harts 2` (`soc/gridrt_soc/harts.py`):
//! the worker traces every second row of a frame on its own port to the co-processor
//! (`coproc1`), the first hart traces the others on its port and sends every row in order,
//! as the device loop does ([`HartFarm`], a [`RowFarm`]). Each pixel is a pure function of
//! the frame, the scene and the co-processor's memories, so the bytes on the UART are those
//! of one hart.
//!
//! The mailbox words are `gridrt_firmware::bsp::harts`'s (the protocol is written there).
//! The memory the harts share: the frame's [`Rows`] (the first hart's stack: the scene, the
//! frame's context) and [`EXCHANGE`] (the worker's two row slots). VexRiscv's data caches
//! are write-through and not coherent, so a hart invalidates its own ([`invalidate_dcache`])
//! before it reads what the other wrote, and publishes a mailbox word only after a `fence`.
//!
//! If the worker traps or stops answering, the first hart holds it in reset, traces the
//! rest of the frame itself and renders alone from then on.

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::ops::ControlFlow;
use core::sync::atomic::{fence, Ordering};

use gridrt_firmware::bsp::coproc_csr::CoprocCsr;
use gridrt_firmware::bsp::harts::{Done, HartCsr, Job};
use gridrt_firmware::bsp::VolatileMmio;
use gridrt_firmware::device::{FrameStats, RowDone, RowFarm, RowFault, RowTracer, Rows, MAX_IMAGE_DIM};
use gridrt_firmware::interp::Sample;

use crate::board::MAX_VOXELS;
use crate::link::CsrFifoLink;
use crate::litex_map as map;

/// The widest row (the widest frame).
const MAX_ROW: usize = MAX_IMAGE_DIM as usize;
/// Bytes of the worker's stack (in .bss).
const WORKER_STACK_BYTES: usize = 64 << 10;
/// Polls of the worker's `DONE` word before the first hart gives up on it: a CSR read each,
/// far more than any row's time (a row of 4096 pixels at 10⁵ cycles per pixel is 4·10⁸
/// cycles).
const WORKER_POLLS: u32 = 1 << 30;

/// Frames are numbered 1..=MAX_SEQ (15 bits, so that a `DONE` word is never `TRAPPED`).
const MAX_SEQ: u16 = 0x7FFF;

/// One of the worker's rows, handed over.
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
    /// The worker's rows, `j % 2` for its `j`-th.
    slots: [Slot; 2],
    /// The first hart's own row (its stack has no room for one).
    own: [Sample; MAX_ROW],
}

struct Shared(UnsafeCell<MaybeUninit<Exchange>>);

// SAFETY: the two harts touch disjoint parts of it at any time, in the order the mailbox
// protocol sets (module docs).
unsafe impl Sync for Shared {}

/// In .bss (an initialiser would put 144 KiB into the loaded image); [`HartFarm::start`]
/// initialises it before the worker runs.
static EXCHANGE: Shared = Shared(UnsafeCell::new(MaybeUninit::uninit()));

fn exchange() -> *mut Exchange {
    EXCHANGE.0.get().cast()
}

/// Gives [`EXCHANGE`] its first value, field by field (its size would overflow the stack).
fn init_exchange() {
    let ex = exchange();
    // SAFETY: the worker is not running yet; all-zero bytes are valid samples, and the
    // other fields are written whole.
    unsafe {
        core::ptr::addr_of_mut!((*ex).rows).write(core::ptr::null());
        core::ptr::addr_of_mut!((*ex).own).write_bytes(0, 1);
        for j in 0..2 {
            let s = slot(j);
            core::ptr::addr_of_mut!((*s).y).write(0);
            core::ptr::addr_of_mut!((*s).samples).write_bytes(0, 1);
            core::ptr::addr_of_mut!((*s).fault).write(None);
            core::ptr::addr_of_mut!((*s).stats).write(None);
        }
    }
}

#[repr(C, align(16))]
struct Stack([u8; WORKER_STACK_BYTES]);

/// The worker's stack; only `_gridrt_worker_start` takes its address.
static mut WORKER_STACK: Stack = Stack([0; WORKER_STACK_BYTES]);

// The worker's reset vector: riscv-rt's start-up is the first hart's (it zeroes .bss and
// copies .data, which the first hart did before starting the worker), so the worker only
// sets its global pointer, stack and trap vector. Its trap handler publishes
// `Done::TRAPPED` and stops.
core::arch::global_asm!(
    ".section .text.gridrt_worker, \"ax\"",
    ".balign 4",
    ".global _gridrt_worker_start",
    "_gridrt_worker_start:",
    ".option push",
    ".option norelax",
    "la gp, __global_pointer$",
    ".option pop",
    "la sp, {stack}",
    "li t0, {stack_bytes}",
    "add sp, sp, t0",
    "csrw mie, zero",
    "la t0, 2f",
    "csrw mtvec, t0",
    "j {main}",
    ".balign 4",
    "2:",
    "li t0, {done}",
    "li t1, -1",
    "sw t1, 0(t0)",
    "3:",
    "wfi",
    "j 3b",
    stack = sym WORKER_STACK,
    stack_bytes = const WORKER_STACK_BYTES,
    main = sym worker_main,
    done = const map::harts::DONE,
);

extern "C" {
    fn _gridrt_worker_start();
}

/// Drops this hart's data-cache lines (VexRiscv's `0x500F`): the next loads read memory,
/// where the other hart's stores are (write-through).
#[inline(always)]
fn invalidate_dcache() {
    fence(Ordering::SeqCst);
    // SAFETY: VexRiscv's data-cache invalidation; the cache is write-through, so no store
    // is lost. The asm is a compiler barrier (it may touch memory).
    unsafe { core::arch::asm!(".4byte 0x0000500F") };
}

fn hart_csr() -> HartCsr<VolatileMmio> {
    // SAFETY: the SoC's `harts` block (csr.json); its registers are plain words.
    HartCsr::new(unsafe { VolatileMmio::new(map::harts::BASE) })
}

/// The co-processor port at `base` (`coproc` or `coproc1`), without resetting it.
fn port(base: usize) -> CsrFifoLink<VolatileMmio> {
    // SAFETY: a port's CSR FIFOs; each hart uses its own, and the device loop leaves the
    // first one alone while the farm renders.
    CsrFifoLink(CoprocCsr::new(unsafe { VolatileMmio::new(base) }))
}

fn slot(j: u16) -> *mut Slot {
    let ex = exchange();
    // SAFETY: a field of the static; no reference is made.
    unsafe { core::ptr::addr_of_mut!((*ex).slots).cast::<Slot>().add(usize::from(j & 1)) }
}

/// The worker's main loop: waits for a job, traces its rows, reports, forever.
extern "C" fn worker_main() -> ! {
    // Before any f32 arithmetic: a custom instruction on a disabled CFU port traps.
    #[cfg(feature = "cfu-float")]
    gridrt_firmware::sfloat::cfu::enable();
    let csr = hart_csr();
    let mut last = 0u16;
    loop {
        let job = csr.job();
        if job.seq == 0 || job.seq == last || job.cancel {
            continue;
        }
        last = job.seq;
        invalidate_dcache();
        // SAFETY: the first hart wrote the pointer before posting the job, and the rows,
        // scene and frame context it points at stay as they are until this hart reports
        // `finished` (protocol step 4).
        let rows = unsafe { &*(*exchange()).rows };
        let published = trace_rows(&csr, job, rows);
        fence(Ordering::SeqCst);
        csr.report(Done::Rows { seq: job.seq, rows: published, finished: true });
    }
}

/// The worker's rows of a frame (every second one, from the region's second row); returns
/// how many it published.
fn trace_rows(csr: &HartCsr<VolatileMmio>, job: Job, rows: &Rows<'_, MAX_VOXELS>) -> u16 {
    let mut tracer = RowTracer::new(rows, port(map::coproc1::BASE));
    let mut published = 0u16;
    for y in rows.ys().skip(1).step_by(2) {
        // Both slots full: wait until the first hart takes one, or ends the frame.
        loop {
            if csr.job() != job {
                return published;
            }
            if published.wrapping_sub(csr.taken()) < 2 {
                break;
            }
        }
        let s = slot(published);
        // SAFETY: the first hart reads this slot only after this hart publishes it, and has
        // taken its previous row (the wait above).
        let s = unsafe { &mut *s };
        s.y = y;
        s.fault = tracer.row(rows, y, &mut s.samples).err();
        s.stats = Some(tracer.take_stats());
        published = published.wrapping_add(1);
        fence(Ordering::SeqCst);
        csr.report(Done::Rows { seq: job.seq, rows: published, finished: false });
        if s.fault.is_some() {
            break;
        }
    }
    published
}

/// The first hart's side: a [`RowFarm`] that shares each frame with the worker, when the SoC
/// has one.
pub struct HartFarm {
    csr: HartCsr<VolatileMmio>,
    /// The last frame's number.
    seq: u16,
    /// The worker runs and answers.
    worker: bool,
}

impl HartFarm {
    /// Starts the worker if the SoC was built with one.
    pub fn start() -> Self {
        let csr = hart_csr();
        let worker = csr.count() >= 2;
        if worker {
            init_exchange();
            csr.start(_gridrt_worker_start as *const () as usize as u32);
        }
        Self { csr, seq: 0, worker }
    }

    /// Harts that render a frame (1 when the worker is absent or was stopped).
    pub fn harts(&self) -> u32 {
        if self.worker {
            2
        } else {
            1
        }
    }

    /// Waits until the worker published row `j` of frame `seq`; false if it trapped,
    /// stopped short or does not answer.
    fn wait_row(&self, seq: u16, j: u16) -> bool {
        for _ in 0..WORKER_POLLS {
            match self.csr.done() {
                Done::Rows { seq: s, rows, .. } if s == seq && rows > j => return true,
                Done::Rows { seq: s, finished: true, .. } if s == seq => return false,
                Done::Trapped => return false,
                Done::Rows { .. } => {}
            }
        }
        false
    }

    /// Ends frame `seq` for the worker and waits until it has stopped using the frame's
    /// memory; a worker that does not is held in reset.
    fn end(&mut self, seq: u16) {
        self.csr.post(Job { seq, cancel: true });
        for _ in 0..WORKER_POLLS {
            match self.csr.done() {
                Done::Rows { seq: s, finished: true, .. } if s == seq => return,
                Done::Trapped => break,
                Done::Rows { .. } => {}
            }
        }
        self.give_up();
    }

    fn give_up(&mut self) {
        self.csr.stop();
        self.worker = false;
    }
}

impl<L> RowFarm<L> for HartFarm {
    fn render<const N: usize>(
        &mut self,
        _link: &L,
        rows: &Rows<'_, N>,
        sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>,
    ) -> bool {
        if !self.worker || N != MAX_VOXELS || rows.width() > MAX_ROW {
            return false;
        }
        self.seq = if self.seq >= MAX_SEQ { 1 } else { self.seq.wrapping_add(1) };
        let seq = self.seq;
        let ex = exchange();
        // SAFETY: the worker reads the pointer only after the job below is posted, and uses
        // it only until it reports `finished` (`end`, before this function returns). N is
        // MAX_VOXELS (checked above): the cast changes only the lifetime.
        unsafe { (*ex).rows = (rows as *const Rows<'_, N>).cast() };
        self.csr.set_taken(0);
        fence(Ordering::SeqCst);
        self.csr.post(Job { seq, cancel: false });

        let mut own = RowTracer::new(rows, port(map::coproc::BASE));
        // SAFETY: only this hart touches `own`.
        let buf = unsafe { &mut *core::ptr::addr_of_mut!((*ex).own) };
        let mut taken = 0u16;
        for (k, y) in rows.ys().enumerate() {
            let mine = k % 2 == 0 || !self.worker;
            let (flow, fault) = if mine {
                let fault = own.row(rows, y, buf).err();
                (sink(RowDone { y, samples: buf, fault, stats: own.take_stats() }), fault)
            } else if self.wait_row(seq, taken) {
                invalidate_dcache();
                // SAFETY: the worker published this slot (`wait_row`) and will not write it
                // again before `TAKEN` counts it.
                let s = unsafe { &*slot(taken) };
                let done = RowDone { y, samples: &s.samples, fault: s.fault, stats: s.stats.unwrap_or_default() };
                let fault = s.fault;
                let flow = sink(done);
                taken = taken.wrapping_add(1);
                self.csr.set_taken(taken);
                (flow, fault)
            } else {
                // The worker failed: this row and the rest are traced here.
                self.give_up();
                let fault = own.row(rows, y, buf).err();
                (sink(RowDone { y, samples: buf, fault, stats: own.take_stats() }), fault)
            };
            if flow.is_break() || fault.is_some() {
                break;
            }
        }
        if self.worker {
            self.end(seq);
        }
        true
    }
}
