//! The co-processor link: an FSL-style stream of 32-bit words with a control bit.
//!
//! [`FslLink`] mirrors MicroBlaze's `nput`/`nget` (non-blocking) and `put`/`get` (blocking)
//! stream instructions. It has three implementations: the MMIO AXI4-Stream FIFO driver in
//! [`crate::bsp`] (real board), `VirtualCoproc` (the co-processor model linked into the
//! image, for the loopback simulator and the emulated board) and `DirectKernel` (no
//! co-processor: the firmware calls the intersection code itself, the soft-core-only
//! configuration of `gridrt bench frame`). The one generic user is the ray path in
//! [`crate::device`].
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

pub use gridrt_shared::fsl::FslWord;
use gridrt_shared::fsl::{FslError, ListEntry, RayKind, RayResult};
use gridrt_shared::math::Ray;

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

    /// Answers a ray without the word stream, on the soft-core itself: `Some` only for a link
    /// that is not a co-processor but the intersection code linked into the firmware
    /// ([`DirectKernel`]); `None`, the default and the answer of every co-processor link, means
    /// "send the request over FSL". The default compiles to nothing.
    #[inline(always)]
    fn trace_direct(
        &mut self,
        _kind: RayKind,
        _ray: &Ray,
        _t_max: f32,
        _list: &[ListEntry],
    ) -> Option<Result<RayResult, FslError>> {
        None
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
    #[inline(always)]
    fn trace_direct(
        &mut self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
    ) -> Option<Result<RayResult, FslError>> {
        (**self).trace_direct(kind, ray, t_max, list)
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

/// No co-processor: the firmware intersects each ray itself by calling the co-processor
/// model's intersection code directly ([`Coprocessor::trace_untimed`](gridrt_coproc::Coprocessor::trace_untimed):
/// the same voxel lookup, kernel and arbitration as the PEs, one entry after the other, no
/// cycle model), through [`FslLink::trace_direct`]. No request or result words are packed
/// or sent; every instruction of the intersection runs on the soft-core and is counted in
/// the `fsl_io` stage (the stage that, with a co-processor, waits for the answer).
///
/// Scene loads (LOAD_PE, CLEAR) still go through the model's word interface, as with
/// [`VirtualCoproc`]: the upload is not part of a frame.
#[cfg(feature = "virtual-coproc")]
pub struct DirectKernel<'m> {
    /// The model whose memories hold the scene and whose intersection code runs.
    pub model: gridrt_coproc::Coprocessor<'m>,
}

#[cfg(feature = "virtual-coproc")]
impl FslLink for DirectKernel<'_> {
    type Error = core::convert::Infallible;

    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        self.model.push(word);
        Ok(())
    }

    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        self.model.pop().ok_or(nb::Error::WouldBlock)
    }

    #[inline(always)]
    fn trace_direct(
        &mut self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
    ) -> Option<Result<RayResult, FslError>> {
        Some(self.model.trace_untimed(kind, ray, t_max, list))
    }
}
