//! Timeouts, flow control and chunk sizes of a session.

use std::time::Duration;

/// Largest scene chunk the host sends.
pub const MAX_CHUNK: usize = 1024;

/// Smallest scene chunk the upload shrinks to on a noisy line.
pub const MIN_CHUNK: usize = 64;

/// Timeouts and flow control of a session. Setters are builder-style.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionConfig {
    /// Name of the port, used in error messages.
    pub port_name: String,
    /// Total time to wait for `Version` (split over three `Hello` attempts).
    pub hello_timeout: Duration,
    /// Longest time an upload may go without an acknowledgement before it fails.
    pub upload_timeout: Duration,
    /// Time without acknowledgement after which unacknowledged chunks are sent again.
    pub retransmit_after: Duration,
    /// Longest time a render may go without a message before it fails.
    pub render_timeout: Duration,
    /// Scene chunk size in bytes (capped at [`MAX_CHUNK`] and the device's payload limit).
    pub chunk_size: usize,
    /// Chunks in flight.
    pub window: usize,
    /// Rewinds allowed in a row without any new byte acknowledged before the upload gives up.
    pub max_rewinds: u32,
    /// Render with `RenderRegion` (selective repeat, reset recovery) when the device
    /// supports it; `false` sends one whole-frame `RenderRequest`.
    pub regions: bool,
    /// Rows per region when a frame is rendered with regions (0 = the whole frame).
    pub band_rows: u16,
    /// Requests per band before it fails.
    pub max_requests_per_band: u32,
}

impl SessionConfig {
    /// Defaults for a port called `port_name`: hello 3 s, upload 10 s (retransmit after 1 s),
    /// render 30 s idle, 1024-byte chunks, window of 4, 64 rewinds.
    pub fn new(port_name: impl Into<String>) -> Self {
        Self {
            port_name: port_name.into(),
            hello_timeout: Duration::from_secs(3),
            upload_timeout: Duration::from_secs(10),
            retransmit_after: Duration::from_secs(1),
            render_timeout: Duration::from_secs(30),
            chunk_size: MAX_CHUNK,
            window: 4,
            max_rewinds: 64,
            regions: true,
            band_rows: 0,
            max_requests_per_band: 10_000,
        }
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
    /// Sets the consecutive rewinds without progress allowed during an upload.
    #[must_use]
    pub fn max_rewinds(mut self, n: u32) -> Self {
        self.max_rewinds = n;
        self
    }
    /// Sets the hello timeout.
    #[must_use]
    pub fn hello_timeout(mut self, d: Duration) -> Self {
        self.hello_timeout = d;
        self
    }
    /// Sets the upload timeout.
    #[must_use]
    pub fn upload_timeout(mut self, d: Duration) -> Self {
        self.upload_timeout = d;
        self
    }
    /// Sets the retransmit interval.
    #[must_use]
    pub fn retransmit_after(mut self, d: Duration) -> Self {
        self.retransmit_after = d;
        self
    }
    /// Sets the render idle timeout.
    #[must_use]
    pub fn render_timeout(mut self, d: Duration) -> Self {
        self.render_timeout = d;
        self
    }
    /// Sets the chunk size.
    #[must_use]
    pub fn chunk_size(mut self, n: usize) -> Self {
        self.chunk_size = n;
        self
    }
    /// Sets the window (chunks in flight, at least 1).
    #[must_use]
    pub fn window(mut self, n: usize) -> Self {
        self.window = n.max(1);
        self
    }
}
