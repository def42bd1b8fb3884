//! Flashing an application through the device's bootloader (SPEC.md §3.11).
//!
//! - [`FlashImage::from_elf`]: the loadable bytes of a RISC-V ELF (`PT_LOAD` segments with file
//!   data, placed by physical address, gaps zero-filled), its load address, entry point and
//!   CRC-32. `.bss` and the stack are not part of the image: the application's start-up code
//!   sets them up.
//! - [`flash`]: `Hello` (the device must be a bootloader, `FEATURE_BOOTLOADER`), then the
//!   windowed transfer of SPEC.md §3.14 — the same protocol and the same sender as the scene
//!   upload ([`crate::session`]): `FlashBegin`, `FlashData` chunks in a window, selective
//!   repeat of what the `FlashSack`s prove lost, chunks sized for the line — until the
//!   bootloader's `Verified` CRC, read back from its memory, which must equal ours; then
//!   `FlashBoot` unless told not to. A bootloader without `WINDOWED` gets stop-and-wait
//!   `FlashChunk`s. Progress goes to a [`FlashEvent`] callback (an `Activity` at least once a
//!   second); refusals come back as [`FlashError::Rejected`] with the bootloader's reason.
//!
//! Transport contract as for [`crate::session`]: `Read + Write`, reads time out quickly.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use gridrt_shared::frame::crc32;
use gridrt_shared::msg::{
    self, feature, DeviceInfo, ErrorCode, FlashStatus, Msg, FEATURE_BOOTLOADER, FLASH_FORMAT_VERSION,
};

use crate::session::transfer::Kind;
use crate::session::{Activity, Incoming, ProgressEvent, Session, SessionConfig, SessionError, Stage};
use object::read::elf::{ElfFile32, FileHeader, ProgramHeader};
use object::Endianness;

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
    /// `FlashBegin` was sent.
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
    /// Where the transfer stands (at least once a second).
    Activity(Activity),
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
    /// The line or the bootloader failed (timeouts name the stage and what was last heard).
    #[error(transparent)]
    Link(#[from] SessionError),
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
}

/// A session error, with the bootloader's refusals as [`FlashError::Rejected`].
fn from_session(e: SessionError) -> FlashError {
    match e {
        SessionError::Device { port, code: ErrorCode::FlashRejected, detail, text, .. } => {
            FlashError::Rejected { port, reason: msg::FlashError::from_code(detail), detail, text }
        }
        e => FlashError::Link(e),
    }
}

/// Settings of [`flash`].
#[derive(Debug, Clone)]
pub struct FlashConfig {
    /// The session: port name, line rate and turnaround (the timers derive from them),
    /// hello timeout, probes.
    pub session: SessionConfig,
    /// Send `FlashBoot` after verification.
    pub boot: bool,
}

impl FlashConfig {
    /// Defaults of [`SessionConfig::new`] for `port_name`, and boot.
    pub fn new(port_name: impl Into<String>) -> Self {
        Self { session: SessionConfig::new(port_name), boot: true }
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
    /// Wire bytes sent and received.
    pub wire: (u64, u64),
}

/// Flashes `image` through the bootloader on `port` (see the module doc).
pub fn flash<T: Read + Write>(
    port: &mut T,
    image: &FlashImage,
    cfg: &FlashConfig,
    progress: &mut dyn FnMut(FlashEvent),
) -> Result<FlashReport, FlashError> {
    let start = Instant::now();
    let name = cfg.session.port_name.clone();
    let total = u32::try_from(image.data.len()).map_err(|_| FlashError::Elf("image larger than 4 GiB".into()))?;
    let mut s = Session::new(&mut *port, cfg.session.clone());
    let info = s.hello(&mut |_| {}).map_err(from_session)?;
    if info.features & FEATURE_BOOTLOADER == 0 {
        return Err(FlashError::NotBootloader { port: name, info });
    }
    progress(FlashEvent::Connected(info));
    let begin = Msg::FlashBegin {
        version: FLASH_FORMAT_VERSION,
        total_len: total,
        crc: image.crc,
        load_addr: image.load_addr,
        entry: image.entry,
    };
    progress(FlashEvent::Started { total: total as u64 });
    let (crc, resent) = if info.features & feature::WINDOWED != 0 {
        let mut on = |e: ProgressEvent| match e {
            ProgressEvent::Uploaded { bytes, total } => progress(FlashEvent::Written { bytes, total }),
            ProgressEvent::Activity(a) => progress(FlashEvent::Activity(a)),
            _ => {}
        };
        let r = s.send_windowed(Kind::Flash, &begin, &image.data, image.crc, &mut on).map_err(from_session)?;
        (r.crc, r.resent)
    } else {
        stop_and_wait(&mut s, &begin, image, progress)?
    };
    if crc != image.crc {
        return Err(FlashError::VerifyMismatch { port: name, device: crc, host: image.crc });
    }
    progress(FlashEvent::Verified { crc });

    let mut booted = false;
    if cfg.boot {
        booted = boot(&mut s, crc)?;
        progress(FlashEvent::Booting { entry: image.entry });
    }
    Ok(FlashReport {
        bootloader: info,
        bytes: total as u64,
        crc,
        booted,
        resent,
        elapsed: start.elapsed(),
        wire: (s.bytes_tx(), s.bytes_rx()),
    })
}

/// `FlashBoot` until the bootloader answers `Booting` (derived waits, `max_probes` tries).
fn boot<T: Read + Write>(s: &mut Session<T>, crc: u32) -> Result<bool, FlashError> {
    let stage = Stage::Flash;
    let start = Instant::now();
    for _ in 0..=s.config().max_probes {
        s.send(stage, &Msg::FlashBoot { crc }).map_err(from_session)?;
        let until = Instant::now() + s.answer_wait(16, 24);
        while let Some(m) = s.poll(stage, until).map_err(from_session)? {
            match m {
                Incoming::FlashAck { status: FlashStatus::Booting, crc: c, .. } if c == crc => return Ok(true),
                Incoming::Error { code: ErrorCode::BadFrame, .. } => break,
                Incoming::Error { code, detail, text } => {
                    return Err(from_session(s.device_err(stage, code, detail, text)))
                }
                _ => {} // late Sacks of the transfer
            }
        }
    }
    Err(FlashError::Link(s.timeout(stage, start.elapsed(), "FlashAck{Booting} in answer to FlashBoot")))
}

/// A bootloader without windowed transfers: `FlashBegin`, then `FlashChunk`s one at a time
/// (resent after a derived wait; a `BadOffset` report resumes where the bootloader is).
/// Returns the verified CRC and the chunks resent.
fn stop_and_wait<T: Read + Write>(
    s: &mut Session<T>,
    begin: &Msg<'_>,
    image: &FlashImage,
    progress: &mut dyn FnMut(FlashEvent),
) -> Result<(u32, u64), FlashError> {
    let stage = Stage::Flash;
    let total = image.data.len() as u32;
    let max_probes = s.config().max_probes;
    let mut tries = 0u32;
    s.write_bytes(stage, &[0]).map_err(from_session)?;
    'begin: loop {
        tries += 1;
        if tries > max_probes {
            return Err(FlashError::Link(s.timeout(stage, Duration::ZERO, "FlashAck in answer to FlashBegin")));
        }
        s.send(stage, begin).map_err(from_session)?;
        let until = Instant::now() + s.answer_wait(32, 24);
        while let Some(m) = s.poll(stage, until).map_err(from_session)? {
            match m {
                Incoming::FlashAck { next_offset: 0, status: FlashStatus::Receiving, .. } => break 'begin,
                Incoming::Error { code: ErrorCode::BadFrame, .. } => continue 'begin,
                Incoming::Error { code, detail, text } => {
                    return Err(from_session(s.device_err(stage, code, detail, text)))
                }
                _ => {}
            }
        }
    }
    let chunk = s.config().chunk_size.clamp(1, 1024);
    let (mut offset, mut resent, mut tries) = (0u32, 0u64, 0u32);
    loop {
        let end = (offset as usize + chunk).min(image.data.len());
        s.send(stage, &Msg::FlashChunk { offset, data: &image.data[offset as usize..end] }).map_err(from_session)?;
        let until = Instant::now() + s.answer_wait(end - offset as usize + 20, 24);
        let answer = loop {
            match s.poll(stage, until).map_err(from_session)? {
                Some(Incoming::FlashAck { next_offset, status, crc }) => break Some((next_offset, status, crc)),
                Some(Incoming::Error { code: ErrorCode::BadOffset, detail, .. }) if detail <= total => {
                    break Some((detail, FlashStatus::Receiving, 0))
                }
                Some(Incoming::Error { code: ErrorCode::BadFrame, .. }) | None => break None,
                Some(Incoming::Error { code, detail, text }) => {
                    return Err(from_session(s.device_err(stage, code, detail, text)))
                }
                Some(_) => {}
            }
        };
        match answer {
            Some((next, FlashStatus::Verified, crc)) if next == total => return Ok((crc, resent)),
            Some((next, FlashStatus::Receiving, _)) if next <= total => {
                if next != end as u32 {
                    resent += 1;
                    progress(FlashEvent::Resent { offset: next as u64 });
                }
                tries = if next > offset { 0 } else { tries + 1 };
                offset = next;
                progress(FlashEvent::Written { bytes: offset as u64, total: total as u64 });
            }
            _ => {
                resent += 1;
                tries += 1;
                progress(FlashEvent::Resent { offset: offset as u64 });
            }
        }
        if tries > max_probes {
            return Err(FlashError::Link(s.timeout(stage, Duration::ZERO, format!("FlashAck for offset {offset}"))));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::SessionConfig;
    use gridrt_firmware::boot::Bootloader;
    use gridrt_firmware::embedded_io;
    use std::collections::VecDeque;
    use std::io::ErrorKind;

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
    /// indices are in `drop_answers`, and the host's writes whose indices are in
    /// `drop_writes`, are lost on the way.
    struct BootFake {
        boot: Bootloader<'static>,
        to_host: VecDeque<u8>,
        booted: Option<u32>,
        drop_answers: Vec<usize>,
        answers: usize,
        drop_writes: Vec<usize>,
        writes: usize,
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
                drop_writes: vec![],
                writes: 0,
            }
        }
    }

    impl Write for BootFake {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            self.writes += 1;
            if self.drop_writes.contains(&(self.writes - 1)) {
                return Ok(buf.len());
            }
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
        let session = SessionConfig::new("fake").turnaround(Duration::from_millis(10)).baud(10_000_000);
        FlashConfig { session, boot: true }
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
    fn lost_answers_are_recovered_without_resending() {
        let mut port = BootFake::new(8192);
        // Answers: 0 Version, 1 Begin ack, 2 the probe's Sack, 3.. chunk Sacks.
        port.drop_answers = vec![3, 4, 6];
        let img = FlashImage::new(BASE, BASE, (0..3000u32).map(|i| (i * 13) as u8).collect());
        let r = flash(&mut port, &img, &cfg(), &mut |_| {}).unwrap();
        assert!(r.booted, "{r:?}");
        assert_eq!(r.resent, 0, "a lost Sack alone is no reason to resend");
        assert_eq!(&port.boot.region()[..3000], &img.data[..]);
    }

    #[test]
    fn lost_chunks_are_resent_selectively() {
        let mut port = BootFake::new(8192);
        // Writes: 0 delimiter, 1 Hello, 2 delimiter, 3 Begin, 4 probe, 5.. chunks.
        port.drop_writes = vec![6, 8];
        let img = FlashImage::new(BASE, BASE, (0..5000u32).map(|i| (i * 7) as u8).collect());
        let r = flash(&mut port, &img, &cfg(), &mut |_| {}).unwrap();
        assert!(r.booted, "{r:?}");
        // The two lost 512-byte chunks go again (in pieces of the chunk size the losses call
        // for) and nothing else: wire bytes are the image, those 1024 bytes and frame overhead.
        assert!((2..=8).contains(&r.resent), "{r:?}");
        assert!(r.wire.0 <= 5000 + 1024 + 40 * 16 + 100, "{r:?}");
        assert_eq!(&port.boot.region()[..5000], &img.data[..]);
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
