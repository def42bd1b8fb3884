//! The co-processor link of each board, and the stage clock that goes with it.
//!
//! - qemu-virt: the co-processor *model* runs on the soft-core itself, as a
//!   [`VirtualCoproc`](gridrt_firmware::fsl::VirtualCoproc) behind `FslLink`. Its work must not
//!   count as firmware work, so [`TimedLink`] measures every call into the model and
//!   [`ModelFreeClock`] subtracts the total from `mcycle`/`minstret` (see [`TimedLink`]).
//! - fpga-soc: the real co-processor behind the AXI4-Stream FIFO ([`AxisLink`]); the plain
//!   counters are the firmware's own.

use core::cell::Cell;

use gridrt_firmware::bsp::CycleCounter;
use gridrt_firmware::device::{StageClock, StageCount, StageStamp};
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

/// Instructions per word that [`TimedLink`] leaves in the firmware's count (its call, the
/// counter reads, the bookkeeping, and `FslLink::put`'s poll loop), measured around 64
/// `put`s into a link that does nothing. The app prints it in its banner; BENCHMARKS.md
/// uses it to bound the FSL I/O stage.
pub fn wrapper_overhead<K: CycleCounter + Copy>(counter: K) -> u64 {
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
    const N: u32 = 64;
    let excluded = Excluded::new();
    let mut link = TimedLink::new(Null, counter, &excluded);
    let clock = ModelFreeClock::new(counter, &excluded);
    let t0 = clock.now();
    for i in 0..N {
        let _ = core::hint::black_box(&mut link).put(FslWord { data: i, control: false }, 1);
    }
    let t1 = clock.now();
    u64::from(t1.instret.wrapping_sub(t0.instret)).checked_div(u64::from(N)).unwrap_or(0)
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
    #[inline(always)]
    fn now(&self) -> StageStamp {
        let instret = self.counter.instret_lo();
        let cycles = self.counter.cycles_lo();
        let ex = self.excluded.get();
        // Low words: the stopwatch only takes wrapping differences.
        StageStamp {
            cycles: cycles.wrapping_sub(ex.cycles as u32),
            instret: instret.wrapping_sub(ex.instret as u32),
        }
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
