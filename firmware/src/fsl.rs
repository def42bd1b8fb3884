//! The co-processor link: an FSL-style stream of 32-bit words with a control bit.
//!
//! [`FslLink`] mirrors MicroBlaze's `nput`/`nget` (non-blocking) and `put`/`get` (blocking)
//! stream instructions. It has two implementations: the MMIO AXI4-Stream FIFO driver in
//! [`crate::bsp`] (real board) and `VirtualCoproc` (the co-processor model linked into the
//! image, for the loopback simulator and the emulated board). The one generic user is the
//! ray path in [`crate::device`].
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

pub use gridrt_shared::fsl::FslWord;

/// Error kinds every link error maps to.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LinkErrorKind {
    /// No word arrived within the poll budget.
    Timeout,
    /// The link hardware reported an error (FIFO overrun, reset, …).
    Hardware,
    /// Something else.
    Other,
}

/// A link error that can say which kind it is.
pub trait LinkError: core::fmt::Debug {
    /// The kind of this error.
    fn kind(&self) -> LinkErrorKind;
}

impl LinkError for core::convert::Infallible {
    fn kind(&self) -> LinkErrorKind {
        match *self {}
    }
}

/// A bidirectional FSL-style word stream to the co-processor.
///
/// # Blocking
/// - [`nput`](FslLink::nput) returns `WouldBlock` when the outbound FIFO is full and never
///   waits; [`nget`](FslLink::nget) returns `WouldBlock` when no word is available and never
///   waits.
/// - [`put`](FslLink::put) / [`get`](FslLink::get) wait until the word is accepted / available,
///   polling at most `max_polls` times, then fail with [`LinkErrorKind::Timeout`]; firmware
///   loops over link data are therefore always bounded.
pub trait FslLink {
    /// Error of this implementation.
    type Error: LinkError;

    /// Non-blocking put (MicroBlaze `nput`/`ncput`).
    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error>;

    /// Non-blocking get (MicroBlaze `nget`/`ncget`).
    fn nget(&mut self) -> nb::Result<FslWord, Self::Error>;

    /// Blocking put with a poll budget.
    fn put(&mut self, word: FslWord, max_polls: u32) -> Result<(), BoundedError<Self::Error>> {
        for _ in 0..max_polls {
            match self.nput(word) {
                Ok(()) => return Ok(()),
                Err(nb::Error::WouldBlock) => continue,
                Err(nb::Error::Other(e)) => return Err(BoundedError::Link(e)),
            }
        }
        Err(BoundedError::Timeout)
    }

    /// Blocking get with a poll budget.
    fn get(&mut self, max_polls: u32) -> Result<FslWord, BoundedError<Self::Error>> {
        for _ in 0..max_polls {
            match self.nget() {
                Ok(w) => return Ok(w),
                Err(nb::Error::WouldBlock) => continue,
                Err(nb::Error::Other(e)) => return Err(BoundedError::Link(e)),
            }
        }
        Err(BoundedError::Timeout)
    }
}

impl<T: FslLink + ?Sized> FslLink for &mut T {
    type Error = T::Error;
    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        (**self).nput(word)
    }
    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        (**self).nget()
    }
}

/// Failure of a bounded blocking call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoundedError<E> {
    /// The poll budget ran out.
    Timeout,
    /// The link reported an error.
    Link(E),
}

impl<E: LinkError> BoundedError<E> {
    /// The kind of this error.
    pub fn kind(&self) -> LinkErrorKind {
        match self {
            Self::Timeout => LinkErrorKind::Timeout,
            Self::Link(e) => e.kind(),
        }
    }
}

/// The co-processor model linked into the firmware as a virtual co-processor.
///
/// `nput` hands the word to the model, which executes a packet as soon as its last word
/// arrives (one ray in flight, like GridRT); `nget` returns the model's queued output words.
#[cfg(feature = "virtual-coproc")]
pub struct VirtualCoproc<'m> {
    /// The model.
    pub model: gridrt_coproc::Coprocessor<'m>,
}

#[cfg(feature = "virtual-coproc")]
impl FslLink for VirtualCoproc<'_> {
    type Error = core::convert::Infallible;

    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        self.model.push(word);
        Ok(())
    }

    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        self.model.pop().ok_or(nb::Error::WouldBlock)
    }
}

/// A ray port onto the co-processor model (`Coprocessor::ray_port`): a second link to the
/// same loaded PEs, for a simulator's row farm.
#[cfg(feature = "virtual-coproc")]
impl FslLink for gridrt_coproc::RayPort<'_> {
    type Error = core::convert::Infallible;

    #[inline]
    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        self.push(word);
        Ok(())
    }

    #[inline]
    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        self.pop().ok_or(nb::Error::WouldBlock)
    }
}
