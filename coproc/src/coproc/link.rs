//! The FSL word interface: receives packets word by word, checks each word as it arrives
//! (errors and resynchronisation in the module doc of [`crate::coproc`]), executes a packet
//! at its last word and queues the reply words.

use heapless::{Deque, Vec as HVec};

use gridrt_shared::fsl::{self, op, FslError, FslWord, ListEntry, RayKind, FRAME_WORDS, RAY_HEADER_WORDS};
use gridrt_shared::math::{Ray, Vec3};

use super::observe::{NoObserver, PeReadObserver};
use super::pes::{PeMem, Pes};
use super::search::View;
use crate::config::{LIST_CAPACITY, OUT_QUEUE_WORDS};

/// Reply to CLEAR (SPEC §4.4: `0x94000000`).
pub const CLEAR_ACK: u32 = fsl::ack_word(op::CLEAR, 0);

/// Reply to a successful LOAD_PE of `pe` (SPEC §4.4: `0x910000pe`).
pub const fn load_ack(pe: u8) -> u32 {
    fsl::ack_word(op::LOAD_PE, pe)
}

/// Reply to FRAME (SPEC §4.6: `0x95000000`).
pub const FRAME_ACK: u32 = fsl::ack_word(op::FRAME, 0);

/// The FRAME box checks (SPEC §4.6): `Err(index)` of the first non-finite word (1..=6), else
/// of the maximum word of the first axis with max < min (4 + axis).
pub(super) fn check_frame_box(min: [f32; 3], max: [f32; 3]) -> Result<(), u16> {
    let words = [min[0], min[1], min[2], max[0], max[1], max[2]];
    // Word indices 1..=6 of the packet (small constants: no overflow).
    if let Some(i) = (1u16..).zip(words).find_map(|(i, c)| (!c.is_finite()).then_some(i)) {
        return Err(i);
    }
    match (4u16..).zip(min.iter().zip(&max)).find_map(|(i, (lo, hi))| (hi < lo).then_some(i)) {
        Some(i) => Err(i),
        None => Ok(()),
    }
}

/// Receiver state of the inbound word stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Rx {
    /// Between packets.
    Idle,
    /// After an error: dropping words up to and including the next control word.
    Discard,
    /// LOAD_PE header seen; the word count is next.
    LoadCount { pe: u8 },
    /// Receiving `declared` image words, `got` so far.
    LoadWords { pe: u8, declared: u32, got: u32 },
    /// Receiving a ray request; `idx` is the index of the next word in the packet.
    Ray { kind: RayKind, count: u16, idx: u32 },
    /// Receiving a FRAME packet; `idx` is the index of the next word (1..=6).
    Frame { idx: u32 },
}

/// The link side of the model: receiver state, the ray packet being received, the output
/// queue.
pub(super) struct Link {
    rx: Rx,
    head: [u32; RAY_HEADER_WORDS],
    frame: [u32; FRAME_WORDS],
    pending: u32,
    list: HVec<ListEntry, LIST_CAPACITY>,
    out: Deque<FslWord, OUT_QUEUE_WORDS>,
}

impl core::fmt::Debug for Link {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Link").field("rx", &self.rx).field("out_len", &self.out.len()).finish_non_exhaustive()
    }
}

impl Link {
    /// Idle, with empty queues.
    pub(super) fn new() -> Self {
        Self {
            rx: Rx::Idle,
            head: [0; RAY_HEADER_WORDS],
            frame: [0; FRAME_WORDS],
            pending: 0,
            list: HVec::new(),
            out: Deque::new(),
        }
    }

    /// True while a packet is partly received (or being discarded after an error).
    pub(super) fn in_packet(&self) -> bool {
        self.rx != Rx::Idle
    }

    /// Dequeues the next outbound word.
    pub(super) fn pop(&mut self) -> Option<FslWord> {
        self.out.pop_front()
    }

    /// Outbound words waiting.
    pub(super) fn out_len(&self) -> usize {
        self.out.len()
    }

    /// True when the output queue can take a full ray result; a driver modelling FSL
    /// back-pressure should stop pushing while this is false (words of replies that do not
    /// fit are dropped and counted in `CoprocStats::out_dropped`).
    pub(super) fn can_push(&self) -> bool {
        OUT_QUEUE_WORDS.saturating_sub(self.out.len()) >= fsl::RESULT_WORDS
    }

    /// Consumes one inbound word; executes a packet when its last word arrives.
    pub(super) fn push(&mut self, pes: &mut Pes<impl PeMem>, w: FslWord) {
        self.push_observed(pes, w, &mut NoObserver);
    }

    /// [`push`](Self::push) that tells `obs` the PE-memory reads of a ray it executes.
    pub(super) fn push_observed<O: PeReadObserver>(&mut self, pes: &mut Pes<impl PeMem>, w: FslWord, obs: &mut O) {
        pes.stats.words_in = pes.stats.words_in.saturating_add(1);
        if let Rx::Ray { kind, count, idx } = self.rx {
            // Mid-packet only the word index moves: update it in place. (Storing the whole
            // state back through the stack stalled store forwarding on every word, ~8 % of
            // a simulated frame.)
            match self.on_ray_word(pes, kind, count, idx, w, obs) {
                Rx::Ray { idx: next, .. } => {
                    if let Rx::Ray { idx, .. } = &mut self.rx {
                        *idx = next;
                    }
                }
                other => self.rx = other,
            }
            return;
        }
        self.rx = match self.rx {
            Rx::Idle => self.on_first_word(pes, w),
            Rx::Discard => {
                if w.control {
                    Rx::Idle
                } else {
                    Rx::Discard
                }
            }
            Rx::LoadCount { pe } => self.on_load_count(pes, pe, w),
            Rx::LoadWords { pe, declared, got } => self.on_load_word(pes, pe, declared, got, w),
            Rx::Ray { kind, count, idx } => self.on_ray_word(pes, kind, count, idx, w, obs),
            Rx::Frame { idx } => self.on_frame_word(pes, idx, w),
        };
    }

    fn emit(&mut self, pes: &mut Pes<impl PeMem>, data: u32, control: bool) {
        if self.out.push_back(FslWord { data, control }).is_err() {
            pes.stats.out_dropped = pes.stats.out_dropped.saturating_add(1);
        } else {
            pes.stats.words_out = pes.stats.words_out.saturating_add(1);
        }
    }

    /// Reports `e` and picks the next state: packet over if `control`, else resynchronise.
    fn fail(&mut self, pes: &mut Pes<impl PeMem>, e: FslError, detail: u16, control: bool) -> Rx {
        pes.stats.errors = pes.stats.errors.saturating_add(1);
        self.emit(pes, e.to_word(detail), true);
        if control {
            Rx::Idle
        } else {
            Rx::Discard
        }
    }

    fn on_first_word(&mut self, pes: &mut Pes<impl PeMem>, w: FslWord) -> Rx {
        let ctl = w.control;
        match fsl::opcode(w.data) {
            op::LOAD_PE => {
                let pe = w.data as u8;
                if pe as u16 >= pes.cfg.pe_count {
                    return self.fail(pes, FslError::PeOutOfRange, pe as u16, ctl);
                }
                if pes.mem.words_mut().is_none() {
                    // A ray port shares the PE memories read-only.
                    return self.fail(pes, FslError::Unsupported, pe as u16, ctl);
                }
                pes.begin_load(pe);
                if ctl {
                    return self.fail(pes, FslError::PacketTooShort, 0, true);
                }
                Rx::LoadCount { pe }
            }
            op::CLEAR => {
                if !ctl {
                    return self.fail(pes, FslError::MissingControl, 0, false);
                }
                pes.clear();
                self.emit(pes, CLEAR_ACK, true);
                Rx::Idle
            }
            op::RAY_CLOSEST | op::RAY_ANY => {
                let kind = if fsl::opcode(w.data) == op::RAY_ANY { RayKind::Any } else { RayKind::Closest };
                let count = w.data as u16;
                if let Err((e, d)) = pes.view().check_header(count as usize) {
                    return self.fail(pes, e, d, ctl);
                }
                if ctl {
                    return self.fail(pes, FslError::PacketTooShort, 0, true);
                }
                self.head[0] = w.data;
                self.list.clear();
                Rx::Ray { kind, count, idx: 1 }
            }
            op::FRAME => {
                if ctl {
                    return self.fail(pes, FslError::PacketTooShort, 0, true);
                }
                Rx::Frame { idx: 1 }
            }
            other => self.fail(pes, FslError::UnknownOpcode, other as u16, ctl),
        }
    }

    /// FRAME words 1..=6: the box; at word 6 the box checks, then framing, then the frame.
    fn on_frame_word(&mut self, pes: &mut Pes<impl PeMem>, idx: u32, w: FslWord) -> Rx {
        let ctl = w.control;
        if let Some(slot) = self.frame.get_mut(idx as usize) {
            *slot = w.data;
        }
        const LAST: u32 = FRAME_WORDS as u32 - 1;
        let last = LAST;
        if idx < last {
            if ctl {
                return self.fail(pes, FslError::PacketTooShort, idx as u16, true);
            }
            return Rx::Frame { idx: idx.saturating_add(1) };
        }
        let f = |i: usize| f32::from_bits(self.frame.get(i).copied().unwrap_or(0));
        let (min, max) = ([f(1), f(2), f(3)], [f(4), f(5), f(6)]);
        if let Err(detail) = check_frame_box(min, max) {
            return self.fail(pes, FslError::BadFrame, detail, ctl);
        }
        if !ctl {
            return self.fail(pes, FslError::MissingControl, last as u16, false);
        }
        pes.set_frame_box(min, max);
        self.emit(pes, FRAME_ACK, true);
        Rx::Idle
    }

    fn on_load_count(&mut self, pes: &mut Pes<impl PeMem>, pe: u8, w: FslWord) -> Rx {
        let n = w.data;
        if n > pes.cfg.pe_mem_words {
            return self.fail(pes, FslError::PeMemoryOverflow, pe as u16, w.control);
        }
        if n == 0 {
            if !w.control {
                return self.fail(pes, FslError::MissingControl, 1, false);
            }
            return self.complete_load(pes, pe, 0);
        }
        if w.control {
            return self.fail(pes, FslError::PacketTooShort, 1, true);
        }
        Rx::LoadWords { pe, declared: n, got: 0 }
    }

    fn on_load_word(&mut self, pes: &mut Pes<impl PeMem>, pe: u8, declared: u32, got: u32, w: FslWord) -> Rx {
        let at = pes.base(pe).saturating_add(got as usize);
        // `declared ≤ pe_mem_words` was checked, so this slot exists; stay safe regardless.
        let Some(slot) = pes.mem.words_mut().and_then(|m| m.get_mut(at)) else {
            return self.fail(pes, FslError::PeMemoryOverflow, pe as u16, w.control);
        };
        *slot = w.data;
        // `got < declared ≤ pe_mem_words` (a u32): no overflow.
        let got = got.saturating_add(1);
        // Index in the packet: header, count, then the image words.
        let index = (got as u64).saturating_add(1).min(u16::MAX as u64) as u16;
        if got == declared {
            if !w.control {
                return self.fail(pes, FslError::MissingControl, index, false);
            }
            return self.complete_load(pes, pe, declared as usize);
        }
        if w.control {
            return self.fail(pes, FslError::PacketTooShort, index, true);
        }
        Rx::LoadWords { pe, declared, got }
    }

    fn complete_load(&mut self, pes: &mut Pes<impl PeMem>, pe: u8, len: usize) -> Rx {
        match pes.finish_load(pe, len) {
            Ok(()) => {
                self.emit(pes, load_ack(pe), true);
                Rx::Idle
            }
            Err(e) => self.fail(pes, e, pe as u16, true),
        }
    }

    fn on_ray_word<O: PeReadObserver>(
        &mut self,
        pes: &mut Pes<impl PeMem>,
        kind: RayKind,
        count: u16,
        idx: u32,
        w: FslWord,
        obs: &mut O,
    ) -> Rx {
        let ctl = w.control;
        let index = idx.min(u16::MAX as u32) as u16;
        let next = Rx::Ray { kind, count, idx: idx.saturating_add(1) };
        if (idx as usize) < RAY_HEADER_WORDS {
            if let Some(h) = self.head.get_mut(idx as usize) {
                *h = w.data;
            }
            if idx as usize == RAY_HEADER_WORDS - 1 {
                let (ray, t_max) = self.head_ray();
                if let Err((e, d)) = View::check_ray(&ray, t_max) {
                    return self.fail(pes, e, d, ctl);
                }
                if count == 0 {
                    if !ctl {
                        return self.fail(pes, FslError::MissingControl, index, false);
                    }
                    return self.execute(pes, kind, obs);
                }
            }
            if ctl {
                return self.fail(pes, FslError::PacketTooShort, index, true);
            }
            return next;
        }
        let j = (idx as usize).saturating_sub(RAY_HEADER_WORDS);
        let k = j / 2;
        if j & 1 == 0 {
            self.pending = w.data;
            let e = fsl::entry_from_words(w.data, 0);
            if let Err((e, d)) = pes.view().check_entry_target(k, e.pe, e.voxel) {
                return self.fail(pes, e, d, ctl);
            }
            if ctl {
                return self.fail(pes, FslError::PacketTooShort, index, true);
            }
            return next;
        }
        let e = fsl::entry_from_words(self.pending, w.data);
        if let Err((e, d)) = View::check_entry_exit(k, e.t_exit) {
            return self.fail(pes, e, d, ctl);
        }
        if self.list.push(e).is_err() {
            return self.fail(pes, FslError::ListTooLong, pes.cfg.max_list, ctl);
        }
        if k.saturating_add(1) == count as usize {
            if !ctl {
                return self.fail(pes, FslError::MissingControl, index, false);
            }
            return self.execute(pes, kind, obs);
        }
        if ctl {
            return self.fail(pes, FslError::PacketTooShort, index, true);
        }
        next
    }

    fn head_ray(&self) -> (Ray, f32) {
        let f = |i: usize| f32::from_bits(self.head.get(i).copied().unwrap_or(0));
        let ray = Ray { origin: Vec3::new(f(1), f(2), f(3)), dir: Vec3::new(f(4), f(5), f(6)) };
        (ray, f(7))
    }

    fn execute<O: PeReadObserver>(&mut self, pes: &mut Pes<impl PeMem>, kind: RayKind, obs: &mut O) -> Rx {
        let (ray, t_max) = self.head_ray();
        // Every word of the packet passed its check on arrival.
        let words = pes.trace_validated_observed(kind, &ray, t_max, &self.list, obs).to_words();
        let last = words.len().saturating_sub(1);
        for (i, &wd) in words.iter().enumerate() {
            self.emit(pes, wd, i == last);
        }
        Rx::Idle
    }
}
