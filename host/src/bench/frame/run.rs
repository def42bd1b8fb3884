//! The runs behind a frame bench: one frame on a firmware image booted on QEMU, on the
//! loopback simulator with a given timing profile, and on this CPU natively.

use std::collections::{BTreeMap, VecDeque};
use std::io::{Read, Write};
use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use gridrt_coproc::{Coprocessor, KernelKind, NumberFormat, TimingProfile};
use gridrt_firmware::device::{Device, NoClock};
use gridrt_firmware::fsl::DirectKernel;
use gridrt_loopback::{SimConfig, SIM_MAX_VOXELS};
use gridrt_shared::frame::{encode_frame, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{stat, Msg, RenderRequest};

use super::setup::{BenchEvent, FrameBenchError};
use crate::bench::in_process::{read_queued, VecSink};
use crate::scene_image::PreparedScene;
use crate::session::{ProgressEvent, RenderedFrame, Session, SessionConfig};

/// PEs of the qemu-virt board (`firmware/image/src/board.rs`), and of every run here.
pub const QEMU_PE_COUNT: u16 = 4;
/// Words per PE memory of the qemu-virt board: every run uses the same, so the grids agree.
pub const QEMU_PE_MEM_WORDS: u32 = 1 << 19;
/// Both.
const QEMU_PES: (u16, u32) = (QEMU_PE_COUNT, QEMU_PE_MEM_WORDS);

/// How long a device may stay silent during a render or upload.
const STAGE_TIMEOUT: Duration = Duration::from_secs(600);

/// The banner line of the qemu-virt app that measures its timed link (`firmware/image`).
const WRAPPER_LINE: &str = "timed link: ";

/// One frame rendered on one device.
#[derive(Debug, Clone)]
pub struct DeviceRun {
    /// The frame (image, device counters, wire bytes, wall time of the render).
    pub frame: RenderedFrame,
    /// Wire bytes of the scene upload, both directions.
    pub upload_bytes: u64,
    /// Wire bytes of the frame's `Stats` and `FrameEnd` (sent after the last pixel).
    pub tail_bytes: u64,
    /// The qemu-virt link wrapper's own instructions per FSL word, from the app's banner
    /// (`None` for an image without the timed link).
    pub wrapper_per_word: Option<u64>,
    /// What the device printed before its first frame.
    pub banner: String,
    /// Wall time of the render: QEMU's, or this CPU's inside the device (native runs).
    pub wall_ms: f64,
}

impl DeviceRun {
    /// A device counter, 0 when absent.
    pub fn stat(&self, key: u8) -> u64 {
        self.frame.stats.get(&key).copied().unwrap_or(0)
    }

    /// Rays in flight the device reported ([`stat::RAYS_IN_FLIGHT`]), 1 when absent or 0.
    pub fn rays_in_flight(&self) -> u32 {
        self.stat(stat::RAYS_IN_FLIGHT).clamp(1, u32::MAX as u64) as u32
    }
}

/// Wire bytes of `msg` as one frame (header, CRC, COBS, delimiter).
fn wire_len(msg: &Msg<'_>) -> u64 {
    let mut payload = [0u8; MAX_PAYLOAD];
    let mut wire = [0u8; MAX_ENCODED];
    msg.encode(&mut payload)
        .ok()
        .and_then(|n| encode_frame(msg.kind() as u8, 0, &payload[..n], &mut wire).ok())
        .unwrap_or(0) as u64
}

/// Wire bytes of the `Stats` (with these counters) and `FrameEnd` of a frame.
pub fn tail_bytes(frame: u16, stats: &BTreeMap<u8, u64>, spans: u32, crc: u32) -> u64 {
    let mut entries = Vec::with_capacity(stats.len() * 9);
    for (k, v) in stats {
        entries.push(*k);
        entries.extend_from_slice(&v.to_le_bytes());
    }
    wire_len(&Msg::Stats { frame, entries: &entries }) + wire_len(&Msg::FrameEnd { frame, spans, image_crc: crc })
}

/// Hello, upload and one render of `req` on a session; the wall time is measured around the
/// render.
/// `pes`: the PEs and words per PE the grid was built for; the device must have them.
pub(super) fn hello_upload_render<T: Read + Write>(
    session: &mut Session<T>,
    prepared: &PreparedScene,
    req: &RenderRequest,
    run: &str,
    pes: (u16, u32),
    progress: &mut dyn FnMut(BenchEvent),
) -> Result<(RenderedFrame, u64, f64), FrameBenchError> {
    let mut on = |e: ProgressEvent| progress(BenchEvent::Session { run: run.to_string(), event: e });
    let info = session.hello(&mut on)?;
    if (info.pe_count, info.pe_mem_words) != pes {
        return Err(FrameBenchError::Device(format!(
            "{run}: the device has {} PEs of {} words; the bench builds grids for {} of {}",
            info.pe_count, info.pe_mem_words, pes.0, pes.1
        )));
    }
    let (tx, rx) = (session.bytes_tx(), session.bytes_rx());
    session.upload_scene(&prepared.image, &mut on)?;
    let upload_bytes = session.bytes_tx() - tx + session.bytes_rx() - rx;
    // A slow line (QEMU's UART) makes the upload resend chunks; the device's late answers
    // to them must not count as the frame's bytes. A Hello round trip reads them first.
    session.hello(&mut on)?;
    let start = Instant::now();
    let frame = session.render(req, &mut on)?;
    Ok((frame, upload_bytes, start.elapsed().as_secs_f64() * 1e3))
}

pub(super) fn finish(frame: RenderedFrame, upload_bytes: u64, wall_ms: f64, banner: String) -> DeviceRun {
    let tail = tail_bytes(frame.frame, &frame.stats, frame.spans_reported, frame.image_crc);
    let wrapper_per_word = banner.lines().find_map(parse_wrapper_line);
    DeviceRun { frame, upload_bytes, tail_bytes: tail, wrapper_per_word, banner, wall_ms }
}

/// The wrapper's instructions per FSL word from the app's `timed link: …` banner line
/// (`… stay in fsl_io, N of them the wrapper's …`).
fn parse_wrapper_line(line: &str) -> Option<u64> {
    let rest = line.trim().strip_prefix(WRAPPER_LINE)?;
    let (_, after) = rest.split_once("stay in fsl_io, ")?;
    after.split_whitespace().next()?.parse().ok()
}

/// Boots `elf` on QEMU, reads its banner, uploads `prepared` and renders `req` over the
/// UART's pty. QEMU is stopped when this returns.
pub fn run_on_qemu(
    elf: &Path,
    prepared: &PreparedScene,
    req: &RenderRequest,
    run: &str,
    progress: &mut dyn FnMut(BenchEvent),
) -> Result<DeviceRun, FrameBenchError> {
    progress(BenchEvent::Step(format!("{run}: booting {} on QEMU", elf.display())));
    let qemu_lines = Arc::new(std::sync::Mutex::new(Vec::<String>::new()));
    let sink = qemu_lines.clone();
    let machine = gridrt_qemu::Launch::new(elf)
        .boot(Arc::new(move |_, line| sink.lock().unwrap_or_else(|e| e.into_inner()).push(line.to_string())))
        .map_err(|e| FrameBenchError::Qemu(e.to_string()))?;
    let pty = machine.pty().unwrap_or_default().to_string();
    let mut port = crate::serial::open(&pty, 115_200, crate::serial::DEFAULT_READ_TIMEOUT)?;
    let banner = read_banner(&mut port, Duration::from_secs(60)).map_err(|what| {
        let said = qemu_lines.lock().unwrap_or_else(|e| e.into_inner()).join("\n");
        FrameBenchError::Qemu(format!("{run}: {what}; QEMU said: {said}"))
    })?;
    let cfg = SessionConfig::new(pty).render_timeout(STAGE_TIMEOUT);
    let mut session = Session::new(port, cfg);
    let (frame, upload, wall_ms) = hello_upload_render(&mut session, prepared, req, run, QEMU_PES, progress)?;
    drop(machine);
    Ok(finish(frame, upload, wall_ms, banner))
}

/// Reads the device's boot text up to its `0x00` delimiter.
pub(super) fn read_banner(port: &mut dyn Read, timeout: Duration) -> Result<String, String> {
    let deadline = Instant::now() + timeout;
    let mut text = Vec::new();
    let mut buf = [0u8; 256];
    while Instant::now() < deadline {
        match port.read(&mut buf) {
            Ok(0) => return Err("the UART closed during the banner".into()),
            Ok(n) => {
                if let Some(end) = buf[..n].iter().position(|&b| b == 0) {
                    text.extend_from_slice(&buf[..end]);
                    // Bytes after the delimiter would be frames; the app sends none unasked.
                    return Ok(String::from_utf8_lossy(&text).into_owned());
                }
                text.extend_from_slice(&buf[..n]);
            }
            Err(e) if matches!(e.kind(), std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock) => {}
            Err(e) => return Err(format!("reading the banner: {e}")),
        }
    }
    Err(format!("no banner within {} s (got {:?})", timeout.as_secs(), String::from_utf8_lossy(&text)))
}

/// Renders `req` on the loopback simulator with `timing`, its PEs running `kernel`
/// (intersection kernel and number format; cycles kernel-true, [`SimConfig::coproc`]), and
/// the qemu-virt board's PEs.
pub fn run_on_loopback(
    timing: TimingProfile,
    kernel: (KernelKind, NumberFormat),
    prepared: &PreparedScene,
    req: &RenderRequest,
    run: &str,
    progress: &mut dyn FnMut(BenchEvent),
) -> Result<DeviceRun, FrameBenchError> {
    let (kind, format) = kernel;
    progress(BenchEvent::Step(format!("{run}: loopback simulator, {} profile, {kind:?} {format:?}", timing.name)));
    let config = SimConfig {
        pe_count: QEMU_PE_COUNT,
        pe_mem_words: QEMU_PE_MEM_WORDS,
        timing,
        kernel: kind,
        format,
        ..SimConfig::default()
    };
    run_on_loopback_with(config, prepared, req, run, progress)
}

/// Renders `req` on the loopback simulator configured as `config` (e.g.
/// [`SimConfig::RTL`]: `--sim --coproc rtl`).
pub fn run_on_loopback_with(
    config: SimConfig,
    prepared: &PreparedScene,
    req: &RenderRequest,
    run: &str,
    progress: &mut dyn FnMut(BenchEvent),
) -> Result<DeviceRun, FrameBenchError> {
    let mut port = gridrt_loopback::spawn(config);
    port.set_timeout(Duration::from_millis(20));
    let cfg = SessionConfig::new("sim").render_timeout(STAGE_TIMEOUT);
    let mut session = Session::new(port, cfg);
    let pes = (config.pe_count, config.pe_mem_words);
    let (frame, upload, wall_ms) = hello_upload_render(&mut session, prepared, req, run, pes, progress)?;
    Ok(finish(frame, upload, wall_ms, String::new()))
}

type NativeDevice<'m> = Device<DirectKernel<'m>, NoClock, SIM_MAX_VOXELS>;

/// The device on this thread as a byte transport: a write runs the device on the bytes
/// and times it, a read returns what it answered.
struct InProcess<'d, 'm> {
    device: &'d mut NativeDevice<'m>,
    out: VecDeque<u8>,
    busy: Duration,
}

impl Write for InProcess<'_, '_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let start = Instant::now();
        self.device.feed(buf, &mut VecSink(&mut self.out));
        self.busy += start.elapsed();
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Read for InProcess<'_, '_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        read_queued(&mut self.out, buf)
    }
}

/// Renders `req` natively on this CPU, single-threaded: the firmware's device code with the
/// intersection called directly ([`DirectKernel`], the soft-core-only firmware, compiled for
/// this machine), fed through an in-memory transport. After `warmup` untimed frames, the best
/// of `runs` frames is reported; `wall_ms` is the time spent inside the device (rays,
/// shading, span encoding), not the host's decoding.
pub fn run_native(
    prepared: &PreparedScene,
    req: &RenderRequest,
    warmup: u32,
    runs: u32,
    progress: &mut dyn FnMut(BenchEvent),
) -> Result<DeviceRun, FrameBenchError> {
    progress(BenchEvent::Step(format!(
        "host-native: {warmup} warm-up + best of {} frames on this CPU, single thread",
        runs.max(1)
    )));
    let work = || -> Result<DeviceRun, FrameBenchError> {
        let config = SimConfig { pe_count: QEMU_PE_COUNT, pe_mem_words: QEMU_PE_MEM_WORDS, ..SimConfig::default() };
        let coproc = config.coproc();
        let mut backing = vec![0u32; coproc.required_backing_words()];
        let model = Coprocessor::new(coproc, &mut backing)
            .map_err(|e| FrameBenchError::Device(format!("co-processor configuration: {e}")))?;
        let mut device: Box<NativeDevice<'_>> =
            Box::new(Device::new(DirectKernel { model }, NoClock, config.device_info()));
        let port = InProcess { device: &mut device, out: VecDeque::new(), busy: Duration::ZERO };
        let cfg = SessionConfig::new("native").render_timeout(STAGE_TIMEOUT);
        let mut session = Session::new(port, cfg);
        let mut quiet = |_: BenchEvent| {};
        let (mut frame, upload, _) =
            hello_upload_render(&mut session, prepared, req, "host-native", QEMU_PES, &mut quiet)?;
        let mut best = f64::INFINITY;
        for i in 0..warmup + runs.max(1) {
            session.port_mut().busy = Duration::ZERO;
            let next =
                session.render(&RenderRequest { frame: req.frame.wrapping_add(1 + i as u16), ..*req }, &mut |_| {})?;
            if next.rgb != frame.rgb {
                return Err(FrameBenchError::Device("host-native: frames of the same request differ".into()));
            }
            if i >= warmup {
                best = best.min(session.port_mut().busy.as_secs_f64() * 1e3);
            }
            frame = next;
        }
        Ok(finish(frame, upload, best, String::new()))
    };
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("gridrt-native-device".into())
            // The device keeps its voxel map inline, as firmware does in static RAM.
            .stack_size(64 << 20)
            .spawn_scoped(s, work)
            .map_err(|e| FrameBenchError::Device(format!("starting the native device thread: {e}")))?
            .join()
            .unwrap_or_else(|_| Err(FrameBenchError::Device("the native device thread panicked".into())))
    })
}

/// The work counters a QEMU run and the loopback must agree on for the same frame (every one
/// but the cycle and instruction counters, which depend on the machine).
pub const WORK_COUNTERS: [u8; 12] = [
    stat::PRIMARY_RAYS,
    stat::SHADOW_RAYS,
    stat::REFLECTION_RAYS,
    stat::COPROC_RAYS,
    stat::CULLED_RAYS,
    stat::LIST_ENTRIES,
    stat::FSL_WORDS_OUT,
    stat::FSL_WORDS_IN,
    stat::INTERSECTION_TESTS,
    stat::PIXELS,
    stat::FSL_WORDS_PRIMARY,
    stat::FSL_WORDS_SHADOW,
];

/// The work counters on which `a` and `b` differ: `(name, a, b)`.
pub fn work_differences(a: &DeviceRun, b: &DeviceRun) -> Vec<(String, u64, u64)> {
    WORK_COUNTERS
        .iter()
        .filter(|&&k| a.stat(k) != b.stat(k))
        .map(|&k| (crate::stats::stat_name(k), a.stat(k), b.stat(k)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_wrapper_cost_is_read_from_the_apps_banner() {
        let line = "timed link: 36 instructions per FSL word stay in fsl_io, 30 of them the wrapper's (a bare put: 6; a hardware put/get is 1)\r";
        assert_eq!(parse_wrapper_line(line), Some(30));
        assert_eq!(parse_wrapper_line("co-processor: none, the soft-core intersects"), None);
    }

    #[test]
    fn the_tail_is_the_stats_and_frame_end_frames() {
        let stats: BTreeMap<u8, u64> = [(stat::PRIMARY_RAYS, 8u64), (stat::PIXELS, 8)].into_iter().collect();
        // Stats: payload 4 + 2·9 = 22 B; FrameEnd: 12 B. Each frame adds its 6-byte header,
        // the CRC-32 (4 B), one COBS byte (under 254 B) and the delimiter: 12 B.
        assert_eq!(tail_bytes(1, &stats, 2, 0x1234_5678), 22 + 12 + 2 * 12);
    }
}
