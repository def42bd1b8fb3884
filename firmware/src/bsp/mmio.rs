//! Register access: the one seam between drivers and hardware.

/// Access to one peripheral's register block, by byte offset from its base.
///
/// Methods take `&self`: device registers are shared state the compiler cannot see,
/// exactly like a `Cell`. Implementations must perform every access exactly once and in
/// program order (volatile), because reads and writes have side effects (a read of a
/// receive FIFO pops it).
pub trait Mmio {
    /// Reads the 8-bit register at byte offset `off`.
    fn read8(&self, off: usize) -> u8;
    /// Writes the 8-bit register at byte offset `off`.
    fn write8(&self, off: usize, value: u8);
    /// Reads the 32-bit register at byte offset `off` (4-byte aligned).
    fn read32(&self, off: usize) -> u32;
    /// Writes the 32-bit register at byte offset `off` (4-byte aligned).
    fn write32(&self, off: usize, value: u32);
}

// Lets a test keep the mock while a driver holds a reference to it.
impl<T: Mmio + ?Sized> Mmio for &T {
    fn read8(&self, off: usize) -> u8 {
        (**self).read8(off)
    }
    fn write8(&self, off: usize, value: u8) {
        (**self).write8(off, value)
    }
    fn read32(&self, off: usize) -> u32 {
        (**self).read32(off)
    }
    fn write32(&self, off: usize, value: u32) {
        (**self).write32(off, value)
    }
}

/// Memory-mapped registers at a fixed physical address, accessed with volatile
/// loads and stores (the real board).
#[derive(Debug)]
pub struct VolatileMmio {
    base: usize,
}

impl VolatileMmio {
    /// Register block at physical address `base`.
    ///
    /// # Safety
    ///
    /// `base` must be the base address of a device register block that is mapped,
    /// uncached (or strongly ordered) and large enough for every offset the driver using
    /// it touches, and no other code may drive that device at the same time.
    pub const unsafe fn new(base: usize) -> Self {
        Self { base }
    }

    /// The base address this block was created with.
    pub const fn base(&self) -> usize {
        self.base
    }
}

impl Mmio for VolatileMmio {
    fn read8(&self, off: usize) -> u8 {
        // SAFETY: `new`'s contract makes base + off a valid device register (so it does not
        // wrap).
        unsafe { core::ptr::read_volatile(self.base.wrapping_add(off) as *const u8) }
    }
    fn write8(&self, off: usize, value: u8) {
        // SAFETY: as in `read8`.
        unsafe { core::ptr::write_volatile(self.base.wrapping_add(off) as *mut u8, value) }
    }
    fn read32(&self, off: usize) -> u32 {
        // SAFETY: as in `read8`; the drivers only use 4-byte aligned offsets for 32-bit
        // registers and every base address in our memory maps is 4-byte aligned.
        unsafe { core::ptr::read_volatile(self.base.wrapping_add(off) as *const u32) }
    }
    fn write32(&self, off: usize, value: u32) {
        // SAFETY: as in `read32`.
        unsafe { core::ptr::write_volatile(self.base.wrapping_add(off) as *mut u32, value) }
    }
}
