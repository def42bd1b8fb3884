//! What a device says about itself: [`DeviceInfo`] of a `Version` message and its
//! compiled-in stages ([`feature`] bits).

/// What the device says about itself in [`Msg::Version`](crate::msg::Msg::Version).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DeviceInfo {
    /// UART protocol version the device speaks.
    pub protocol: u16,
    /// Firmware version major, minor, patch.
    pub firmware: [u8; 3],
    /// Board id: 0 = loopback simulator, 1 = qemu-virt, 2 = FPGA SoC.
    pub board: u8,
    /// Largest payload the device accepts.
    pub max_payload: u16,
    /// PEs of the attached co-processor.
    pub pe_count: u16,
    /// Largest grid (voxels) the device can hold.
    pub voxel_capacity: u32,
    /// Words of memory per PE.
    pub pe_mem_words: u32,
    /// Compiled-in pipeline stages (bit flags, SPEC.md §3.2).
    pub features: u32,
}

/// Compiled-in pipeline stages (bit flags in [`DeviceInfo::features`]).
pub mod feature {
    /// The shadow-ray stage is compiled in.
    pub const SHADOWS: u32 = 1 << 0;
    /// The device can send primitive-id spans ([`render_flags::PRIM_IDS`](crate::msg::render_flags::PRIM_IDS)).
    pub const PRIM_IDS: u32 = 1 << 1;
    /// Mirror-reflection rays ([`render_flags::REFLECTIONS`](crate::msg::render_flags::REFLECTIONS) is honoured; SPEC.md §3.13).
    pub const REFLECTIONS: u32 = 1 << 16;
    /// Procedural textures ([`render_flags::TEXTURES`](crate::msg::render_flags::TEXTURES) is honoured).
    pub const TEXTURES: u32 = 1 << 17;
    /// Specular highlights ([`render_flags::SPECULAR`](crate::msg::render_flags::SPECULAR) is honoured).
    pub const SPECULAR: u32 = 1 << 18;
    /// Row interpolation (Malcheva et al.; the `render_flags` interpolation fields are honoured).
    pub const INTERP: u32 = 1 << 19;
    /// Scenes with analytic primitives and ViRAY materials (the scene image of SPEC.md §5) are
    /// accepted.
    pub const ANALYTIC_PRIMITIVES: u32 = 1 << 20;
    /// The device renders `RenderRegion` requests (SPEC.md §3.12).
    pub const RENDER_REGION: u32 = 1 << 8;
    /// The device sends `Rgb565` spans.
    pub const RGB565: u32 = 1 << 9;
    /// The device sends `Rle` spans.
    pub const RLE: u32 = 1 << 10;
    /// Windowed transfers (SPEC.md §3.14): a device accepts `SceneData` and answers
    /// `SceneSack`; a bootloader accepts `FlashData` and answers `FlashSack`.
    pub const WINDOWED: u32 = 1 << 11;
    /// The device's receiver holds a request that arrives while it renders and answers it
    /// afterwards, in order (SPEC.md §3.12.3 "Flow control"): a host may send the next
    /// frame's `RenderRegion` before the current frame's answer is in. A property of the
    /// board's UART path (the loopback simulator and `gridrt device`: an OS or in-memory
    /// buffer), not of the firmware; a soft-core's 16-byte FIFO does not have it.
    pub const REQUEST_QUEUE: u32 = 1 << 13;
    /// Point clouds (SPEC.md §6): the device loads a scene image's point section and renders
    /// [`render_flags::SPLATS`](crate::msg::render_flags::SPLATS) frames.
    pub const SPLATS: u32 = 1 << 21;
    /// Compact scene uploads (SPEC.md §5.12): the device decodes a `GRTZ` stream with a
    /// vertex cache of 4096 entries (`cache_log2` ≤ 12).
    pub const COMPACT_SCENE: u32 = 1 << 12;
}
