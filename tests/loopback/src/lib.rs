//! Loopback simulator: the firmware's device loop and the co-processor model in one process.
//!
//! The host reaches the simulated board only through [`SimPort`], an in-memory byte stream
//! with the same blocking/timeout behaviour as a serial port: the device thread sees UART
//! bytes, the co-processor sees FSL words, and nothing else crosses.
//!
//! ```text
//! host ──bytes──► SimPort ══channel══► device thread: Device<VirtualCoproc> ──FSL──► Coprocessor
//!      ◄─bytes──         ◄═channel══                 (firmware logic)              (PE model)
//! ```

use std::io;
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::thread::JoinHandle;
use std::time::Duration;

use gridrt_coproc::{CoprocConfig, Coprocessor, KernelKind, TimingProfile};
use gridrt_firmware::device::{ByteSink, Device, NoClock};
use gridrt_firmware::fsl::VirtualCoproc;
use gridrt_shared::frame::MAX_PAYLOAD;
use gridrt_shared::msg::DeviceInfo;

/// Largest grid the simulated device accepts (voxels): 128³.
pub const SIM_MAX_VOXELS: usize = 1 << 21;

/// Board id the simulator reports in its Version message.
pub const BOARD_LOOPBACK: u8 = 0;

/// Configuration of the simulated board.
#[derive(Debug, Clone, Copy)]
pub struct SimConfig {
    /// Processing elements of the co-processor.
    pub pe_count: u16,
    /// Memory per PE in 32-bit words.
    pub pe_mem_words: u32,
    /// Longest traversal list the co-processor accepts.
    pub max_list: u16,
    /// Cycle model.
    pub timing: TimingProfile,
    /// Intersection kernel run by every PE.
    pub kernel: KernelKind,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            pe_count: 4,
            pe_mem_words: 1 << 20,
            max_list: 1024,
            timing: TimingProfile::GRIDRT,
            kernel: KernelKind::default(),
        }
    }
}

impl SimConfig {
    /// The co-processor configuration for this board.
    pub fn coproc(&self) -> CoprocConfig {
        CoprocConfig {
            pe_count: self.pe_count,
            pe_mem_words: self.pe_mem_words,
            max_list: self.max_list,
            timing: self.timing,
            kernel: self.kernel,
        }
    }

    /// What the simulated device reports in its Version message.
    pub fn device_info(&self) -> DeviceInfo {
        let v = |s: &str| s.parse::<u8>().unwrap_or(0);
        DeviceInfo {
            protocol: gridrt_shared::PROTOCOL_VERSION as u16,
            firmware: [v(env!("CARGO_PKG_VERSION_MAJOR")), v(env!("CARGO_PKG_VERSION_MINOR")), v(env!("CARGO_PKG_VERSION_PATCH"))],
            board: BOARD_LOOPBACK,
            max_payload: MAX_PAYLOAD as u16,
            pe_count: self.pe_count,
            voxel_capacity: SIM_MAX_VOXELS as u32,
            pe_mem_words: self.pe_mem_words,
            features: 0,
        }
    }
}

struct ChannelSink<'a>(&'a Sender<Vec<u8>>);

impl ByteSink for ChannelSink<'_> {
    fn write_bytes(&mut self, bytes: &[u8]) {
        // A closed channel means the host went away; the device keeps running until its
        // input closes too, like a board whose UART cable was pulled.
        let _ = self.0.send(bytes.to_vec());
    }
}

/// Runs the device loop on the current thread until `input` closes.
fn run_device(config: SimConfig, input: Receiver<Vec<u8>>, output: Sender<Vec<u8>>) {
    let coproc_config = config.coproc();
    let mut backing = vec![0u32; coproc_config.required_backing_words()];
    let model = match Coprocessor::new(coproc_config, &mut backing) {
        Ok(m) => m,
        Err(e) => {
            // The board cannot start; report it on the line like firmware would, then stop.
            let _ = output.send(format!("loopback: invalid co-processor configuration: {e:?}\n").into_bytes());
            return;
        }
    };
    let mut device: Box<Device<VirtualCoproc<'_>, NoClock, SIM_MAX_VOXELS>> =
        Box::new(Device::new(VirtualCoproc { model }, NoClock, config.device_info()));
    let mut sink = ChannelSink(&output);
    while let Ok(bytes) = input.recv() {
        device.feed(&bytes, &mut sink);
    }
}

/// Starts a simulated board in its own thread and returns the host's end of its UART.
pub fn spawn(config: SimConfig) -> SimPort {
    let (to_device, device_rx) = mpsc::channel::<Vec<u8>>();
    let (device_tx, from_device) = mpsc::channel::<Vec<u8>>();
    let thread = std::thread::Builder::new()
        .name("gridrt-sim-device".into())
        // The device keeps its voxel map inline, as firmware does in static RAM.
        .stack_size(64 << 20)
        .spawn(move || run_device(config, device_rx, device_tx))
        .ok();
    SimPort { to_device: Some(to_device), from_device, pending: Vec::new(), pending_pos: 0, timeout: Duration::from_secs(10), thread }
}

/// Host end of the simulated UART: `Read + Write`, reads time out like a serial port.
#[derive(Debug)]
pub struct SimPort {
    to_device: Option<Sender<Vec<u8>>>,
    from_device: Receiver<Vec<u8>>,
    pending: Vec<u8>,
    pending_pos: usize,
    timeout: Duration,
    thread: Option<JoinHandle<()>>,
}

impl SimPort {
    /// How long a read waits for the first byte before failing with `TimedOut`.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// The current read timeout.
    pub fn timeout(&self) -> Duration {
        self.timeout
    }
}

impl io::Read for SimPort {
    /// Returns buffered bytes at once; otherwise waits up to the timeout for the device.
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        if self.pending_pos >= self.pending.len() {
            match self.from_device.recv_timeout(self.timeout) {
                Ok(bytes) => {
                    self.pending = bytes;
                    self.pending_pos = 0;
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(io::Error::new(io::ErrorKind::TimedOut, "simulated device sent nothing before the timeout"))
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(io::Error::new(io::ErrorKind::ConnectionAborted, "simulated device stopped"))
                }
            }
        }
        let avail = &self.pending[self.pending_pos..];
        let n = avail.len().min(buf.len());
        buf[..n].copy_from_slice(&avail[..n]);
        self.pending_pos += n;
        Ok(n)
    }
}

impl io::Write for SimPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let tx = self.to_device.as_ref().ok_or_else(|| io::Error::new(io::ErrorKind::BrokenPipe, "port closed"))?;
        tx.send(buf.to_vec()).map_err(|_| io::Error::new(io::ErrorKind::BrokenPipe, "simulated device stopped"))?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Drop for SimPort {
    fn drop(&mut self) {
        // Closing the input ends the device loop; wait so no thread outlives the port.
        self.to_device = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
