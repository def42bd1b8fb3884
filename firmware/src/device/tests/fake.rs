//! A small scripted co-processor for the device tests, independent of the `gridrt-coproc`
//! model: it checks packet framing strictly and answers with canned results.

use crate::fsl::{FslLink, FslWord};
use gridrt_shared::fsl::{self as wire, entry_from_words, op, FslError, ListEntry, RayKind, RayResult};
use gridrt_shared::math::Ray;
use std::collections::VecDeque;
use std::vec::Vec;

#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Mode {
    /// Answer everything.
    Normal,
    /// Answer ray packets with this ERROR word.
    ErrorOnRay(u32),
    /// Answer LOAD_PE packets with this ERROR word.
    ErrorOnLoad(u32),
    /// Never answer ray packets (the device must time out).
    SilentOnRay,
    /// Answer FRAME packets with this ERROR word (an older co-processor: `UnknownOpcode`).
    ErrorOnFrame(u32),
}

#[derive(Debug, Clone, PartialEq)]
pub(super) struct RayReq {
    pub(super) kind: u32,
    pub(super) origin: [f32; 3],
    pub(super) dir: [f32; 3],
    pub(super) t_max: f32,
    pub(super) list: Vec<ListEntry>,
}

pub(super) struct FakeCoproc {
    pub(super) mode: Mode,
    /// Answer of any-hit queries.
    pub(super) shadow_hit: bool,
    /// Answer rays through `FslLink::trace_direct` instead of the word stream.
    pub(super) direct: bool,
    packet: Vec<u32>,
    out: VecDeque<FslWord>,
    pub(super) words_in: usize,
    pub(super) clears: usize,
    /// FRAME boxes received: min xyz, max xyz.
    pub(super) frames: Vec<[f32; 6]>,
    pub(super) loads: Vec<(u8, Vec<u32>)>,
    pub(super) rays: Vec<RayReq>,
    pub(super) violations: Vec<&'static str>,
}

impl FakeCoproc {
    pub(super) fn new() -> Self {
        Self {
            mode: Mode::Normal,
            shadow_hit: false,
            direct: false,
            packet: Vec::new(),
            out: VecDeque::new(),
            words_in: 0,
            clears: 0,
            frames: Vec::new(),
            loads: Vec::new(),
            rays: Vec::new(),
            violations: Vec::new(),
        }
    }

    fn answer(&mut self, words: &[u32]) {
        for (i, &w) in words.iter().enumerate() {
            self.out.push_back(FslWord { data: w, control: i + 1 == words.len() });
        }
    }

    fn packet_done(&mut self) {
        let p = core::mem::take(&mut self.packet);
        let ack = op::ACK << 28;
        match wire::opcode(p[0]) {
            op::CLEAR => {
                if p.len() != 1 {
                    self.violations.push("CLEAR length");
                }
                self.clears += 1;
                self.answer(&[ack]);
            }
            op::FRAME => {
                if p.len() != wire::FRAME_WORDS {
                    self.violations.push("FRAME length");
                    return self.answer(&[FslError::PacketTooShort.to_word(0)]);
                }
                let f = |i: usize| f32::from_bits(p[i]);
                self.frames.push([f(1), f(2), f(3), f(4), f(5), f(6)]);
                match self.mode {
                    Mode::ErrorOnFrame(w) => self.answer(&[w]),
                    _ => self.answer(&[wire::ack_word(op::FRAME, 0)]),
                }
            }
            op::LOAD_PE => {
                let count = p.get(1).copied().unwrap_or(u32::MAX) as usize;
                if p.len() != 2 + count {
                    self.violations.push("LOAD_PE length");
                }
                self.loads.push((p[0] as u8, p[2..].to_vec()));
                match self.mode {
                    Mode::ErrorOnLoad(w) => self.answer(&[w]),
                    _ => self.answer(&[ack]),
                }
            }
            op::RAY_CLOSEST | op::RAY_ANY => {
                let n = (p[0] & 0xFFFF) as usize;
                if p.len() != RAY_HEADER + 2 * n || n == 0 {
                    self.violations.push("ray length");
                }
                let f = |i: usize| f32::from_bits(p[i]);
                let list: Vec<_> = p[RAY_HEADER..].chunks(2).map(|c| entry_from_words(c[0], c[1])).collect();
                let req = RayReq {
                    kind: wire::opcode(p[0]),
                    origin: [f(1), f(2), f(3)],
                    dir: [f(4), f(5), f(6)],
                    t_max: f(7),
                    list,
                };
                let r = self.result_of(&req);
                self.rays.push(req);
                match self.mode {
                    Mode::ErrorOnRay(w) => return self.answer(&[w]),
                    Mode::SilentOnRay => return,
                    _ => {}
                }
                self.answer(&r.to_words());
            }
            _ => {
                self.violations.push("unknown opcode");
                self.answer(&[FslError::UnknownOpcode.to_word(0)]);
            }
        }
    }
}

const RAY_HEADER: usize = wire::RAY_HEADER_WORDS;

impl FakeCoproc {
    /// The canned answer: a closest-hit query (or an any-hit one when `shadow_hit`) hits in
    /// the first entry, 648 cycles per entry.
    fn result_of(&self, req: &RayReq) -> RayResult {
        let n = req.list.len();
        let hit = req.kind == op::RAY_CLOSEST || self.shadow_hit;
        match (hit, req.list.first()) {
            (true, Some(e)) => RayResult {
                hit: true,
                pe: e.pe,
                list_pos: 0,
                t: e.t_exit * 0.95,
                prim: e.voxel + 100,
                material: (e.voxel % 2) as u16,
                tests: n as u16,
                normal: [0.0, 0.0, 2.0],
                cycles: 648 * n as u32,
            },
            _ => RayResult { tests: n as u16, cycles: 648 * n as u32, ..RayResult::MISS },
        }
    }
}

impl FslLink for FakeCoproc {
    type Error = core::convert::Infallible;
    fn nput(&mut self, word: FslWord) -> nb::Result<(), Self::Error> {
        self.words_in += 1;
        self.packet.push(word.data);
        if word.control {
            self.packet_done();
        }
        Ok(())
    }
    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        self.out.pop_front().ok_or(nb::Error::WouldBlock)
    }
    // May answer directly (`direct`); otherwise `trace_direct` declines and the words go out.
    const DIRECT: bool = true;

    /// With `direct` set, answers rays without words (the soft-core-only link's path).
    fn trace_direct(
        &mut self,
        kind: RayKind,
        ray: &Ray,
        t_max: f32,
        list: &[ListEntry],
    ) -> Option<Result<RayResult, FslError>> {
        if !self.direct {
            return None;
        }
        let req = RayReq {
            kind: kind.opcode(),
            origin: ray.origin.to_array(),
            dir: ray.dir.to_array(),
            t_max,
            list: list.to_vec(),
        };
        let r = self.result_of(&req);
        self.rays.push(req);
        Some(Ok(r))
    }
}
