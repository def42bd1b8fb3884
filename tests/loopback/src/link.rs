//! The co-processor behind the simulated board's FSL link: the Rust model linked in, or the
//! RTL's Verilator build as a child process (`gridrt_rtl::sim::CoprocSim`).

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use gridrt_coproc::{Coprocessor, FixedFrame};
use gridrt_firmware::fsl::{FslLink, FslWord, LinkError, LinkErrorKind, VirtualCoproc};
use gridrt_rtl::sim::{CoprocSim, RtlParams};

use crate::config::{Backend, SimConfig};

/// The RTL simulation failed (the child died or its pipe broke): a hardware fault to the
/// firmware, which reports it and aborts the frame.
#[derive(Debug)]
pub struct RtlLinkError(pub String);

impl LinkError for RtlLinkError {
    fn kind(&self) -> LinkErrorKind {
        LinkErrorKind::Hardware
    }
}

/// The simulated board's co-processor.
// The model variant is large (its link buffers); the link lives inside the boxed `Device`.
#[allow(clippy::large_enum_variant)]
pub(crate) enum SimLink<'m> {
    /// The Rust model.
    Model(VirtualCoproc<'m>),
    /// The RTL in Verilator.
    Rtl(Box<CoprocSim>),
    /// The RTL in Verilator with the model beside it ([`LOCKSTEP_VAR`]): every word goes to
    /// both, and every reply word of the RTL (RESULT words included) must equal the model's.
    Checked(Box<CoprocSim>, VirtualCoproc<'m>),
}

/// Environment variable that, set to `1`, runs the model beside the RTL and compares every
/// reply word (a difference is a link error: the frame fails with both words in the message).
pub const LOCKSTEP_VAR: &str = "GRIDRT_RTL_LOCKSTEP";

/// Whether [`LOCKSTEP_VAR`] asks for the model beside the RTL.
pub(crate) fn lockstep() -> bool {
    std::env::var(LOCKSTEP_VAR).is_ok_and(|v| v.trim() == "1")
}

/// Whether a board of `config` needs the model's backing memory: it runs the model, alone or
/// beside the RTL.
pub(crate) fn needs_model(config: &SimConfig) -> bool {
    config.backend == Backend::Model || lockstep()
}

impl FslLink for SimLink<'_> {
    type Error = RtlLinkError;

    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        match self {
            Self::Model(m) => {
                m.model.push(word);
                Ok(())
            }
            Self::Rtl(s) => s.push(word).map_err(|e| nb::Error::Other(RtlLinkError(e.to_string()))),
            Self::Checked(s, m) => {
                m.model.push(word);
                s.push(word).map_err(|e| nb::Error::Other(RtlLinkError(e.to_string())))
            }
        }
    }

    /// The RTL runs until it has consumed every word put so far and is idle, so a reply it
    /// owes is here at the first poll (the same behaviour as the model).
    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        match self {
            Self::Model(m) => m.model.pop().ok_or(nb::Error::WouldBlock),
            Self::Rtl(s) => match s.pop() {
                Ok(Some(w)) => Ok(w),
                Ok(None) => Err(nb::Error::WouldBlock),
                Err(e) => Err(nb::Error::Other(RtlLinkError(e.to_string()))),
            },
            Self::Checked(s, m) => {
                let rtl = s.pop().map_err(|e| nb::Error::Other(RtlLinkError(e.to_string())))?;
                let model = m.model.pop();
                if rtl != model {
                    return Err(nb::Error::Other(RtlLinkError(format!(
                        "RTL reply word {rtl:?} differs from the model's {model:?}"
                    ))));
                }
                rtl.ok_or(nb::Error::WouldBlock)
            }
        }
    }
}

/// The RTL build parameters of a board configuration.
pub(crate) fn rtl_params(config: &SimConfig) -> RtlParams {
    RtlParams {
        pes: config.pe_count,
        pe_mem_words: config.pe_mem_words,
        max_list: config.max_list,
        pe_cache_lines: config.pe_cache_lines,
        ..RtlParams::default()
    }
}

/// The Verilated program a board needs (built or reused by `cargo xtask rtl sim`, once per
/// parameter set and process); `None` for the model.
pub(crate) fn rtl_program(config: &SimConfig) -> Result<Option<PathBuf>, String> {
    static BUILT: Mutex<Vec<(RtlParams, PathBuf)>> = Mutex::new(Vec::new());
    if config.backend == Backend::Model {
        return Ok(None);
    }
    let params = rtl_params(config);
    let mut built = BUILT.lock().map_err(|_| "RTL build cache poisoned".to_string())?;
    if let Some((_, p)) = built.iter().find(|(q, _)| *q == params) {
        return Ok(Some(p.clone()));
    }
    let path = gridrt_rtl::sim::build(params).map_err(|e| e.to_string())?.coproc;
    built.push((params, path.clone()));
    Ok(Some(path))
}

/// A freshly reset co-processor: the model in `backing` (its number format selected, the
/// frame coming from the firmware's FRAME packet), or a new RTL process.
pub(crate) fn open<'m>(
    config: &SimConfig,
    backing: &'m mut [u32],
    program: Option<&Path>,
) -> Result<SimLink<'m>, String> {
    match program {
        None => {
            let model = match config.pe_caches() {
                Some(caches) => Coprocessor::with_pe_caches(config.coproc(), caches, backing),
                None => Coprocessor::new(config.coproc(), backing),
            };
            let mut model = model.map_err(|e| format!("invalid co-processor configuration: {e}"))?;
            model.set_number_format(config.format, FixedFrame::IDENTITY);
            Ok(SimLink::Model(VirtualCoproc { model }))
        }
        Some(p) => {
            let args = if config.pe_cache_lines != 0 {
                vec!["--mem-latency".to_string(), config.pe_mem_latency.to_string()]
            } else {
                Vec::new()
            };
            let sim = Box::new(CoprocSim::spawn_with(p, &args).map_err(|e| e.to_string())?);
            if !lockstep() {
                return Ok(SimLink::Rtl(sim));
            }
            let mut model = Coprocessor::new(config.coproc(), backing)
                .map_err(|e| format!("invalid co-processor configuration: {e:?}"))?;
            model.set_number_format(config.format, FixedFrame::IDENTITY);
            Ok(SimLink::Checked(sim, VirtualCoproc { model }))
        }
    }
}

/// What the PE caches did since the board booted: the cycles the co-processor stood still
/// for them and the external memory's words (the RTL's counters, or the model's timing).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PeCacheCounts {
    /// Cycles stopped (not in the co-processor's `RESULT.cycles`).
    pub stall_cycles: u64,
    /// Words read (line fills).
    pub reads: u64,
    /// Words written (LOAD_PE's, through).
    pub writes: u64,
    /// True when the model counted them, false for the RTL's own counters.
    pub modelled: bool,
}

impl SimLink<'_> {
    /// The PE caches' counters, if this co-processor has caches.
    pub(crate) fn pe_cache_counts(&mut self, config: &SimConfig) -> Option<PeCacheCounts> {
        if config.pe_cache_lines == 0 {
            return None;
        }
        match self {
            Self::Model(m) => {
                let s = m.model.stats();
                Some(PeCacheCounts {
                    stall_cycles: s.pe_stall_cycles,
                    reads: s.pe_mem_reads,
                    writes: s.pe_mem_writes,
                    modelled: true,
                })
            }
            Self::Rtl(s) | Self::Checked(s, _) => s.pe_memory().ok().map(|c| PeCacheCounts {
                stall_cycles: c.stall_cycles,
                reads: c.reads.into(),
                writes: c.writes.into(),
                modelled: false,
            }),
        }
    }
}
