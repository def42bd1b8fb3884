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
use gridrt_firmware::device::{StageClock, StageCount};
use gridrt_firmware::fsl::{FslLink, FslWord};

/// Counter time spent inside a co-processor model, shared by [`TimedLink`] (which adds to
/// it) and [`ModelFreeClock`] (which subtracts it).
#[derive(Debug, Default)]
pub struct Excluded(Cell<StageCount>);

impl Excluded {
    /// Nothing excluded yet.
    pub const fn new() -> Self {
        Self(Cell::new(StageCount { cycles: 0, instret: 0 }))
    }

    /// Total time excluded so far.
    pub fn get(&self) -> StageCount {
        self.0.get()
    }

    fn add(&self, from: StageCount, to: StageCount) {
        let t = self.0.get();
        self.0.set(StageCount {
            cycles: t.cycles.wrapping_add(to.cycles.wrapping_sub(from.cycles)),
            instret: t.instret.wrapping_add(to.instret.wrapping_sub(from.instret)),
        });
    }
}

fn read<K: CycleCounter>(k: &K) -> StageCount {
    // instret first, then cycles, in both reads: the two measurement points are symmetric.
    let instret = k.instret();
    StageCount { cycles: k.cycles(), instret }
}

/// A link whose every `nput`/`nget` is timed and added to an [`Excluded`] total.
///
/// What is excluded: everything between the counter reads around the call into the inner
/// link, i.e. the co-processor model's own work (executing a packet happens inside the
/// `nput` of its last word) plus the model's call/return. What stays in the firmware's
/// FSL I/O stage: the firmware's own loop, the `FslLink::put`/`get` poll wrappers, and
/// this wrapper's call and counter reads (a few tens of instructions per word on rv32,
/// where a 64-bit CSR read is a 3-instruction retry loop; a real FSL `put`/`get` is one
/// instruction). The FSL I/O numbers are therefore an upper bound of the firmware's cost
/// per word, and every other stage is exact.
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
}

/// Instructions per FSL word that stay in the firmware's `fsl_io` count around the model
/// (measured at boot on this hart; [`wrapper_cost`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WrapperCost {
    /// A `put` through [`TimedLink`] into a link that does nothing: the poll loop, the call
    /// and the wrapper (its counter reads and bookkeeping).
    pub timed_put: u64,
    /// The same `put` without [`TimedLink`].
    pub bare_put: u64,
}

impl WrapperCost {
    /// The wrapper's own instructions per FSL word: what [`TimedLink`] adds to a `put` or
    /// `get`. Not the firmware's work: `gridrt bench frame` reports it on a line of its own
    /// and takes it out of `fsl_io` (the virtual co-processor never makes the firmware
    /// poll, so every put and get is one wrapped call per word).
    pub fn wrapper(&self) -> u64 {
        self.timed_put.saturating_sub(self.bare_put)
    }
}

/// Measures [`WrapperCost`]: 64 `put`s into a link that does nothing, with and without
/// [`TimedLink`]. The app prints it in its banner (`timed link: ...`); `gridrt bench frame`
/// reads it from there.
pub fn wrapper_cost<K: CycleCounter + Copy>(counter: K) -> WrapperCost {
    struct Null;
    impl FslLink for Null {
        type Error = core::convert::Infallible;
        fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
            core::hint::black_box(word);
            Ok(())
        }
        fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
            Ok(FslWord { data: 0, control: false })
        }
    }
    let excluded = Excluded::new();
    let clock = ModelFreeClock::new(counter, &excluded);
    let timed_put = instructions_per_put(&clock, &mut TimedLink::new(Null, counter, &excluded));
    let bare_put = instructions_per_put(&clock, &mut Null);
    WrapperCost { timed_put, bare_put }
}

/// Instructions per `put` into `link`, over 64 puts.
fn instructions_per_put<C: StageClock, L: FslLink>(clock: &C, link: &mut L) -> u64 {
    const N: u32 = 64;
    let t0 = clock.now();
    for i in 0..N {
        let _ = core::hint::black_box(&mut *link).put(FslWord { data: i, control: false }, 1);
    }
    let t1 = clock.now();
    t1.instret.wrapping_sub(t0.instret).checked_div(u64::from(N)).unwrap_or(0)
}

/// `mcycle`/`minstret` minus the time [`TimedLink`] excluded: the firmware's own counts.
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

impl<K: CycleCounter> StageClock for ModelFreeClock<'_, K> {
    #[inline]
    fn now(&self) -> StageCount {
        let raw = read(&self.counter);
        let ex = self.excluded.get();
        StageCount { cycles: raw.cycles.wrapping_sub(ex.cycles), instret: raw.instret.wrapping_sub(ex.instret) }
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
