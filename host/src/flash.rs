//! Flashing an application through the device's bootloader (SPEC.md §3.11).
//!
//! - [`FlashImage::from_elf`]: the loadable bytes of a RISC-V ELF (`PT_LOAD` segments with file
//!   data, placed by physical address, gaps zero-filled), its load address, entry point and
//!   CRC-32. `.bss` and the stack are not part of the image: the application's start-up code
//!   sets them up.
//! - [`flash`]: `Hello` (the device must be a bootloader, `FEATURE_BOOTLOADER`), `FlashBegin`,
//!   stop-and-wait `FlashChunk`s (resent on silence; a `BadOffset` report resumes where the
//!   bootloader is), the bootloader's `Verified` CRC — read back from its memory — compared
//!   with ours, then `FlashBoot` unless told not to. Progress goes to a [`FlashEvent`]
//!   callback; refusals come back as [`FlashError::Rejected`] with the bootloader's reason.
//!
//! Transport contract as for [`crate::session`]: `Read + Write`, reads time out quickly.

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use gridrt_shared::frame::{crc32, encode_frame, FeedResult, FrameAccumulator, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{self, DeviceInfo, ErrorCode, FlashStatus, Msg, FEATURE_BOOTLOADER, FLASH_FORMAT_VERSION};
use gridrt_shared::PROTOCOL_VERSION;
use object::read::elf::{ElfFile32, FileHeader, ProgramHeader};
use object::Endianness;

/// Largest chunk sent (bytes of image per `FlashChunk`).
pub const MAX_CHUNK: usize = 1024;

/// Largest image accepted from an ELF (the span from the lowest to the highest loaded byte).
pub const MAX_IMAGE: usize = 64 << 20;

/// The loadable bytes of an application.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FlashImage {
    /// Address of `data[0]`.
    pub load_addr: u32,
    /// Entry point (the ELF's `e_entry`).
    pub entry: u32,
    /// The bytes, `load_addr..load_addr + data.len()`.
    pub data: Vec<u8>,
    /// CRC-32 announced in `FlashBegin` (of `data` as built).
    pub crc: u32,
    /// The loaded segments: (physical address, file bytes, memory bytes).
    pub segments: Vec<(u32, u32, u32)>,
}

impl FlashImage {
    /// An image of `data` at `load_addr`, entering at `entry`.
    pub fn new(load_addr: u32, entry: u32, data: Vec<u8>) -> Self {
        let crc = crc32(&data);
        let len = data.len() as u32;
        Self { load_addr, entry, data, crc, segments: vec![(load_addr, len, len)] }
    }

    /// Extracts the image from a 32-bit RISC-V ELF.
    pub fn from_elf(bytes: &[u8]) -> Result<Self, FlashError> {
        let elf =
            ElfFile32::<Endianness>::parse(bytes).map_err(|e| FlashError::Elf(format!("not a 32-bit ELF: {e}")))?;
        let endian = elf.endian();
        let header = elf.elf_header();
        if header.e_machine(endian) != object::elf::EM_RISCV {
            return Err(FlashError::Elf(format!("ELF machine {} is not RISC-V", header.e_machine(endian).0)));
        }
        let entry = header.e_entry(endian);
        let mut segments = vec![];
        for ph in elf.elf_program_headers() {
            if ph.p_type(endian) != object::elf::PT_LOAD || ph.p_filesz(endian) == 0 {
                continue;
            }
            let data = ph.data(endian, bytes).map_err(|()| FlashError::Elf("segment outside the file".into()))?;
            segments.push((ph.p_paddr(endian), ph.p_filesz(endian), ph.p_memsz(endian), data));
        }
        let start = segments
            .iter()
            .map(|s| s.0)
            .min()
            .ok_or_else(|| FlashError::Elf("no loadable segment with data".into()))?;
        let end = segments.iter().map(|s| s.0 as u64 + s.1 as u64).max().unwrap_or(start as u64);
        let len = (end - start as u64) as usize;
        if len > MAX_IMAGE {
            return Err(FlashError::Elf(format!(
                "loadable bytes span {len} bytes (more than {MAX_IMAGE}): segments far apart?"
            )));
        }
        let mut data = vec![0u8; len];
        for (paddr, _, _, bytes) in &segments {
            let off = (paddr - start) as usize;
            data[off..off + bytes.len()].copy_from_slice(bytes);
        }
        if entry < start || entry as u64 >= end {
            return Err(FlashError::Elf(format!(
                "entry {entry:#010x} is outside the loaded bytes {start:#010x}..{end:#010x}"
            )));
        }
        let crc = crc32(&data);
        Ok(Self { load_addr: start, entry, data, crc, segments: segments.iter().map(|s| (s.0, s.1, s.2)).collect() })
    }
}

/// Progress of [`flash`].
#[derive(Debug, Clone, PartialEq)]
pub enum FlashEvent {
    /// The bootloader answered `Hello`.
    Connected(DeviceInfo),
    /// `FlashBegin` was accepted.
    Started {
        /// Image bytes.
        total: u64,
    },
    /// `bytes` of `total` are written.
    Written {
        /// Acknowledged bytes.
        bytes: u64,
        /// Image bytes.
        total: u64,
    },
    /// A chunk was sent again (no answer in time, or the bootloader asked for `offset`).
    Resent {
        /// Offset sending continues from.
        offset: u64,
    },
    /// The bootloader read the image back and its CRC-32 matched ours.
    Verified {
        /// The CRC-32.
        crc: u32,
    },
    /// The bootloader is jumping to the entry point.
    Booting {
        /// The entry point.
        entry: u32,
    },
}

/// Why flashing failed.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum FlashError {
    /// The ELF cannot be flashed.
    #[error("ELF: {0}")]
    Elf(String),
    /// The device did not answer in time.
    #[error("{port}: no answer to {what} within {}ms", waited.as_millis())]
    Timeout {
        /// Port name.
        port: String,
        /// The request.
        what: &'static str,
        /// How long we waited (all attempts).
        waited: Duration,
    },
    /// The device is not in its bootloader.
    #[error("{port}: the device is not a bootloader (firmware {}.{}.{}, board {}, features {:#010x}); reset it into the bootloader first", info.firmware[0], info.firmware[1], info.firmware[2], info.board, info.features)]
    NotBootloader {
        /// Port name.
        port: String,
        /// What it said it is.
        info: DeviceInfo,
    },
    /// The bootloader refused the image.
    #[error("{port}: the bootloader refused the image: {}{text}", reason.map(|r| format!("{r} — ")).unwrap_or_default())]
    Rejected {
        /// Port name.
        port: String,
        /// The reason, if this host knows its number.
        reason: Option<msg::FlashError>,
        /// The `Error.detail`.
        detail: u32,
        /// The bootloader's text.
        text: String,
    },
    /// Some other device error.
    #[error("{port}: device error {code:?} (detail {detail:#x}): {text}")]
    Device {
        /// Port name.
        port: String,
        /// Code.
        code: ErrorCode,
        /// Detail.
        detail: u32,
        /// Text.
        text: String,
    },
    /// The bootloader's read-back CRC differs from ours.
    #[error("{port}: verification failed: the bootloader read back CRC-32 {device:#010x}, the image has {host:#010x}")]
    VerifyMismatch {
        /// Port name.
        port: String,
        /// CRC the bootloader reported.
        device: u32,
        /// Our CRC.
        host: u32,
    },
    /// The device sent something that makes no sense here.
    #[error("{port}: protocol error: {what}")]
    Protocol {
        /// Port name.
        port: String,
        /// What.
        what: String,
    },
    /// The transport failed.
    #[error("{port}: {source}")]
    Io {
        /// Port name.
        port: String,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// Settings of [`flash`].
#[derive(Debug, Clone)]
pub struct FlashConfig {
    /// Port name for messages.
    pub port_name: String,
    /// How long to wait for each answer before resending.
    pub reply_timeout: Duration,
    /// Sends of one request before giving up.
    pub attempts: u32,
    /// Image bytes per chunk (≤ [`MAX_CHUNK`]).
    pub chunk_size: usize,
    /// Send `FlashBoot` after verification.
    pub boot: bool,
}

impl FlashConfig {
    /// Defaults: 2 s per answer, 5 attempts, 1024-byte chunks, boot.
    pub fn new(port_name: impl Into<String>) -> Self {
        Self {
            port_name: port_name.into(),
            reply_timeout: Duration::from_secs(2),
            attempts: 5,
            chunk_size: MAX_CHUNK,
            boot: true,
        }
    }
}

/// What [`flash`] did.
#[derive(Debug, Clone, PartialEq)]
pub struct FlashReport {
    /// The bootloader's `Version`.
    pub bootloader: DeviceInfo,
    /// Image bytes written.
    pub bytes: u64,
    /// CRC-32 verified by the bootloader.
    pub crc: u32,
    /// Whether the bootloader jumped to the image.
    pub booted: bool,
    /// Chunks sent again.
    pub resent: u64,
    /// Wall time.
    pub elapsed: Duration,
}

/// Framed request/answer link over a byte transport.
struct Link<'p, T> {
    port: &'p mut T,
    name: String,
    acc: Box<FrameAccumulator<MAX_ENCODED>>,
    pending: Vec<u8>,
    seq: u16,
}

/// A decoded answer.
#[derive(Debug)]
enum Answer {
    Version(DeviceInfo),
    Ack { next_offset: u32, status: FlashStatus, crc: u32 },
    Error { code: ErrorCode, detail: u32, text: String },
}

impl<T: Read + Write> Link<'_, T> {
    fn io(&self, source: std::io::Error) -> FlashError {
        FlashError::Io { port: self.name.clone(), source }
    }

    fn send(&mut self, m: &Msg<'_>) -> Result<(), FlashError> {
        let mut payload = [0u8; MAX_PAYLOAD];
        let n = m
            .encode(&mut payload)
            .map_err(|e| FlashError::Protocol { port: self.name.clone(), what: e.to_string() })?;
        let mut wire = [0u8; MAX_ENCODED];
        let len = encode_frame(m.kind() as u8, self.seq, &payload[..n], &mut wire)
            .map_err(|e| FlashError::Protocol { port: self.name.clone(), what: e.to_string() })?;
        self.seq = self.seq.wrapping_add(1);
        self.port.write_all(&wire[..len]).map_err(|e| self.io(e))?;
        self.port.flush().map_err(|e| self.io(e))
    }

    /// The next answer before `until`, skipping noise and messages that are not answers.
    fn recv(&mut self, until: Instant) -> Result<Option<Answer>, FlashError> {
        let mut buf = [0u8; 4096];
        loop {
            while !self.pending.is_empty() {
                let (used, answer) = match self.acc.feed(&self.pending) {
                    FeedResult::Consumed => (self.pending.len(), None),
                    FeedResult::Overflow { rest } | FeedResult::BadFrame { rest, .. } => {
                        (self.pending.len() - rest.len(), None)
                    }
                    FeedResult::Frame { frame, rest } => {
                        let a = match Msg::decode(frame.kind, frame.payload) {
                            Ok(Msg::Version(d)) => Some(Answer::Version(d)),
                            Ok(Msg::FlashAck { next_offset, status, crc }) => {
                                Some(Answer::Ack { next_offset, status, crc })
                            }
                            Ok(Msg::Error { code, detail, text }) => {
                                Some(Answer::Error { code, detail, text: text.to_string() })
                            }
                            _ => None,
                        };
                        (self.pending.len() - rest.len(), a)
                    }
                };
                self.pending.drain(..used);
                if answer.is_some() {
                    return Ok(answer);
                }
            }
            if Instant::now() >= until {
                return Ok(None);
            }
            match self.port.read(&mut buf) {
                Ok(0) => return Err(self.io(std::io::Error::new(ErrorKind::UnexpectedEof, "port closed"))),
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::Interrupted) => {}
                Err(e) if e.kind() == ErrorKind::WouldBlock => std::thread::sleep(Duration::from_millis(1)),
                Err(e) => return Err(self.io(e)),
            }
        }
    }
}

fn device_error(port: &str, code: ErrorCode, detail: u32, text: String) -> FlashError {
    if code == ErrorCode::FlashRejected {
        FlashError::Rejected { port: port.to_string(), reason: msg::FlashError::from_code(detail), detail, text }
    } else {
        FlashError::Device { port: port.to_string(), code, detail, text }
    }
}

/// Flashes `image` through the bootloader on `port` (see the module doc).
pub fn flash<T: Read + Write>(
    port: &mut T,
    image: &FlashImage,
    cfg: &FlashConfig,
    progress: &mut dyn FnMut(FlashEvent),
) -> Result<FlashReport, FlashError> {
    let start = Instant::now();
    let name = cfg.port_name.clone();
    let total = u32::try_from(image.data.len()).map_err(|_| FlashError::Elf("image larger than 4 GiB".into()))?;
    let mut link = Link { port, name: name.clone(), acc: Box::new(FrameAccumulator::new()), pending: vec![], seq: 0 };
    let attempts = cfg.attempts.max(1);

    // Hello: a lone delimiter first ends any noise in the bootloader's receiver.
    let mut info = None;
    link.port.write_all(&[0]).map_err(|e| link.io(e))?;
    'hello: for _ in 0..attempts {
        link.send(&Msg::Hello { protocol: PROTOCOL_VERSION as u16 })?;
        let until = Instant::now() + cfg.reply_timeout;
        while let Some(a) = link.recv(until)? {
            match a {
                Answer::Version(d) => {
                    info = Some(d);
                    break 'hello;
                }
                Answer::Error { code: ErrorCode::BadFrame, .. } => {} // noise before our Hello
                Answer::Error { code, detail, text } => return Err(device_error(&name, code, detail, text)),
                Answer::Ack { .. } => {}
            }
        }
    }
    let info = info.ok_or(FlashError::Timeout { port: name.clone(), what: "Hello", waited: start.elapsed() })?;
    if info.features & FEATURE_BOOTLOADER == 0 {
        return Err(FlashError::NotBootloader { port: name, info });
    }
    progress(FlashEvent::Connected(info));

    // Begin.
    let begin = Msg::FlashBegin {
        version: FLASH_FORMAT_VERSION,
        total_len: total,
        crc: image.crc,
        load_addr: image.load_addr,
        entry: image.entry,
    };
    let mut accepted = false;
    let mut wait = cfg.reply_timeout;
    'begin: for _ in 0..attempts {
        link.send(&begin)?;
        let until = Instant::now() + wait;
        loop {
            match link.recv(until)? {
                Some(Answer::Ack { next_offset: 0, status: FlashStatus::Receiving, .. }) => {
                    accepted = true;
                    break 'begin;
                }
                // A slow bootloader's answer to a repeated Hello.
                Some(Answer::Version(_)) => {}
                Some(Answer::Error { code, detail, text }) => return Err(device_error(&name, code, detail, text)),
                Some(other) => {
                    return Err(FlashError::Protocol {
                        port: name,
                        what: format!("unexpected answer to FlashBegin: {other:?}"),
                    })
                }
                None => break,
            }
        }
        wait = wait.saturating_mul(2);
    }
    if !accepted {
        return Err(FlashError::Timeout { port: name, what: "FlashBegin", waited: start.elapsed() });
    }
    progress(FlashEvent::Started { total: total as u64 });

    // Chunks, stop-and-wait.
    let chunk = cfg.chunk_size.clamp(1, MAX_CHUNK.min(info.max_payload.saturating_sub(4).max(1) as usize));
    let mut offset = 0u32;
    let mut resent = 0u64;
    let mut verified_crc = None;
    let mut tries = 0u32;
    // The wait adapts to the bootloader (one simulated cycle by cycle answers a chunk after
    // seconds): twice the last answer's round trip when it needed no resend, at least
    // `reply_timeout`; doubled after each silence, up to 64 `reply_timeout`s.
    let longest = cfg.reply_timeout.saturating_mul(64);
    wait = cfg.reply_timeout;
    while verified_crc.is_none() {
        let end = (offset as usize + chunk).min(image.data.len());
        link.send(&Msg::FlashChunk { offset, data: &image.data[offset as usize..end] })?;
        let sent = Instant::now();
        match link.recv(sent + wait)? {
            Some(Answer::Ack { next_offset, status: FlashStatus::Receiving, .. })
                if next_offset == end as u32 && next_offset < total =>
            {
                if tries == 0 {
                    wait = sent.elapsed().saturating_mul(2).clamp(cfg.reply_timeout, longest);
                }
                offset = next_offset;
                tries = 0;
                progress(FlashEvent::Written { bytes: offset as u64, total: total as u64 });
            }
            Some(Answer::Ack { next_offset, status: FlashStatus::Verified, crc }) if next_offset == total => {
                progress(FlashEvent::Written { bytes: total as u64, total: total as u64 });
                if crc != image.crc {
                    return Err(FlashError::VerifyMismatch { port: name, device: crc, host: image.crc });
                }
                verified_crc = Some(crc);
            }
            Some(Answer::Error { code: ErrorCode::BadOffset, detail, .. }) if detail <= total => {
                // The bootloader is elsewhere (a lost answer or a duplicate): continue there.
                offset = detail;
                resent += 1;
                tries += 1;
                progress(FlashEvent::Resent { offset: offset as u64 });
            }
            // A slow bootloader's answer to a repeated Hello (the chunk goes again, and a
            // duplicate is answered with BadOffset).
            Some(Answer::Version(_)) => {}
            Some(Answer::Error { code, detail, text }) => return Err(device_error(&name, code, detail, text)),
            Some(other) => {
                return Err(FlashError::Protocol {
                    port: name,
                    what: format!("unexpected answer to FlashChunk: {other:?}"),
                })
            }
            None => {
                resent += 1;
                tries += 1;
                wait = wait.saturating_mul(2).min(longest);
                progress(FlashEvent::Resent { offset: offset as u64 });
            }
        }
        if tries >= attempts {
            return Err(FlashError::Timeout { port: name, what: "FlashChunk", waited: start.elapsed() });
        }
    }
    let crc = verified_crc.unwrap_or(image.crc);
    progress(FlashEvent::Verified { crc });

    let mut booted = false;
    if cfg.boot {
        for _ in 0..attempts {
            link.send(&Msg::FlashBoot { crc })?;
            match link.recv(Instant::now() + cfg.reply_timeout)? {
                Some(Answer::Ack { status: FlashStatus::Booting, crc: c, .. }) if c == crc => {
                    booted = true;
                    break;
                }
                Some(Answer::Error { code, detail, text }) => return Err(device_error(&name, code, detail, text)),
                Some(other) => {
                    return Err(FlashError::Protocol {
                        port: name,
                        what: format!("unexpected answer to FlashBoot: {other:?}"),
                    })
                }
                None => {}
            }
        }
        if !booted {
            return Err(FlashError::Timeout { port: name, what: "FlashBoot", waited: start.elapsed() });
        }
        progress(FlashEvent::Booting { entry: image.entry });
    }
    Ok(FlashReport { bootloader: info, bytes: total as u64, crc, booted, resent, elapsed: start.elapsed() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use gridrt_firmware::boot::Bootloader;
    use gridrt_firmware::embedded_io;
    use std::collections::VecDeque;

    const BASE: u32 = 0x8010_0000;

    /// The bootloader's UART: what it writes reaches the host unless `.1` drops it.
    struct Sink<'a>(&'a mut VecDeque<u8>, bool);
    impl embedded_io::ErrorType for Sink<'_> {
        type Error = core::convert::Infallible;
    }
    impl embedded_io::Write for Sink<'_> {
        fn write(&mut self, bytes: &[u8]) -> Result<usize, Self::Error> {
            if !self.1 {
                self.0.extend(bytes);
            }
            Ok(bytes.len())
        }
        fn flush(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }

    /// The fake transport: a real `Bootloader` over leaked memory; the answers whose
    /// indices are in `drop_answers` are lost on the way.
    struct BootFake {
        boot: Bootloader<'static>,
        to_host: VecDeque<u8>,
        booted: Option<u32>,
        drop_answers: Vec<usize>,
        answers: usize,
    }

    impl BootFake {
        fn new(region: usize) -> Self {
            let info = DeviceInfo {
                protocol: 0,
                firmware: [0, 1, 0],
                board: 1,
                max_payload: 0,
                pe_count: 0,
                voxel_capacity: 0,
                pe_mem_words: 0,
                features: 0,
            };
            let mem: &'static mut [u8] = Box::leak(vec![0u8; region].into_boxed_slice());
            Self {
                boot: Bootloader::new(BASE, mem, info),
                to_host: VecDeque::new(),
                booted: None,
                drop_answers: vec![],
                answers: 0,
            }
        }
    }

    impl Write for BootFake {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            if self.booted.is_none() {
                let before = self.to_host.len();
                let drop = self.drop_answers.contains(&self.answers);
                let mut sink = Sink(&mut self.to_host, drop);
                self.booted = self.boot.feed(buf, &mut sink);
                if self.to_host.len() != before || drop {
                    self.answers += 1;
                }
            }
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    impl Read for BootFake {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            if self.to_host.is_empty() {
                return Err(std::io::Error::new(ErrorKind::TimedOut, "nothing"));
            }
            let n = buf.len().min(self.to_host.len());
            for (d, s) in buf.iter_mut().zip(self.to_host.drain(..n)) {
                *d = s;
            }
            Ok(n)
        }
    }

    fn cfg() -> FlashConfig {
        FlashConfig { reply_timeout: Duration::from_millis(20), ..FlashConfig::new("fake") }
    }

    #[test]
    fn flashes_and_boots() {
        let mut port = BootFake::new(8192);
        let img = FlashImage::new(BASE + 16, BASE + 16, (0..5000u32).map(|i| (i % 251) as u8).collect());
        let mut events = vec![];
        let r = flash(&mut port, &img, &cfg(), &mut |e| events.push(e)).unwrap();
        assert!(r.booted);
        assert_eq!((r.bytes, r.crc, r.resent), (5000, img.crc, 0));
        assert_eq!(port.booted, Some(BASE + 16));
        assert_eq!(&port.boot.region()[16..5016], &img.data[..]);
        assert!(matches!(events[0], FlashEvent::Connected(_)));
        assert!(events.contains(&FlashEvent::Verified { crc: img.crc }));
        assert_eq!(events.last(), Some(&FlashEvent::Booting { entry: BASE + 16 }));
    }

    #[test]
    fn lost_answers_are_recovered() {
        let mut port = BootFake::new(8192);
        // Answers: 0 Version, 1 Begin ack, 2.. chunk acks: lose the first two chunk acks.
        port.drop_answers = vec![2, 3];
        let img = FlashImage::new(BASE, BASE, vec![7u8; 3000]);
        let r = flash(&mut port, &img, &cfg(), &mut |_| {}).unwrap();
        assert!(r.booted && r.resent >= 1, "{r:?}");
        assert_eq!(&port.boot.region()[..3000], &img.data[..]);
    }

    #[test]
    fn refusals_are_reported_with_the_reason() {
        let mut port = BootFake::new(1024);
        let img = FlashImage::new(BASE, BASE, vec![1u8; 2000]);
        let e = flash(&mut port, &img, &cfg(), &mut |_| {}).unwrap_err();
        assert!(matches!(e, FlashError::Rejected { reason: Some(msg::FlashError::TooLarge), .. }), "{e}");
        let mut bad = FlashImage::new(BASE, BASE, vec![1u8; 100]);
        bad.data[3] ^= 1; // corrupted after the CRC was taken
        let e = flash(&mut port, &bad, &cfg(), &mut |_| {}).unwrap_err();
        assert!(matches!(e, FlashError::Rejected { reason: Some(msg::FlashError::BadCrc), .. }), "{e}");
        assert!(e.to_string().contains("CRC"), "{e}");
        // Still alive.
        let good = FlashImage::new(BASE, BASE, vec![1u8; 100]);
        assert!(flash(&mut port, &good, &cfg(), &mut |_| {}).unwrap().booted);
    }

    #[test]
    fn an_application_is_not_a_bootloader() {
        let mut port = gridrt_loopback::spawn(gridrt_loopback::SimConfig::default());
        port.set_timeout(Duration::from_millis(20));
        let img = FlashImage::new(BASE, BASE, vec![1u8; 10]);
        let e = flash(&mut port, &img, &cfg(), &mut |_| {}).unwrap_err();
        assert!(matches!(e, FlashError::NotBootloader { .. }), "{e}");
    }

    /// A minimal ELF32 with two PT_LOAD segments (one with a gap) and a NOBITS-like one.
    fn tiny_elf() -> Vec<u8> {
        let mut f = vec![0u8; 0x200];
        f[..4].copy_from_slice(b"\x7fELF");
        f[4] = 1; // 32-bit
        f[5] = 1; // little-endian
        f[6] = 1;
        let w16 = |f: &mut Vec<u8>, o: usize, v: u16| f[o..o + 2].copy_from_slice(&v.to_le_bytes());
        let w32 = |f: &mut Vec<u8>, o: usize, v: u32| f[o..o + 4].copy_from_slice(&v.to_le_bytes());
        w16(&mut f, 16, 2); // ET_EXEC
        w16(&mut f, 18, 243); // EM_RISCV
        w32(&mut f, 20, 1);
        w32(&mut f, 24, 0x8010_0000); // entry
        w32(&mut f, 28, 52); // phoff
        w16(&mut f, 40, 52); // ehsize
        w16(&mut f, 42, 32); // phentsize
        w16(&mut f, 44, 3); // phnum
        let ph = |f: &mut Vec<u8>, i: usize, off: u32, addr: u32, filesz: u32, memsz: u32| {
            let o = 52 + 32 * i;
            f[o..o + 4].copy_from_slice(&1u32.to_le_bytes());
            f[o + 4..o + 8].copy_from_slice(&off.to_le_bytes());
            f[o + 8..o + 12].copy_from_slice(&(addr + 0x1000_0000).to_le_bytes()); // vaddr differs
            f[o + 12..o + 16].copy_from_slice(&addr.to_le_bytes()); // paddr is what counts
            f[o + 16..o + 20].copy_from_slice(&filesz.to_le_bytes());
            f[o + 20..o + 24].copy_from_slice(&memsz.to_le_bytes());
        };
        ph(&mut f, 0, 0x100, 0x8010_0000, 8, 8);
        ph(&mut f, 1, 0x180, 0x8010_0010, 4, 4);
        ph(&mut f, 2, 0x1F0, 0x8010_0100, 0, 0x1000); // .bss: no file bytes
        f[0x100..0x108].copy_from_slice(&[1, 2, 3, 4, 5, 6, 7, 8]);
        f[0x180..0x184].copy_from_slice(&[9, 9, 9, 9]);
        f
    }

    #[test]
    fn elf_segments_by_physical_address() {
        let img = FlashImage::from_elf(&tiny_elf()).unwrap();
        assert_eq!((img.load_addr, img.entry), (0x8010_0000, 0x8010_0000));
        assert_eq!(img.data, [1, 2, 3, 4, 5, 6, 7, 8, 0, 0, 0, 0, 0, 0, 0, 0, 9, 9, 9, 9]);
        assert_eq!(img.crc, crc32(&img.data));
        assert_eq!(img.segments.len(), 2);
        let mut not_riscv = tiny_elf();
        not_riscv[18] = 62;
        assert!(FlashImage::from_elf(&not_riscv).is_err());
        assert!(FlashImage::from_elf(b"not an elf").is_err());
    }
}
