//! The device statistics of a `Stats` message (SPEC.md §3.8): keys and entries.

/// Keys of the device statistics in a [`Msg::Stats`](crate::msg::Msg::Stats) (SPEC.md §3.8).
pub mod stat {
    /// Camera rays generated.
    pub const PRIMARY_RAYS: u8 = 1;
    /// Shadow rays generated.
    pub const SHADOW_RAYS: u8 = 2;
    /// Rays sent to the co-processor (all kinds).
    pub const COPROC_RAYS: u8 = 3;
    /// Rays that missed the grid box and cost no FSL words.
    pub const CULLED_RAYS: u8 = 4;
    /// FSL words written to the co-processor.
    pub const FSL_WORDS_OUT: u8 = 5;
    /// FSL words read from the co-processor.
    pub const FSL_WORDS_IN: u8 = 6;
    /// Ray–primitive tests the co-processor reported.
    pub const INTERSECTION_TESTS: u8 = 7;
    /// Co-processor cycles the co-processor reported.
    pub const COPROC_CYCLES: u8 = 8;
    /// Pixels sent.
    pub const PIXELS: u8 = 9;
    /// Traversal-list entries sent.
    pub const LIST_ENTRIES: u8 = 10;
    /// First key of the per-stage device counters (instructions), see SPEC.md §3.8.
    pub const STAGE_BASE: u8 = 0x40;
    /// Mirror-reflection rays generated (SPEC.md §3.13).
    pub const REFLECTION_RAYS: u8 = 0x20;
    /// Pixels filled by row interpolation instead of traced.
    pub const INTERPOLATED_PIXELS: u8 = 0x21;
    /// Centre pixels traced because a segment failed the interpolation test.
    pub const INTERP_RETRACES: u8 = 0x22;
    /// The pipeline plan the device followed (`render_flags` bits it honoured).
    pub const PLAN: u8 = 0x23;
    /// FSL words (both directions) of primary rays.
    pub const FSL_WORDS_PRIMARY: u8 = 0x24;
    /// FSL words (both directions) of shadow rays.
    pub const FSL_WORDS_SHADOW: u8 = 0x25;
    /// FSL words (both directions) of reflection rays.
    pub const FSL_WORDS_REFLECTION: u8 = 0x26;
    /// Rays the firmware keeps in flight in the co-processor (its ray-queue depth). Absent
    /// or 0 means 1: one ray at a time, the soft-core waiting for every result.
    pub const RAYS_IN_FLIGHT: u8 = 0x27;
    /// Instructions the stage counters exclude because a co-processor model ran them on the
    /// soft-core (emulated board; SPEC.md §3.8).
    pub const MODEL_INSTRUCTIONS: u8 = 0x28;
    /// Instructions of the emulated board's link wrapper around the model that the stage
    /// counters exclude (SPEC.md §3.8).
    pub const LINK_WRAPPER_INSTRUCTIONS: u8 = 0x29;
    /// Cycles from the render request's arrival to the frame's last byte leaving the UART's
    /// transmit FIFO (`mcycle`; 0 on a board without a cycle counter). SPEC.md §3.8.
    pub const FRAME_CYCLES: u8 = 0x2A;
    /// Cycles from the frame's first byte written to the UART to its transmit FIFO draining
    /// after the last: the frame's time on the line when the line is the bottleneck.
    pub const LINK_CYCLES: u8 = 0x2B;
    /// Bytes the device wrote to the UART between those two instants (the frame's spans and
    /// `Stats` excluded: pixels only, framing included).
    pub const FRAME_TX_BYTES: u8 = 0x2C;
    /// Cycles (`mcycle`) of the upload that loaded the current scene: from the UART batch
    /// that held its `SceneBegin` to the one that completed it. Sent only by a device with a
    /// cycle counter, in every frame's `Stats` after such an upload.
    pub const UPLOAD_CYCLES: u8 = 0x2D;
    /// Of those, the cycles inside the device's input handling (framing, CRC-32, messages,
    /// answers); the rest went to reading the UART and waiting for bytes.
    pub const UPLOAD_FEED_CYCLES: u8 = 0x2E;
    /// Of the feed cycles, those in the scene parser and loader (the image's CRC-32, its
    /// records into the scene store, the LOAD_PE words to the co-processor).
    pub const UPLOAD_PARSE_CYCLES: u8 = 0x2F;
    /// First key of the per-hart counters of a frame shared by several harts (SoC built with
    /// `--harts N`): rows hart h traced at `HART_ROWS_BASE + h`, h = 0..=3 (0: the first).
    pub const HART_ROWS_BASE: u8 = 0x50;
    /// Cycles (`mcycle`) hart h spent tracing its rows: `HART_BUSY_BASE + h`.
    pub const HART_BUSY_BASE: u8 = 0x54;
    /// Cycles hart h waited: the first hart for the next row to be ready, a worker for a free
    /// row slot: `HART_WAIT_BASE + h`.
    pub const HART_WAIT_BASE: u8 = 0x58;
    /// Splat frames (SPEC.md §6): points the code generator transformed.
    pub const SPLAT_POINTS: u8 = 0x30;
    /// Splat codewords sent to the splat stage (one per 8×8 tile).
    pub const SPLAT_CODEWORDS: u8 = 0x31;
    /// Points culled (behind the eye, off the region, edge-on, or too small to cover a pixel).
    pub const SPLAT_CULLED: u8 = 0x32;
    /// Points whose screen radius exceeded the shape table and was clamped to its largest size.
    pub const SPLAT_CLAMPED: u8 = 0x33;
    /// Command words (shift, load, ambient) sent to the splat stage.
    pub const SPLAT_COMMANDS: u8 = 0x34;
    /// Box pixels the splat stage depth-tested.
    pub const SPLAT_FRAGMENTS: u8 = 0x35;
    /// Instructions (`minstret`) of the code generator (transform, table lookup, codewords,
    /// Y buckets): the key of stage 5 (`STAGE_BASE + 10`); its cycles are the next key.
    pub const STAGE_SPLAT_CODEGEN: u8 = STAGE_BASE + 10;
    /// Instructions of the splat stage (decode, depth test, stripe buffer): stage 6.
    pub const STAGE_SPLAT_STAGE: u8 = STAGE_BASE + 12;
}

/// Bytes per stats entry: key u8, value u64.
pub const STAT_ENTRY_LEN: usize = 9;

/// Harts the per-hart keys cover: `stat::HART_ROWS_BASE + h` and its siblings for
/// h < `STAT_HARTS` (each base is `STAT_HARTS` keys after the one before).
pub const STAT_HARTS: u8 = 4;

/// Iterates over the (key, value) entries of a stats payload.
pub fn stat_entries(entries: &[u8]) -> impl Iterator<Item = (u8, u64)> + '_ {
    entries.chunks_exact(STAT_ENTRY_LEN).map(|c| {
        let mut v = [0u8; 8];
        v.copy_from_slice(c.get(1..9).unwrap_or(&[0; 8]));
        (c.first().copied().unwrap_or(0), u64::from_le_bytes(v))
    })
}
