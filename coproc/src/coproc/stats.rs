//! The model's counters ([`CoprocStats`]) and what an untimed trace reports ([`TraceInfo`]).

/// Counters of the model since creation or [`Coprocessor::reset_stats`](super::Coprocessor::reset_stats).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CoprocStats {
    /// Ray queries answered with a result (word or direct API; not `trace_untimed`).
    pub rays: u64,
    /// Of which with a hit.
    pub hits: u64,
    /// Ray–triangle tests charged (started before each ray completed; see `timing`).
    pub tests: u64,
    /// Cycles of answered rays and successful loads.
    pub cycles: u64,
    /// Words pushed into the model.
    pub words_in: u64,
    /// Words queued for output.
    pub words_out: u64,
    /// Protocol violations reported (word or direct API).
    pub errors: u64,
    /// Successful PE loads.
    pub loads: u64,
    /// Output words dropped because the output queue was full (the reader did not pop).
    pub out_dropped: u64,
    /// Ray–triangle tests (timed path) whose fixed-point arithmetic overflowed: reported and
    /// counted as misses, never wrapped.
    pub overflows: u64,
    /// Triangle records found degenerate at load (zero area): they never hit.
    pub degenerate_records: u64,
    /// Triangle records whose precomputed values do not fit the fixed-point storage at load
    /// (every test of them counts in `overflows`).
    pub overflow_records: u64,
    /// With PE caches ([`Coprocessor::with_pe_caches`](super::Coprocessor::with_pe_caches)):
    /// cycles the RTL co-processor stands still for them (line fills, write-buffer drains,
    /// replays, the tag clear after the reset), not in `cycles` (the RTL's
    /// `stall_cycles_o`; `pe_cache` module doc).
    pub pe_stall_cycles: u64,
    /// With PE caches: words read from the external memory (8 per line filled).
    pub pe_mem_reads: u64,
    /// With PE caches: words written to the external memory (LOAD_PE's image words,
    /// records and normals, written through).
    pub pe_mem_writes: u64,
}

/// What an untimed trace saw besides its result ([`Coprocessor::trace_untimed_with_info`](super::Coprocessor::trace_untimed_with_info)).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TraceInfo {
    /// Tests performed (entries up to the winner), not saturated.
    pub tests: u64,
    /// Tests whose fixed-point arithmetic overflowed (counted as misses).
    pub overflows: u64,
}
