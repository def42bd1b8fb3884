//! The flash bootloader's protocol (SPEC.md §3.11), I/O agnostic like [`crate::device`].
//!
//! [`Bootloader`] owns a window of memory, the *application region*, given as a byte slice
//! and the address of its first byte. It answers `Hello` (as a device with
//! [`FEATURE_BOOTLOADER`] and [`feature::WINDOWED`] set), accepts one image at a time
//! (`FlashBegin`: version, size, address and entry checks; `FlashData` written where it
//! belongs in any order inside the window, SPEC.md §3.14, or `FlashChunk`s in order; CRC-32
//! read back from memory after the last byte) and, on `FlashBoot` with the verified CRC, returns the entry point
//! from [`Bootloader::feed`]. The caller (the bootloader binary) then jumps there. Every
//! refusal is an `Error` message and leaves the bootloader serving.
//!
//! Answers go to any [`embedded_io::Write`] (blocking `write_all`). An answer whose write
//! fails is lost: it is counted ([`Bootloader::write_errors`]) and the bootloader goes on
//! serving; the host, which waits for every answer, times out and sends its request again.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use core::fmt::Write as _;

use crate::pixels::FrameTx;
use core::ops::ControlFlow;
use embedded_io::Write;
use gridrt_shared::frame::{crc32, FrameAccumulator, FrameError, Received};
use gridrt_shared::msg::{
    feature, DeviceInfo, ErrorCode, FlashError, FlashStatus, Msg, MsgError, MsgType, Sack, FEATURE_BOOTLOADER,
    FLASH_FORMAT_VERSION, MAX_ERROR_TEXT,
};
use gridrt_shared::window::{Arrival, ReceiveWindow};

/// Error text buffer.
type Text = heapless::String<MAX_ERROR_TEXT>;

/// The image being received.
#[derive(Debug, Clone, Copy)]
struct Transfer {
    /// Offset of `load_addr` in the region.
    start: usize,
    total_len: u32,
    crc: u32,
    entry: u32,
    /// What has been written (data goes straight to its address: no buffer, the widest window).
    window: ReceiveWindow,
    verified: bool,
}

/// The bootloader: feed it UART bytes; it writes images into its region and says when to
/// jump.
pub struct Bootloader<'m> {
    rx: FrameAccumulator,
    core: Core<'m>,
}

/// Everything but the receive buffer (split so a received frame can borrow that buffer
/// while its handler writes the region).
struct Core<'m> {
    tx: FrameTx,
    info: DeviceInfo,
    base: u32,
    region: &'m mut [u8],
    xfer: Option<Transfer>,
    /// Answers held back until the input at hand is used up (SPEC.md §3.14): the
    /// `FlashSack` of the last `FlashData`, and a corrupt frame after it.
    held_sack: Option<(FlashStatus, Sack)>,
    held_bad: Option<FrameError>,
    /// The window offered in `FlashSack`s ([`Bootloader::set_window`]).
    window: u16,
}

impl<'m> Bootloader<'m> {
    /// A bootloader whose application region is `region`, starting at address `base`.
    /// `info` supplies firmware version and board; the protocol, payload limit and the
    /// [`FEATURE_BOOTLOADER`] bit are filled in here, and the co-processor fields are 0.
    pub fn new(base: u32, region: &'m mut [u8], info: DeviceInfo) -> Self {
        let info = DeviceInfo {
            protocol: gridrt_shared::PROTOCOL_VERSION as u16,
            max_payload: gridrt_shared::frame::MAX_PAYLOAD as u16,
            pe_count: 0,
            voxel_capacity: 0,
            pe_mem_words: 0,
            features: FEATURE_BOOTLOADER | feature::WINDOWED,
            ..info
        };
        let core = Core {
            tx: FrameTx::new(),
            info,
            base,
            region,
            xfer: None,
            held_sack: None,
            held_bad: None,
            window: u16::MAX,
        };
        Self { rx: FrameAccumulator::new(), core }
    }

    /// Sets the window of a flash transfer, the bytes past the last contiguous one a host may
    /// send before the next `FlashSack` (SPEC.md §3.14; at least 1, default 65 535: data goes
    /// straight to its address). A board whose UART buffers fewer bytes than arrive while a
    /// data frame is written offers one frame's worth, so that no byte arrives while the
    /// bootloader is busy. Applies from the next `FlashBegin`.
    pub fn set_window(&mut self, bytes: u16) {
        self.core.window = bytes.max(1);
    }

    /// What the bootloader reports in `Msg::Version`.
    pub fn info(&self) -> &DeviceInfo {
        &self.core.info
    }

    /// First address of the application region.
    pub fn region_start(&self) -> u32 {
        self.core.base
    }

    /// Size of the application region in bytes.
    pub fn region_len(&self) -> usize {
        self.core.region.len()
    }

    /// The application region (what has been written so far).
    pub fn region(&self) -> &[u8] {
        self.core.region
    }

    /// Answers whose write failed so far (they were lost; see the module docs).
    pub fn write_errors(&self) -> u32 {
        self.core.tx.write_errors()
    }

    /// Processes received bytes. Returns `Some(entry)` once a verified image was asked to
    /// boot (its `FlashAck{Booting}` has been written to `out`); bytes after that frame are
    /// ignored. Partial frames wait for the next call.
    pub fn feed(&mut self, input: &[u8], out: &mut impl Write) -> Option<u32> {
        let core = &mut self.core;
        let entry = self.rx.feed_all(input, |received| match received {
            Received::Frame(frame) => match core.handle(frame.kind, frame.seq, frame.payload, out) {
                Some(entry) => ControlFlow::Break(entry),
                None => ControlFlow::Continue(()),
            },
            Received::Bad(error) => {
                core.held_bad = Some(error);
                ControlFlow::Continue(())
            }
        });
        core.flush(out);
        entry
    }
}

impl Core<'_> {
    /// Sends the answers held back: the `FlashSack`, then the report of a corrupt frame that
    /// came after its data frame.
    fn flush(&mut self, out: &mut impl Write) {
        if let Some((status, sack)) = self.held_sack.take() {
            let _ = self.tx.send(&Msg::FlashSack { status, sack }, out);
        }
        if let Some(e) = self.held_bad.take() {
            let mut t = Text::new();
            let _ = write!(t, "bad frame: {e}");
            let _ = self.tx.send(&Msg::Error { code: ErrorCode::BadFrame, detail: e.code(), text: &t }, out);
        }
    }

    fn send(&mut self, msg: &Msg<'_>, out: &mut impl Write) {
        self.flush(out);
        // Fails on a write error (counted by `tx`; the host asks again, module docs) or on a
        // firmware bug (message larger than a frame): nothing to report either with.
        let _ = self.tx.send(msg, out);
    }

    fn error(&mut self, code: ErrorCode, detail: u32, text: &str, out: &mut impl Write) {
        self.send(&Msg::Error { code, detail, text }, out);
    }

    fn reject(&mut self, e: FlashError, text: &str, out: &mut impl Write) {
        self.error(ErrorCode::FlashRejected, e.code(), text, out);
    }

    fn handle(&mut self, kind: u8, seq: u16, payload: &[u8], out: &mut impl Write) -> Option<u32> {
        if kind != MsgType::FlashData as u8 {
            // Everything else is answered in order, after what was held back.
            self.flush(out);
        }
        let msg = match Msg::decode(kind, payload) {
            Ok(m) => m,
            Err(MsgError::DecodeUnknownType) => {
                self.error(ErrorCode::UnexpectedMessage, kind as u32, "unknown message type", out);
                return None;
            }
            Err(e) => {
                let mut t = Text::new();
                let _ = write!(t, "malformed payload of message {kind:#04x}: {e}");
                self.error(ErrorCode::BadRequest, 0xFFFF_0000 | e.code(), &t, out);
                return None;
            }
        };
        match msg {
            Msg::Hello { .. } => {
                let info = self.info;
                self.send(&Msg::Version(info), out);
            }
            Msg::FlashBegin { version, total_len, crc, load_addr, entry } => {
                self.begin(version, total_len, crc, load_addr, entry, out);
            }
            Msg::FlashChunk { offset, data } => self.data(MsgType::FlashChunk, seq, offset, data, out),
            Msg::FlashData { offset, data } => self.data(MsgType::FlashData, seq, offset, data, out),
            Msg::FlashBoot { crc } => return self.boot(crc, out),
            // Never answer an Error with an Error (SPEC.md §1).
            Msg::Error { .. } => {}
            other => {
                let k = other.kind() as u8;
                self.error(
                    ErrorCode::UnexpectedMessage,
                    k as u32,
                    "this is the bootloader: only Hello and Flash* messages",
                    out,
                );
            }
        }
        None
    }

    fn begin(&mut self, version: u16, total_len: u32, crc: u32, load_addr: u32, entry: u32, out: &mut impl Write) {
        self.xfer = None;
        let mut t = Text::new();
        if version != FLASH_FORMAT_VERSION {
            let _ = write!(t, "flash image format {version}, this bootloader takes {FLASH_FORMAT_VERSION}");
            return self.reject(FlashError::BadVersion, &t, out);
        }
        let len = total_len as usize;
        let (base, size) = (self.base, self.region.len());
        if len == 0 || len > size {
            let _ = write!(t, "image of {total_len} bytes; the application region holds 1..={size}");
            return self.reject(FlashError::TooLarge, &t, out);
        }
        let start = load_addr.wrapping_sub(base) as usize;
        if !load_addr.is_multiple_of(4) || load_addr < base || start.checked_add(len).is_none_or(|end| end > size) {
            let _ = write!(
                t,
                "image {load_addr:#010x}+{total_len:#x} not inside the application region {base:#010x}+{size:#x} (or misaligned)"
            );
            return self.reject(FlashError::BadAddress, &t, out);
        }
        if !entry.is_multiple_of(2) || entry.checked_sub(load_addr).is_none_or(|off| off >= total_len) {
            let _ =
                write!(t, "entry {entry:#010x} not inside the image {load_addr:#010x}+{total_len:#x} (or misaligned)");
            return self.reject(FlashError::BadEntry, &t, out);
        }
        let window = ReceiveWindow::new(total_len, self.window);
        self.xfer = Some(Transfer { start, total_len, crc, entry, window, verified: false });
        self.send(&Msg::FlashAck { next_offset: 0, status: FlashStatus::Receiving, crc: 0 }, out);
    }

    /// `FlashChunk` (in order, answered with `FlashAck`) or `FlashData` (any order inside the
    /// window, answered with `FlashSack`), the frame with sequence number `seq`.
    fn data(&mut self, kind: MsgType, seq: u16, offset: u32, data: &[u8], out: &mut impl Write) {
        let windowed = kind == MsgType::FlashData;
        let Some(mut x) = self.xfer else {
            return self.reject(FlashError::NotBegun, "flash data without FlashBegin", out);
        };
        let next = x.window.next();
        if !windowed && (x.verified || offset != next) {
            return self.error(ErrorCode::BadOffset, next, "flash chunk out of order", out);
        }
        if !x.verified {
            let len = u32::try_from(data.len()).unwrap_or(u32::MAX);
            let arrival = x.window.arrive(offset, len);
            if arrival == Arrival::PastEnd {
                self.xfer = None;
                return self.reject(FlashError::Overrun, "flash data past the end of the image", out);
            }
            if arrival.accepted() {
                let from = x.start.checked_add(offset as usize);
                let Some(dst) = from.and_then(|f| self.region.get_mut(f..)).and_then(|r| r.get_mut(..data.len()))
                else {
                    // Unreachable: begin() checked start + total_len against the region.
                    self.xfer = None;
                    return self.reject(FlashError::BadAddress, "data outside the application region", out);
                };
                dst.copy_from_slice(data);
            }
            if x.window.complete() {
                // Complete: verify what memory now holds, not what we were sent.
                let image = self.region.get(x.start..).and_then(|r| r.get(..x.total_len as usize)).unwrap_or(&[]);
                let got = crc32(image);
                if got != x.crc {
                    self.xfer = None;
                    let mut t = Text::new();
                    let _ = write!(
                        t,
                        "image CRC-32 read back from memory is {got:#010x}, FlashBegin announced {:#010x}",
                        x.crc
                    );
                    return self.reject(FlashError::BadCrc, &t, out);
                }
                x.verified = true;
            }
            self.xfer = Some(x);
        }
        let status = if x.verified { FlashStatus::Verified } else { FlashStatus::Receiving };
        if windowed {
            // Held back: a later data frame of this batch answers for both.
            self.held_sack = Some((status, x.window.sack(seq, x.crc)));
            self.held_bad = None;
        } else {
            let crc = if x.verified { x.crc } else { 0 };
            self.send(&Msg::FlashAck { next_offset: x.window.next(), status, crc }, out);
        }
    }

    fn boot(&mut self, crc: u32, out: &mut impl Write) -> Option<u32> {
        match self.xfer {
            Some(x) if x.verified && x.crc == crc => {
                self.send(&Msg::FlashAck { next_offset: x.total_len, status: FlashStatus::Booting, crc }, out);
                Some(x.entry)
            }
            Some(x) if x.verified => {
                let mut t = Text::new();
                let _ = write!(t, "FlashBoot CRC {crc:#010x} is not the verified image's {:#010x}", x.crc);
                self.reject(FlashError::NotVerified, &t, out);
                None
            }
            _ => {
                self.reject(FlashError::NotVerified, "no verified image to boot", out);
                None
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;
    use gridrt_shared::msg::MsgType;

    fn frame(m: &Msg<'_>) -> Vec<u8> {
        crate::pixels::tests::frame_of(m, 0)
    }

    /// Decoded replies: (type, payload).
    fn replies(bytes: &[u8]) -> Vec<(u8, Vec<u8>)> {
        crate::pixels::tests::frames(bytes).into_iter().map(|(_, kind, payload)| (kind, payload)).collect()
    }

    const BASE: u32 = 0x8010_0000;

    fn info() -> DeviceInfo {
        DeviceInfo {
            protocol: 0,
            firmware: [0, 1, 0],
            board: 1,
            max_payload: 0,
            pe_count: 9,
            voxel_capacity: 9,
            pe_mem_words: 9,
            features: 0,
        }
    }

    fn exchange(b: &mut Bootloader<'_>, m: &Msg<'_>) -> (Option<u32>, Vec<(u8, Vec<u8>)>) {
        let mut out = Vec::new();
        let r = b.feed(&frame(m), &mut out);
        (r, replies(&out))
    }

    fn one(b: &mut Bootloader<'_>, m: &Msg<'_>) -> Msg<'static> {
        let (r, rep) = exchange(b, m);
        assert_eq!(r, None);
        assert_eq!(rep.len(), 1, "{rep:?}");
        let (k, p) = &rep[0];
        let p: &'static [u8] = Box::leak(p.clone().into_boxed_slice());
        Msg::decode(*k, p).unwrap()
    }

    fn rejected(m: Msg<'_>) -> Option<FlashError> {
        match m {
            Msg::Error { code: ErrorCode::FlashRejected, detail, .. } => FlashError::from_code(detail),
            _ => None,
        }
    }

    fn image(n: usize) -> Vec<u8> {
        (0..n).map(|i| (i * 7 + 3) as u8).collect()
    }

    fn begin(img: &[u8], load_addr: u32, entry: u32) -> Msg<'_> {
        Msg::FlashBegin {
            version: FLASH_FORMAT_VERSION,
            total_len: img.len() as u32,
            crc: crc32(img),
            load_addr,
            entry,
        }
    }

    #[test]
    fn hello_reports_a_bootloader() {
        let mut mem = vec![0u8; 4096];
        let mut b = Bootloader::new(BASE, &mut mem, info());
        let Msg::Version(v) = one(&mut b, &Msg::Hello { protocol: 1 }) else { panic!() };
        assert_eq!(v.features, FEATURE_BOOTLOADER | feature::WINDOWED);
        assert_eq!((v.pe_count, v.voxel_capacity, v.board, v.firmware), (0, 0, 1, [0, 1, 0]));
    }

    #[test]
    fn flashes_verifies_and_boots() {
        let mut mem = vec![0u8; 4096];
        let img = image(3000);
        let mut b = Bootloader::new(BASE, &mut mem, info());
        let load = BASE + 64;
        assert_eq!(
            one(&mut b, &begin(&img, load, load + 8)),
            Msg::FlashAck { next_offset: 0, status: FlashStatus::Receiving, crc: 0 }
        );
        let mut off = 0;
        for c in img.chunks(1024) {
            let m = one(&mut b, &Msg::FlashChunk { offset: off, data: c });
            off += c.len() as u32;
            let expect = if off == 3000 {
                Msg::FlashAck { next_offset: 3000, status: FlashStatus::Verified, crc: crc32(&img) }
            } else {
                Msg::FlashAck { next_offset: off, status: FlashStatus::Receiving, crc: 0 }
            };
            assert_eq!(m, expect);
        }
        assert_eq!(rejected(one(&mut b, &Msg::FlashBoot { crc: 1 })), Some(FlashError::NotVerified));
        let (entry, rep) = exchange(&mut b, &Msg::FlashBoot { crc: crc32(&img) });
        assert_eq!(entry, Some(load + 8));
        assert_eq!(
            Msg::decode(rep[0].0, &rep[0].1).unwrap(),
            Msg::FlashAck { next_offset: 3000, status: FlashStatus::Booting, crc: crc32(&img) }
        );
        let mem = b.region();
        assert_eq!(&mem[64..3064], &img[..]);
        assert!(mem[..64].iter().chain(&mem[3064..]).all(|&x| x == 0));
    }

    #[test]
    fn refuses_bad_images_and_stays_alive() {
        let mut mem = vec![0u8; 4096];
        let img = image(100);
        let mut b = Bootloader::new(BASE, &mut mem, info());
        let mut m = begin(&img, BASE, BASE);
        if let Msg::FlashBegin { version, .. } = &mut m {
            *version = 2;
        }
        assert_eq!(rejected(one(&mut b, &m)), Some(FlashError::BadVersion));
        let big = image(4097);
        assert_eq!(rejected(one(&mut b, &begin(&big, BASE, BASE))), Some(FlashError::TooLarge));
        assert_eq!(rejected(one(&mut b, &begin(&[], BASE, BASE))), Some(FlashError::TooLarge));
        for load in [BASE - 4, BASE + 2, BASE + 4000, 0, u32::MAX - 3] {
            assert_eq!(rejected(one(&mut b, &begin(&img, load, load))), Some(FlashError::BadAddress), "{load:#x}");
        }
        for entry in [BASE - 2, BASE + 100, BASE + 1] {
            assert_eq!(rejected(one(&mut b, &begin(&img, BASE, entry))), Some(FlashError::BadEntry), "{entry:#x}");
        }
        assert_eq!(rejected(one(&mut b, &Msg::FlashChunk { offset: 0, data: &img })), Some(FlashError::NotBegun));
        assert_eq!(rejected(one(&mut b, &Msg::FlashBoot { crc: 0 })), Some(FlashError::NotVerified));

        // Corrupted transfer: one byte flipped on the way, CRC of the original announced.
        one(&mut b, &begin(&img, BASE, BASE));
        let mut bad = img.clone();
        bad[50] ^= 0x40;
        assert_eq!(rejected(one(&mut b, &Msg::FlashChunk { offset: 0, data: &bad })), Some(FlashError::BadCrc));
        assert_eq!(rejected(one(&mut b, &Msg::FlashBoot { crc: crc32(&img) })), Some(FlashError::NotVerified));

        // Out of order, overrun.
        one(&mut b, &begin(&img, BASE, BASE));
        let m = one(&mut b, &Msg::FlashChunk { offset: 4, data: &img[4..] });
        assert!(matches!(m, Msg::Error { code: ErrorCode::BadOffset, detail: 0, .. }), "{m:?}");
        assert_eq!(rejected(one(&mut b, &Msg::FlashChunk { offset: 0, data: &big[..101] })), Some(FlashError::Overrun));

        // Not a device: scenes are refused; Errors are not answered; noise is reported.
        let m = one(&mut b, &Msg::SceneBegin { total_len: 4, crc: 0 });
        assert!(matches!(m, Msg::Error { code: ErrorCode::UnexpectedMessage, detail: 0x10, .. }), "{m:?}");
        let (r, rep) = exchange(&mut b, &Msg::Error { code: ErrorCode::BadFrame, detail: 0, text: "" });
        assert_eq!((r, rep.len()), (None, 0));
        let mut out = Vec::new();
        assert_eq!(b.feed(b"gridrt banner noise\r\n\0", &mut out), None);
        assert_eq!(replies(&out)[0].0, MsgType::Error as u8);

        // Still alive: a good image goes through.
        one(&mut b, &begin(&img, BASE, BASE));
        let m = one(&mut b, &Msg::FlashChunk { offset: 0, data: &img });
        assert_eq!(m, Msg::FlashAck { next_offset: 100, status: FlashStatus::Verified, crc: crc32(&img) });
        assert_eq!(exchange(&mut b, &Msg::FlashBoot { crc: crc32(&img) }).0, Some(BASE));
    }

    fn sack(m: Msg<'_>) -> (FlashStatus, gridrt_shared::msg::Sack) {
        match m {
            Msg::FlashSack { status, sack } => (status, sack),
            other => panic!("expected a FlashSack, got {other:?}"),
        }
    }

    #[test]
    fn windowed_data_in_any_order_is_written_verified_and_booted() {
        use rand::{seq::SliceRandom, SeedableRng};
        let img = image(3000);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0xF1A5);
        for round in 0..20 {
            let mut mem = vec![0u8; 4096];
            let mut b = Bootloader::new(BASE, &mut mem, info());
            one(&mut b, &begin(&img, BASE + 8, BASE + 8));
            let mut pieces: Vec<(usize, usize)> = (0..3000).step_by(97).map(|o| (o, 97.min(3000 - o))).collect();
            pieces.shuffle(&mut rng);
            let mut seq = 0u16;
            let mut verified = None;
            // A sender resends what was not taken (more than four gaps at a time are refused).
            let passes = std::iter::repeat_n(pieces.iter(), 40).flatten();
            for &(o, n) in passes {
                if verified.is_some() {
                    break;
                }
                seq += 1;
                let mut out = Vec::new();
                b.feed(
                    &crate::pixels::tests::frame_of(&Msg::FlashData { offset: o as u32, data: &img[o..o + n] }, seq),
                    &mut out,
                );
                let rep = replies(&out);
                let (status, s) = sack(Msg::decode(rep[0].0, &rep[0].1).unwrap());
                assert_eq!((s.heard, s.crc, s.window), (seq, crc32(&img), u16::MAX));
                if status == FlashStatus::Verified {
                    assert_eq!(s.next_offset, 3000);
                    verified.get_or_insert(seq);
                }
            }
            assert!(verified.is_some(), "round {round}");
            assert_eq!(&b.region()[8..3008], &img[..]);
            assert_eq!(exchange(&mut b, &Msg::FlashBoot { crc: crc32(&img) }).0, Some(BASE + 8));
        }
    }

    /// A board that takes one frame at a time offers that window in every `FlashSack`, and
    /// holds nothing beyond it.
    #[test]
    fn the_window_set_is_offered_and_bounds_what_is_held() {
        let mut mem = vec![0u8; 4096];
        let img = image(1000);
        let mut b = Bootloader::new(BASE, &mut mem, info());
        b.set_window(200);
        one(&mut b, &begin(&img, BASE, BASE));
        let (_, s) = sack(one(&mut b, &Msg::FlashData { offset: 0, data: &img[..100] }));
        assert_eq!((s.window, s.next_offset), (200, 100));
        let (_, s) = sack(one(&mut b, &Msg::FlashData { offset: 350, data: &img[350..360] }));
        assert!(s.ranges.as_slice().is_empty(), "beyond the window: not held, {s:?}");
        let (_, s) = sack(one(&mut b, &Msg::FlashData { offset: 250, data: &img[250..260] }));
        assert_eq!(s.ranges.as_slice(), &[(150, 160)][..]);
        b.set_window(0);
        one(&mut b, &begin(&img, BASE, BASE));
        let (_, s) = sack(one(&mut b, &Msg::FlashData { offset: 0, data: &img[..1] }));
        assert_eq!(s.window, 1);
    }

    #[test]
    fn windowed_data_reports_held_ranges_and_refuses_overruns() {
        let mut mem = vec![0u8; 4096];
        let img = image(1000);
        let mut b = Bootloader::new(BASE, &mut mem, info());
        assert_eq!(rejected(one(&mut b, &Msg::FlashData { offset: 0, data: &img })), Some(FlashError::NotBegun));
        one(&mut b, &begin(&img, BASE, BASE));
        let (st, s) = sack(one(&mut b, &Msg::FlashData { offset: 500, data: &img[500..600] }));
        assert_eq!((st, s.next_offset, s.ranges.as_slice()), (FlashStatus::Receiving, 0, &[(500, 600)][..]));
        let (_, s) = sack(one(&mut b, &Msg::FlashData { offset: 0, data: &[] }));
        assert_eq!((s.next_offset, s.ranges.as_slice()), (0, &[(500, 600)][..]));
        // In order, a FlashChunk is still answered with a FlashAck.
        let m = one(&mut b, &Msg::FlashChunk { offset: 0, data: &img[..500] });
        assert_eq!(m, Msg::FlashAck { next_offset: 600, status: FlashStatus::Receiving, crc: 0 });
        assert_eq!(rejected(one(&mut b, &Msg::FlashData { offset: 990, data: &[0; 20] })), Some(FlashError::Overrun));
        assert_eq!(rejected(one(&mut b, &Msg::FlashData { offset: 0, data: &[] })), Some(FlashError::NotBegun));
    }

    #[test]
    fn split_frames_and_several_per_call() {
        let mut mem = vec![0u8; 256];
        let img = image(10);
        let mut b = Bootloader::new(BASE, &mut mem, info());
        let mut bytes = frame(&begin(&img, BASE, BASE));
        bytes.extend(frame(&Msg::FlashChunk { offset: 0, data: &img }));
        bytes.extend(frame(&Msg::FlashBoot { crc: crc32(&img) }));
        bytes.extend(frame(&Msg::Hello { protocol: 1 }));
        let mut out = Vec::new();
        let mut entry = None;
        for c in bytes.chunks(3) {
            if let Some(e) = b.feed(c, &mut out) {
                entry = Some(e);
                break;
            }
        }
        assert_eq!(entry, Some(BASE));
        let kinds: Vec<u8> = replies(&out).iter().map(|r| r.0).collect();
        assert_eq!(kinds, [0x32, 0x32, 0x32]);
    }
}
