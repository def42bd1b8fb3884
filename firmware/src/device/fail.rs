//! Why a frame or an upload stopped ([`Fail`]), and how that is reported: the `Msg::Error`
//! code, detail and text (SPEC.md §3.10), formatted without `core::fmt` into a fixed buffer
//! that keeps what fits ([`Trunc`]).

use crate::fsl::{BoundedError, LinkError, LinkErrorKind};
use crate::pixels::TxError;
use crate::text::TextOut;
use gridrt_shared::fsl::{self as wire, op, FslError};
use gridrt_shared::msg::{ErrorCode, MAX_ERROR_TEXT};

/// `Msg::Error` detail of a link timeout (distinct from any ERROR word, whose top nibble is 0xE).
pub const DETAIL_LINK_TIMEOUT: u32 = 0xFFFF_0001;
/// `Msg::Error` detail of a link hardware error.
pub const DETAIL_LINK_HARDWARE: u32 = 0xFFFF_0002;
/// `Msg::Error` detail of any other link error.
pub const DETAIL_LINK_OTHER: u32 = 0xFFFF_0003;

/// `Msg::Error{BadRequest}` detail of a payload that failed to decode: this bit pattern `|` the
/// `MsgError` number (SPEC.md §3.9), so it never collides with a field offset.
pub const DETAIL_MSG_ERROR: u32 = 0xFFFF_0000;

/// Error text buffer (formatted details, ≤ `MAX_ERROR_TEXT`).
pub(super) type Text = heapless::String<MAX_ERROR_TEXT>;

/// [`TextOut`] into a [`Text`] that keeps what fits (whole characters) instead of failing,
/// so a long detail never loses the whole message. (No `core::fmt` on the device: its
/// `write!` machinery costs KBs of the soft-core's code budget; `crate::text`.)
pub(super) struct Trunc<'a>(pub(super) &'a mut Text);

impl TextOut for Trunc<'_> {
    fn put(&mut self, s: &str) {
        // The longest prefix that fits and ends on a character boundary.
        let mut end = s.len().min(self.0.capacity().saturating_sub(self.0.len()));
        // 0 is a boundary, so this stops before it would underflow.
        while !s.is_char_boundary(end) {
            end = end.saturating_sub(1);
        }
        let _ = self.0.push_str(s.get(..end).unwrap_or(""));
    }
}

/// Why a frame or an upload stopped. Small and `Copy` so the per-ray `Result`s stay cheap;
/// the text is formatted only when the error is reported.
#[derive(Debug, Clone, Copy)]
pub(super) enum Fail {
    /// The link failed (timeout, hardware) during `what`.
    Link(LinkErrorKind, &'static str),
    /// The co-processor answered `what` with this word (an ERROR word, or garbage).
    Word(u32, &'static str),
    /// Anything else, reported as is.
    Plain(ErrorCode, u32, &'static str),
    /// Writing to the output failed (already counted by the frame encoder): the frame
    /// stops and nothing more is sent for it, not even an `Error`, which would need the
    /// output that just failed.
    Output,
}

impl Fail {
    /// A link failure during `what`.
    pub(super) fn link<E: LinkError>(e: BoundedError<E>, what: &'static str) -> Self {
        Self::Link(e.kind(), what)
    }

    /// The failure of a frame's span or `Stats` that could not be sent.
    pub(super) fn tx(e: TxError) -> Self {
        match e {
            TxError::Write(_) => Self::Output,
            TxError::Msg(_) | TxError::Frame(_) => Self::Plain(ErrorCode::BadRequest, 0, "frame encoder failure"),
        }
    }

    /// The `Msg::Error` code and detail that report this failure.
    pub(super) fn code_detail(self) -> (ErrorCode, u32) {
        match self {
            Self::Link(LinkErrorKind::Timeout, _) => (ErrorCode::Coprocessor, DETAIL_LINK_TIMEOUT),
            Self::Link(LinkErrorKind::Hardware, _) => (ErrorCode::Coprocessor, DETAIL_LINK_HARDWARE),
            Self::Link(_, _) => (ErrorCode::Coprocessor, DETAIL_LINK_OTHER),
            Self::Word(w, _) => (ErrorCode::Coprocessor, w),
            Self::Plain(c, d, _) => (c, d),
            Self::Output => (ErrorCode::BadRequest, 0),
        }
    }

    /// Appends the `Msg::Error` text that reports this failure (what fits).
    pub(super) fn describe(self, t: &mut Text) {
        let mut w = Trunc(t);
        match self {
            Self::Link(kind, what) => {
                let why = match kind {
                    LinkErrorKind::Timeout => "timeout",
                    LinkErrorKind::Hardware => "hardware error",
                    _ => "error",
                };
                for s in ["FSL link ", why, " on ", what] {
                    w.put(s);
                }
            }
            Self::Word(word, what) if wire::opcode(word) == op::ERROR => {
                let (e, detail) = FslError::from_word(word);
                for s in ["co-processor error on ", what, ": ", e.as_str(), " (detail "] {
                    w.put(s);
                }
                w.put_dec(detail as u64);
                w.put(")");
            }
            Self::Word(word, what) => {
                w.put("unexpected word ");
                w.put_hex(word, 8);
                w.put(" on ");
                w.put(what);
            }
            Self::Plain(_, _, text) => w.put(text),
            Self::Output => w.put("output write error"),
        }
    }
}
