//! Line rate, timers, flow control and chunk sizes of a session.
//!
//! # Timers
//! Every retransmission timer is derived from the line rate and the bytes an answer needs:
//! waiting for an answer to `out` bytes that is `back` bytes long takes
//! [`SessionConfig::answer_wait`] = 2 × the wire time of `out + back` bytes at `baud`
//! (8N1: 10 bit times per byte) plus [`SessionConfig::turnaround`] (the operating system, a
//! USB adapter or relay, the device's own handling). Only two limits are plain durations:
//! [`SessionConfig::hello_timeout`], how long a device may take to boot, and
//! [`SessionConfig::render_timeout`], how long a device may compute without sending a pixel
//! (ray work, not the line). A stage gives up after [`SessionConfig::max_probes`] derived
//! waits in a row without an answer.

use std::time::Duration;

/// Largest scene chunk the host sends: a whole frame's payload (2048 − the 4-byte offset).
pub const MAX_CHUNK: usize = 2044;

/// Smallest chunk the adaptive chunk size goes down to.
pub const MIN_CHUNK: usize = 16;

/// Timers and flow control of a session. Setters are builder-style.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionConfig {
    /// Name of the port, used in error messages.
    pub port_name: String,
    /// Line rate (8N1) the timers are derived from.
    pub baud: u32,
    /// Allowance per exchange on top of the wire time.
    pub turnaround: Duration,
    /// Total time to wait for `Version` (the device may be booting).
    pub hello_timeout: Duration,
    /// Longest time a render may go without a new pixel (device ray work) before it fails.
    pub render_timeout: Duration,
    /// Derived waits in a row without any answer before a stage fails.
    pub max_probes: u32,
    /// Largest scene chunk in bytes (capped at [`MAX_CHUNK`] and the device's payload limit).
    pub chunk_size: usize,
    /// Chunks in flight for a device without windowed transfers (go-back-N).
    pub window: usize,
    /// Render with `RenderRegion` (selective repeat, reset recovery) when the device
    /// supports it; `false` sends one whole-frame `RenderRequest`.
    pub regions: bool,
    /// Rows per region when a frame is rendered with regions (0 = the whole frame).
    pub band_rows: u16,
    /// Requests per band before it fails.
    pub max_requests_per_band: u32,
}

impl SessionConfig {
    /// Defaults for a port called `port_name`: 115 200 baud, 30 ms turnaround, hello 3 s,
    /// render 30 s without a pixel, 10 probes, 2044-byte chunks at most, regions.
    pub fn new(port_name: impl Into<String>) -> Self {
        Self {
            port_name: port_name.into(),
            baud: 115_200,
            turnaround: Duration::from_millis(30),
            hello_timeout: Duration::from_secs(3),
            render_timeout: Duration::from_secs(30),
            max_probes: 10,
            chunk_size: MAX_CHUNK,
            window: 4,
            regions: true,
            band_rows: 0,
            max_requests_per_band: 100_000,
        }
    }

    /// Wire time of `bytes` bytes at [`Self::baud`] (8N1).
    pub fn wire_time(&self, bytes: usize) -> Duration {
        Duration::from_secs_f64(bytes as f64 * 10.0 / self.baud.max(1) as f64)
    }

    /// How long an answer of `back` bytes to `out` bytes may take: twice their wire time
    /// plus the turnaround.
    pub fn answer_wait(&self, out: usize, back: usize) -> Duration {
        2 * self.wire_time(out + back) + self.turnaround
    }

    /// Sets the line rate the timers are derived from.
    #[must_use]
    pub fn baud(mut self, baud: u32) -> Self {
        self.baud = baud.max(1);
        self
    }
    /// Sets the turnaround allowance.
    #[must_use]
    pub fn turnaround(mut self, d: Duration) -> Self {
        self.turnaround = d;
        self
    }
    /// Chooses regions or one whole-frame `RenderRequest` (see [`Self::regions`]).
    #[must_use]
    pub fn regions(mut self, on: bool) -> Self {
        self.regions = on;
        self
    }
    /// Sets the rows per region (0 = whole frame).
    #[must_use]
    pub fn band_rows(mut self, rows: u16) -> Self {
        self.band_rows = rows;
        self
    }
    /// Sets the request budget per band.
    #[must_use]
    pub fn max_requests_per_band(mut self, n: u32) -> Self {
        self.max_requests_per_band = n.max(1);
        self
    }
    /// Sets the unanswered waits in a row a stage allows.
    #[must_use]
    pub fn max_probes(mut self, n: u32) -> Self {
        self.max_probes = n.max(1);
        self
    }
    /// Sets the hello timeout.
    #[must_use]
    pub fn hello_timeout(mut self, d: Duration) -> Self {
        self.hello_timeout = d;
        self
    }
    /// Sets the render timeout (longest device silence).
    #[must_use]
    pub fn render_timeout(mut self, d: Duration) -> Self {
        self.render_timeout = d;
        self
    }
    /// Sets the largest chunk size.
    #[must_use]
    pub fn chunk_size(mut self, n: usize) -> Self {
        self.chunk_size = n;
        self
    }
    /// Sets the go-back-N window (chunks in flight, at least 1).
    #[must_use]
    pub fn window(mut self, n: usize) -> Self {
        self.window = n.max(1);
        self
    }
}
