//! Register-level mock of a peripheral, for host unit tests of the drivers.
//!
//! Reads return, per offset, the next value queued with [`MockMmio::queue`], else the
//! sticky value set with [`MockMmio::set`]/[`MockMmio::set8`] (0 if never set). Writes
//! never change what reads return (like real MMIO: writing THR does not fill RBR); they
//! are only recorded. Every access goes into a log tests can inspect in order.

use super::mmio::Mmio;
use std::cell::RefCell;
use std::collections::{BTreeMap, VecDeque};
use std::vec::Vec;

/// Width of one recorded access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Width {
    /// `read8`/`write8`.
    W8,
    /// `read32`/`write32`.
    W32,
}

/// One recorded register access.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// A read at `off` that returned `value`.
    Read { off: usize, width: Width, value: u32 },
    /// A write of `value` at `off`.
    Write { off: usize, width: Width, value: u32 },
}

#[derive(Default)]
struct State {
    sticky: BTreeMap<usize, u32>,
    queued: BTreeMap<usize, VecDeque<u32>>,
    log: Vec<Access>,
}

/// The mock register block (see the module docs).
#[derive(Default)]
pub struct MockMmio {
    state: RefCell<State>,
}

impl MockMmio {
    pub fn new() -> Self {
        Self::default()
    }

    /// Every later read at `off` returns `value` (once queued values are used up).
    pub fn set(&self, off: usize, value: u32) {
        self.state.borrow_mut().sticky.insert(off, value);
    }

    /// [`MockMmio::set`] for an 8-bit register.
    pub fn set8(&self, off: usize, value: u8) {
        self.set(off, u32::from(value));
    }

    /// The next reads at `off` return `values` in order, then the sticky value.
    pub fn queue(&self, off: usize, values: &[u32]) {
        self.state.borrow_mut().queued.entry(off).or_default().extend(values.iter().copied());
    }

    /// Every access so far, in order.
    pub fn log(&self) -> Vec<Access> {
        self.state.borrow().log.clone()
    }

    /// The values written at `off` (any width), in order.
    pub fn writes_at(&self, off: usize) -> Vec<u32> {
        self.state
            .borrow()
            .log
            .iter()
            .filter_map(|a| match *a {
                Access::Write { off: o, value, .. } if o == off => Some(value),
                _ => None,
            })
            .collect()
    }

    /// [`MockMmio::writes_at`] truncated to bytes (for 8-bit data registers).
    pub fn writes8_at(&self, off: usize) -> Vec<u8> {
        self.writes_at(off).into_iter().map(|v| v as u8).collect()
    }

    /// All writes as `(offset, value)`, in order.
    pub fn writes(&self) -> Vec<(usize, u32)> {
        self.state
            .borrow()
            .log
            .iter()
            .filter_map(|a| match *a {
                Access::Write { off, value, .. } => Some((off, value)),
                Access::Read { .. } => None,
            })
            .collect()
    }

    /// How many reads hit `off`.
    pub fn reads_at(&self, off: usize) -> usize {
        self.state.borrow().log.iter().filter(|a| matches!(a, Access::Read { off: o, .. } if *o == off)).count()
    }

    fn read(&self, off: usize, width: Width) -> u32 {
        let mut st = self.state.borrow_mut();
        let queued = st.queued.get_mut(&off).and_then(VecDeque::pop_front);
        let value = queued.unwrap_or_else(|| st.sticky.get(&off).copied().unwrap_or(0));
        st.log.push(Access::Read { off, width, value });
        value
    }

    fn write(&self, off: usize, width: Width, value: u32) {
        self.state.borrow_mut().log.push(Access::Write { off, width, value });
    }
}

impl Mmio for MockMmio {
    fn read8(&self, off: usize) -> u8 {
        self.read(off, Width::W8) as u8
    }
    fn write8(&self, off: usize, value: u8) {
        self.write(off, Width::W8, u32::from(value));
    }
    fn read32(&self, off: usize) -> u32 {
        self.read(off, Width::W32)
    }
    fn write32(&self, off: usize, value: u32) {
        self.write(off, Width::W32, value);
    }
}
