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

    /// Puts a whole packet: every word of `words` with [`put`](FslLink::put), the control bit
    /// on the last one (an empty slice puts nothing). A link with stream registers overrides
    /// this to write the packet in one go; the words on the wire are the same.
    fn put_packet(&mut self, words: &[u32], max_polls: u32) -> Result<(), BoundedError<Self::Error>> {
        let Some((&last, body)) = words.split_last() else { return Ok(()) };
        for &w in body {
            self.put(FslWord::data(w), max_polls)?;
        }
        self.put(FslWord::last(last), max_polls)
    }

    /// Gets one packet into `buf`: words with [`get`](FslLink::get) until one carries the
    /// control bit or `buf` is full. Returns the number of words read and whether the last
    /// of them carried the control bit (false: `buf` filled up first, or `buf` is empty).
    fn get_packet(&mut self, buf: &mut [u32], max_polls: u32) -> Result<(usize, bool), BoundedError<Self::Error>> {
        for (n, slot) in (1..).zip(buf.iter_mut()) {
            let w = self.get(max_polls)?;
            *slot = w.data;
            if w.control {
                return Ok((n, true));
            }
        }
        Ok((buf.len(), false))
    }

    /// True for a link that answers rays itself ([`trace_direct`](FslLink::trace_direct) may
    /// return `Some`): only then does the ray path decode its request words into a list for
    /// it. A compile-time constant, so a co-processor link pays nothing.
    const DIRECT: bool = false;

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
    fn put_packet(&mut self, words: &[u32], max_polls: u32) -> Result<(), BoundedError<Self::Error>> {
        (**self).put_packet(words, max_polls)
    }
    fn get_packet(&mut self, buf: &mut [u32], max_polls: u32) -> Result<(usize, bool), BoundedError<Self::Error>> {
        (**self).get_packet(buf, max_polls)
    }
    const DIRECT: bool = T::DIRECT;
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

/// The word interface of a link whose `model` field is the co-processor model
/// ([`VirtualCoproc`], [`DirectKernel`]): `nput` hands the word to the model, `nget` returns
/// its queued output words; neither can fail.
#[cfg(feature = "virtual-coproc")]
macro_rules! model_word_io {
    () => {
        type Error = core::convert::Infallible;

        fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
            self.model.push(word);
            Ok(())
        }

        fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
            self.model.pop().ok_or(nb::Error::WouldBlock)
        }
    };
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
    model_word_io!();
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
    model_word_io!();

    const DIRECT: bool = true;

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

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;
    use std::collections::VecDeque;

    /// Records what is put; plays back scripted words (`None` = one `WouldBlock`).
    #[derive(Default)]
    struct Script {
        put: Vec<FslWord>,
        get: VecDeque<Option<FslWord>>,
    }

    impl FslLink for Script {
        type Error = core::convert::Infallible;
        fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
            self.put.push(word);
            Ok(())
        }
        fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
            self.get.pop_front().flatten().ok_or(nb::Error::WouldBlock)
        }
    }

    #[test]
    fn a_packet_carries_the_control_bit_on_its_last_word_only() {
        let mut l = Script::default();
        l.put_packet(&[1, 2, 3], 1).unwrap();
        l.put_packet(&[], 1).unwrap();
        l.put_packet(&[4], 1).unwrap();
        let want = [FslWord::data(1), FslWord::data(2), FslWord::last(3), FslWord::last(4)];
        assert_eq!(l.put, want);
    }

    #[test]
    fn a_packet_is_read_up_to_its_control_bit_or_the_end_of_the_buffer() {
        let mut l = Script::default();
        l.get.extend([Some(FslWord::data(7)), None, Some(FslWord::last(8)), Some(FslWord::data(9))]);
        let mut buf = [0; 4];
        assert_eq!(l.get_packet(&mut buf, 2), Ok((2, true)));
        assert_eq!(buf[..2], [7, 8]);
        // The next packet has no control bit within the buffer: it stops there.
        l.get.extend([Some(FslWord::data(10))]);
        assert_eq!(l.get_packet(&mut buf[..2], 1), Ok((2, false)));
        assert_eq!(buf[..2], [9, 10]);
        // Nothing arrives: the poll budget runs out.
        assert_eq!(l.get_packet(&mut buf, 3), Err(BoundedError::Timeout));
        assert_eq!(l.get_packet(&mut [], 1), Ok((0, false)));
    }
}
