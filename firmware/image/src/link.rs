//! The co-processor link of each board, and the stage clock that goes with it.
//!
//! - qemu-virt: the co-processor *model* runs on the soft-core itself, as a
//!   [`VirtualCoproc`](gridrt_firmware::fsl::VirtualCoproc) behind `FslLink`. Its work must not
//!   count as firmware work, so [`TimedLink`] measures every call into the model and
//!   [`ModelFreeClock`] subtracts the total from `mcycle`/`minstret` (see [`TimedLink`]).
//! - fpga-soc: the real co-processor behind the AXI4-Stream FIFO ([`AxisLink`]); the plain
//!   counters are the firmware's own.
//! - litex: the RTL co-processor behind the SoC's CSR FIFOs (`CsrFifoLink`); plain counters.

use core::cell::Cell;

use gridrt_firmware::bsp::CycleCounter;
use gridrt_firmware::device::{ExcludedWork, StageClock, StageStamp};
use gridrt_firmware::fsl::{BoundedError, FslLink, FslWord};

/// Counter time spent inside a co-processor model, shared by [`TimedLink`] (which adds to
/// it) and [`ModelFreeClock`] (which subtracts it), and the number of timed calls.
#[derive(Debug, Default)]
pub struct Excluded {
    cycles: Cell<u64>,
    instret: Cell<u64>,
    calls: Cell<u64>,
    /// Instructions of [`TimedLink`] per timed call outside its counter reads.
    wrapper: Cell<u32>,
    /// What [`ModelFreeClock`] subtracts from the low counter words: the low words of the
    /// excluded cycles and instructions plus `calls × wrapper`, kept by [`Excluded::add`]
    /// (outside the timed reads, so calibrated away with the wrapper), so that a stage lap
    /// pays one subtraction per counter, as a board's clock pays none.
    offset_cycles: Cell<u32>,
    offset_instret: Cell<u32>,
}

impl Excluded {
    /// Nothing excluded yet; no wrapper cost known (see [`Excluded::calibrate`]).
    pub const fn new() -> Self {
        Self {
            cycles: Cell::new(0),
            instret: Cell::new(0),
            calls: Cell::new(0),
            wrapper: Cell::new(0),
            offset_cycles: Cell::new(0),
            offset_instret: Cell::new(0),
        }
    }

    /// Instructions inside the timed calls (the model's work and the wrapper's own inside
    /// its counter reads) and the wrapper's instructions outside them (calls × the
    /// calibrated cost), since boot.
    pub fn totals(&self) -> ExcludedWork {
        let wrapper = self.calls.get().wrapping_mul(u64::from(self.wrapper.get()));
        ExcludedWork { model: self.instret.get(), link_wrapper: wrapper }
    }

    /// Measures the wrapper's own instructions per timed call that fall outside its counter
    /// reads (its call, the first read's set-up, the bookkeeping after the second read) and
    /// subtracts them from then on, so that the FSL I/O stage holds only the firmware's own
    /// work: `N` packet puts through a [`TimedLink`] over a link that does nothing, minus `N`
    /// through that link directly, per call. Deterministic code: the same count every boot.
    pub fn calibrate<K: CycleCounter + Copy>(&self, counter: K) {
        const N: u32 = 16;
        let probe = Excluded::new();
        let clock = ModelFreeClock::new(counter, &probe);
        let mut timed = TimedLink::new(Null, counter, &probe);
        let t0 = clock.now();
        put_empty(&mut timed, N);
        let t1 = clock.now();
        put_empty(&mut Null, N);
        let t2 = clock.now();
        let wrapped = t1.instret.wrapping_sub(t0.instret);
        let plain = t2.instret.wrapping_sub(t1.instret);
        self.wrapper.set(wrapped.saturating_sub(plain).checked_div(N).unwrap_or(0));
        // The calls so far now count the wrapper's cost too (`ModelFreeClock::now` before).
        let w = (self.calls.get() as u32).wrapping_mul(self.wrapper.get());
        self.offset_cycles.set((self.cycles.get() as u32).wrapping_add(w));
        self.offset_instret.set((self.instret.get() as u32).wrapping_add(w));
    }

    /// The calibrated instructions per call ([`Excluded::calibrate`]).
    pub fn wrapper_per_call(&self) -> u32 {
        self.wrapper.get()
    }

    #[inline(always)]
    fn add(&self, from: StageStamp, to: StageStamp) {
        let (c, i) = (self.cycles.get(), self.instret.get());
        let (dc, di) = (to.cycles.wrapping_sub(from.cycles), to.instret.wrapping_sub(from.instret));
        self.cycles.set(c.wrapping_add(u64::from(dc)));
        self.instret.set(i.wrapping_add(u64::from(di)));
        self.calls.set(self.calls.get().wrapping_add(1));
        let w = self.wrapper.get();
        self.offset_cycles.set(self.offset_cycles.get().wrapping_add(dc).wrapping_add(w));
        self.offset_instret.set(self.offset_instret.get().wrapping_add(di).wrapping_add(w));
    }
}

/// A link that takes and gives everything at once, for [`Excluded::calibrate`].
struct Null;

impl FslLink for Null {
    type Error = core::convert::Infallible;
    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        core::hint::black_box(word);
        Ok(())
    }
    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        Ok(FslWord { data: 0, control: true })
    }
}

#[inline(never)]
fn put_empty<L: FslLink>(link: &mut L, n: u32) {
    for _ in 0..n {
        let _ = core::hint::black_box(&mut *link).put_packet(core::hint::black_box(&[]), 1);
    }
}

#[inline(always)]
fn read<K: CycleCounter>(k: &K) -> StageStamp {
    // instret first, then cycles, in both reads: the two measurement points are symmetric.
    let (instret, cycles) = k.instret_cycles_lo();
    StageStamp { cycles, instret }
}

/// What a word costs the firmware on a board with stream registers: one store of the word to
/// the transmit register (and, for an answer, one load from the receive register into the
/// buffer). The emulated board has no such registers, so [`TimedLink`] stores each word of a
/// packet to this RAM word before handing the packet to the model, and loads and stores each
/// answer word once after taking it.
static STREAM_REGISTER: StreamRegister = StreamRegister(core::cell::UnsafeCell::new(0));

struct StreamRegister(core::cell::UnsafeCell<u32>);

// SAFETY: single hart, no interrupts touch it; only volatile accesses whose values are
// never used for anything but the access itself.
unsafe impl Sync for StreamRegister {}

/// A link whose every call into the inner link (the co-processor model) is timed and added
/// to an [`Excluded`] total.
///
/// What is excluded: everything between the counter reads around a call into the inner link,
/// i.e. the co-processor model's own work (executing a packet happens inside the put of its
/// last word) plus the model's call/return, and (once [`Excluded::calibrate`] ran) the
/// wrapper's own instructions outside those reads, a fixed count per call. What stays in the
/// firmware's FSL I/O stage: the firmware's own code, and for whole packets
/// ([`put_packet`](FslLink::put_packet) / [`get_packet`](FslLink::get_packet), what the ray
/// path uses) one volatile store or load per word, the cost of a stream register. Both
/// excluded parts are reported (`Msg::Stats`, [`Excluded::totals`]), never charged.
pub struct TimedLink<'e, L, K> {
    inner: L,
    counter: K,
    excluded: &'e Excluded,
}

impl<'e, L, K> TimedLink<'e, L, K> {
    /// Wraps `inner`; time inside it is added to `excluded`.
    pub fn new(inner: L, counter: K, excluded: &'e Excluded) -> Self {
        Self { inner, counter, excluded }
    }

    /// The wrapped link.
    pub fn inner(&self) -> &L {
        &self.inner
    }
}

impl<L: FslLink, K: CycleCounter> FslLink for TimedLink<'_, L, K> {
    type Error = L::Error;

    #[inline(always)]
    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        let t0 = read(&self.counter);
        let r = self.inner.nput(word);
        self.excluded.add(t0, read(&self.counter));
        r
    }

    #[inline(always)]
    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        let t0 = read(&self.counter);
        let r = self.inner.nget();
        self.excluded.add(t0, read(&self.counter));
        r
    }

    #[inline(always)]
    fn put_packet(&mut self, words: &[u32], max_polls: u32) -> Result<(), BoundedError<Self::Error>> {
        for &w in words {
            // SAFETY: a plain RAM word (see `STREAM_REGISTER`).
            unsafe { STREAM_REGISTER.0.get().write_volatile(w) };
        }
        let t0 = read(&self.counter);
        let r = self.inner.put_packet(words, max_polls);
        self.excluded.add(t0, read(&self.counter));
        r
    }

    #[inline(always)]
    fn get_packet(&mut self, buf: &mut [u32], max_polls: u32) -> Result<(usize, bool), BoundedError<Self::Error>> {
        let t0 = read(&self.counter);
        let r = self.inner.get_packet(buf, max_polls);
        self.excluded.add(t0, read(&self.counter));
        if let Ok((n, _)) = r {
            for slot in buf.iter_mut().take(n) {
                let p: *mut u32 = slot;
                // SAFETY: `p` is a valid, aligned, exclusive reference: one load and one store
                // of the word, as a read of the receive register into `buf` would do.
                unsafe { p.write_volatile(p.read_volatile()) };
            }
        }
        r
    }
}

/// `mcycle`/`minstret` minus the time [`TimedLink`] excluded: the firmware's own counts.
#[derive(Clone)]
pub struct ModelFreeClock<'e, K> {
    counter: K,
    excluded: &'e Excluded,
}

impl<'e, K> ModelFreeClock<'e, K> {
    /// Counts of `counter` minus `excluded`.
    pub fn new(counter: K, excluded: &'e Excluded) -> Self {
        Self { counter, excluded }
    }
}

impl<K: CycleCounter + Clone> StageClock for ModelFreeClock<'_, K> {
    #[inline(always)]
    fn now(&self) -> StageStamp {
        let (instret, cycles) = self.counter.instret_cycles_lo();
        let ex = self.excluded;
        // Low words: the stopwatch only takes wrapping differences. The wrapper's cost
        // outside its reads is charged at one cycle per instruction (exact under QEMU's
        // `-icount shift=0`), in the offsets (`Excluded::add`).
        StageStamp {
            cycles: cycles.wrapping_sub(ex.offset_cycles.get()),
            instret: instret.wrapping_sub(ex.offset_instret.get()),
        }
    }

    fn excluded(&self) -> ExcludedWork {
        self.excluded.totals()
    }
}

#[cfg(feature = "board-fpga-soc")]
pub use axis::{AxisLink, AxisLinkError};

#[cfg(feature = "board-fpga-soc")]
mod axis {
    use gridrt_firmware::bsp::axis_fifo::{AxisFifo, AxisFifoError};
    use gridrt_firmware::bsp::Mmio;
    use gridrt_firmware::fsl::{FslLink, FslWord, LinkError, LinkErrorKind};

    /// A stream FIFO error as a link error (always [`LinkErrorKind::Hardware`]).
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct AxisLinkError(pub AxisFifoError);

    impl LinkError for AxisLinkError {
        fn kind(&self) -> LinkErrorKind {
            LinkErrorKind::Hardware
        }
    }

    /// The AXI4-Stream FIFO to the co-processor as an [`FslLink`] (control bit = TLAST).
    pub struct AxisLink<M: Mmio>(pub AxisFifo<M>);

    impl<M: Mmio> FslLink for AxisLink<M> {
        type Error = AxisLinkError;

        fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
            self.0.nput_word(word.data, word.control).map_err(|e| e.map(AxisLinkError))
        }

        fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
            match self.0.nget_word() {
                Ok((data, control)) => Ok(FslWord { data, control }),
                Err(e) => Err(e.map(AxisLinkError)),
            }
        }
    }
}

#[cfg(feature = "board-litex")]
pub use csr_fifo::{CsrFifoLink, CsrFifoLinkError};

#[cfg(feature = "board-litex")]
mod csr_fifo {
    use gridrt_firmware::bsp::coproc_csr::{CoprocCsr, CoprocCsrError};
    use gridrt_firmware::bsp::Mmio;
    use gridrt_firmware::fsl::{FslLink, FslWord, LinkError, LinkErrorKind};

    /// A CSR FIFO error as a link error (always [`LinkErrorKind::Hardware`]).
    #[derive(Debug, Clone, Copy, PartialEq, Eq)]
    pub struct CsrFifoLinkError(pub CoprocCsrError);

    impl LinkError for CsrFifoLinkError {
        fn kind(&self) -> LinkErrorKind {
            LinkErrorKind::Hardware
        }
    }

    /// The co-processor's CSR FIFOs in the LiteX SoC as an [`FslLink`] (control bit = tlast).
    pub struct CsrFifoLink<M: Mmio>(pub CoprocCsr<M>);

    impl<M: Mmio> FslLink for CsrFifoLink<M> {
        type Error = CsrFifoLinkError;

        fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
            self.0.nput_word(word.data, word.control).map_err(|e| e.map(CsrFifoLinkError))
        }

        fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
            match self.0.nget_word() {
                Ok((data, control)) => Ok(FslWord { data, control }),
                Err(e) => Err(e.map(CsrFifoLinkError)),
            }
        }
    }
}
