//! The simulated board's configuration: the co-processor behind the FSL link (model or RTL)
//! and what the board reports in its Version message.

use gridrt_coproc::{CoprocConfig, KernelKind, NumberFormat, PeCacheConfig, TimingProfile};
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
    /// Cycle model. A multi-cycle profile is charged at the cycles per test of `kernel` in
    /// `format`, what the simulated PEs run ([`SimConfig::coproc`]).
    pub timing: TimingProfile,
    /// Intersection kernel run by every PE.
    pub kernel: KernelKind,
    /// Number format of the kernel.
    pub format: NumberFormat,
    /// What computes: the model, or the RTL (which has its own kernel, format and timing).
    pub backend: Backend,
    /// Threads that trace a frame's rows: 0 = every core (rayon's global pool, shared by
    /// every board of the process), 1 = the device thread alone, as the firmware does. The
    /// UART bytes are the same either way. Frames with row interpolation, and the RTL
    /// backend, always run on the device thread.
    pub threads: u16,
    /// 0 for PE memories in block RAM, N for PE memories in an external memory behind
    /// caches of N 8-word lines (rtl/README.md §4.6; the answers are the same). With
    /// [`Backend::Rtl`] the harness's memory; with [`Backend::Model`] the model's timing of
    /// those caches (`Coprocessor::with_pe_caches`: the cycles the RTL would stand still,
    /// [`SimPort::pe_cache_counts`](crate::SimPort::pe_cache_counts)), which needs the
    /// `rtl` timing and traces every ray on the device thread, in order.
    pub pe_cache_lines: u32,
    /// With PE caches: the external memory's latency in cycles (the harness's
    /// `--mem-latency`; 8 by default).
    pub pe_mem_latency: u32,
}

/// The co-processor of a simulated board.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    /// The Rust model (`gridrt-coproc`).
    #[default]
    Model,
    /// The RTL (`rtl/hdl/`) in Verilator: watertight, fixed64-q23, the `rtl` timing.
    Rtl,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            pe_count: 4,
            pe_mem_words: 1 << 20,
            max_list: 1024,
            timing: TimingProfile::GRIDRT,
            kernel: KernelKind::default(),
            format: NumberFormat::F32,
            backend: Backend::Model,
            threads: 0,
            pe_cache_lines: 0,
            pe_mem_latency: 8,
        }
    }
}

impl SimConfig {
    /// The board with the RTL co-processor as `cargo xtask rtl sim` builds it by default:
    /// 4 PEs of 16 384 words, lists of 256; watertight in fixed64-q23 with the `rtl` timing
    /// (what the model must be set to for the same images and cycles).
    pub const RTL: SimConfig = SimConfig {
        pe_count: 4,
        pe_mem_words: 16_384,
        max_list: 256,
        timing: TimingProfile::RTL,
        kernel: KernelKind::Watertight,
        format: NumberFormat::Fixed64Q23,
        backend: Backend::Rtl,
        threads: 1,
        pe_cache_lines: 0,
        pe_mem_latency: 8,
    };
}

impl SimConfig {
    /// The co-processor configuration for this board. Its cycles are kernel-true: the
    /// profile's test cost is that of the kernel that runs, in the format it runs in
    /// ([`TimingProfile::for_kernel`]), e.g. 1188 cycles per watertight f32 test on GridRT's
    /// PE instead of the 648 of GridRT's own program. Pipelined profiles are unchanged.
    pub fn coproc(&self) -> CoprocConfig {
        CoprocConfig {
            pe_count: self.pe_count,
            pe_mem_words: self.pe_mem_words,
            max_list: self.max_list,
            timing: self.timing.for_kernel(self.kernel, self.format),
            kernel: self.kernel,
        }
    }

    /// The model's PE caches, if this board has them ([`SimConfig::pe_cache_lines`]).
    pub fn pe_caches(&self) -> Option<PeCacheConfig> {
        (self.pe_cache_lines != 0)
            .then_some(PeCacheConfig { lines: self.pe_cache_lines, mem_latency: self.pe_mem_latency })
    }

    /// Words of backing memory the model of this board needs (PE memories, and the
    /// caches' tags when the model times them).
    pub fn model_backing_words(&self) -> usize {
        let c = self.coproc();
        let tags = match (self.backend, self.pe_caches()) {
            (Backend::Model, Some(p)) => p.state_words(c.pe_count),
            _ => 0,
        };
        c.required_backing_words() + tags
    }

    /// Threads the row farm may use: the model with PE caches traces every ray in order,
    /// on the device thread (its caches' state runs from ray to ray).
    pub fn farm_threads(&self) -> u16 {
        if self.backend == Backend::Model && self.pe_cache_lines != 0 {
            1
        } else {
            self.threads
        }
    }

    /// What the simulated device reports in its Version message.
    pub fn device_info(&self) -> DeviceInfo {
        let v = |s: &str| s.parse::<u8>().unwrap_or(0);
        DeviceInfo {
            protocol: gridrt_shared::PROTOCOL_VERSION as u16,
            firmware: [
                v(env!("CARGO_PKG_VERSION_MAJOR")),
                v(env!("CARGO_PKG_VERSION_MINOR")),
                v(env!("CARGO_PKG_VERSION_PATCH")),
            ],
            board: BOARD_LOOPBACK,
            max_payload: MAX_PAYLOAD as u16,
            pe_count: self.pe_count,
            voxel_capacity: SIM_MAX_VOXELS as u32,
            pe_mem_words: self.pe_mem_words,
            // Bytes wait in an in-memory channel or the OS's pty buffer while the device
            // renders: requests sent ahead are answered in order.
            features: gridrt_shared::msg::feature::REQUEST_QUEUE,
        }
    }
}
