//! Configuration of the co-processor model.

use crate::isect::KernelKind;
use crate::timing::TimingProfile;
use gridrt_shared::scene::MAX_PES;

/// Longest traversal list the model can buffer from the word interface (entries).
/// `CoprocConfig::max_list` must not exceed it. 1024 covers grids up to ~350³ (T = nx+ny+nz).
pub const LIST_CAPACITY: usize = 1024;

/// Capacity of the outbound word queue (a ray result is 8 words).
pub const OUT_QUEUE_WORDS: usize = 64;

/// Static configuration of a co-processor instance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoprocConfig {
    /// Number of PEs, 1..=255.
    pub pe_count: u16,
    /// Memory of each PE in 32-bit words (GridRT: 8192).
    pub pe_mem_words: u32,
    /// Longest traversal list accepted, 1..=[`LIST_CAPACITY`].
    pub max_list: u16,
    /// Cycle model, charged as given. For kernel-true cycles build it with
    /// [`TimingProfile::for_kernel`] of `kernel` and the number format the PEs run (the
    /// loopback simulator and the emulated-board image do).
    pub timing: TimingProfile,
    /// Intersection kernel every PE runs.
    pub kernel: KernelKind,
}

impl CoprocConfig {
    /// GridRT as built: 4 PEs of 8192 words, lists of 8, the GridRT timing and its Cramer kernel.
    pub const GRIDRT: CoprocConfig = CoprocConfig {
        pe_count: 4,
        pe_mem_words: 8192,
        max_list: 8,
        timing: TimingProfile::GRIDRT,
        kernel: KernelKind::Cramer,
    };

    /// Words of backing memory [`crate::Coprocessor::new`] needs: `pe_count · pe_mem_words`
    /// (saturating; an overflowing product is rejected by `validate`).
    pub const fn required_backing_words(&self) -> usize {
        (self.pe_count as usize).saturating_mul(self.pe_mem_words as usize)
    }

    /// Checks every field (called by [`crate::Coprocessor::new`]).
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.pe_count == 0 || self.pe_count as usize > MAX_PES {
            return Err(ConfigError::PeCount);
        }
        if self.pe_mem_words == 0 {
            return Err(ConfigError::PeMemWords);
        }
        if (self.pe_count as usize).checked_mul(self.pe_mem_words as usize).is_none() {
            return Err(ConfigError::PeMemWords);
        }
        if self.max_list == 0 || self.max_list as usize > LIST_CAPACITY {
            return Err(ConfigError::MaxList);
        }
        if self.timing.test_issue_cycles == 0 {
            return Err(ConfigError::Timing);
        }
        Ok(())
    }
}

/// Why a configuration was refused.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConfigError {
    /// `pe_count` is 0 or above 255.
    PeCount,
    /// `pe_mem_words` is 0, or `pe_count · pe_mem_words` overflows `usize`.
    PeMemWords,
    /// `max_list` is 0 or above [`LIST_CAPACITY`].
    MaxList,
    /// `timing.test_issue_cycles` is 0.
    Timing,
    /// PE caches (`PeCacheConfig::validate`) that do not fit the co-processor: more than
    /// 16 PEs, `pe_mem_words` not a power of two, `lines` not a power of two from 2 below
    /// `pe_mem_words / 8`, or a memory latency of 0.
    PeCache,
    /// The backing slice is shorter than [`CoprocConfig::required_backing_words`].
    BackingTooSmall {
        /// Words needed.
        need: usize,
        /// Words given.
        have: usize,
    },
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::PeCount => f.write_str("pe_count must be 1..=255"),
            Self::PeMemWords => f.write_str("pe_mem_words must be non-zero and pe_count*pe_mem_words must fit usize"),
            Self::MaxList => write!(f, "max_list must be 1..={LIST_CAPACITY}"),
            Self::Timing => f.write_str("timing.test_issue_cycles must be at least 1"),
            Self::PeCache => f.write_str(
                "PE caches need at most 16 PEs, pe_mem_words a power of two, lines a power of two from 2 below pe_mem_words/8 and a memory latency of at least 1",
            ),
            Self::BackingTooSmall { need, have } => {
                write!(f, "backing memory too small: need {need} words, have {have}")
            }
        }
    }
}

/// How the winner among list entries is chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ArbitrationRule {
    /// This project's rule: a hit counts for entry k only if `t ≤ t_exit(k)·(1 + 2⁻¹²)`;
    /// the first entry in list order with an accepted hit wins.
    #[default]
    IntervalChecked,
    /// GridRT as built (for comparison only): the first entry with *any* hit (`0 < t < t_max`)
    /// wins, even if the hit point lies in a later voxel — GridRT's flaw.
    GridRtOriginal,
}
