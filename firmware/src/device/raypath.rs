//! The ray path: one ray from its 3D-DDA traversal list to the co-processor's answer
//! (GridRT, Nery 2010, with the extended request of `shared::fsl`, SPEC.md §4): the walk
//! writes the list entries straight into the request words (`dda::WalkGrid`), the head goes
//! in front, and the request leaves as one packet (8 head words and 2 words per entry,
//! control bit on the last); the 8 result words come back as one packet. A link that is the
//! kernel itself (no co-processor, `FslLink::trace_direct`) answers without words.
//! A ray whose list is empty sends nothing. Every wait is a bounded poll; a failed exchange
//! drains stale answer words so the next request starts clean. Each ray's FSL words are
//! charged to its class (primary, shadow, reflection) in [`FrameStats`].

use super::fail::Fail;
use super::scene::{SceneStore, LIGHT_CELLS};
use super::stats::{count, FrameStats, Stage, StageClock, Stopwatch};
use crate::dda::{OriginPlanes, Resume, MAX_LIST};
use crate::fsl::FslLink;
use gridrt_shared::fsl::{
    self as wire, op, FslError, ListEntry, RayKind, RayResult, ENTRY_WORDS, RAY_HEADER_WORDS, RESULT_WORDS,
};
use gridrt_shared::math::Ray;

/// Default poll budget of every blocking FSL put/get (≈ 4 M polls: seconds on a 50 MHz
/// soft-core, far above the longest legitimate co-processor answer).
pub const DEFAULT_POLLS: u32 = 1 << 22;

/// Most stale words read back (and dropped) after an aborted ray, to resynchronise.
const DRAIN_WORDS: u32 = 4096;

/// Entries in the first part of a camera ray's list (`RayPath::rest_of_list`).
const FIRST_PART: usize = 3;

/// Words of the longest ray request: the head and [`MAX_LIST`] entries.
const REQUEST_WORDS: usize = RAY_HEADER_WORDS + ENTRY_WORDS * MAX_LIST;

/// Words of a camera ray's first request: the head and [`FIRST_PART`] entries.
const FIRST_PART_END: usize = RAY_HEADER_WORDS + ENTRY_WORDS * FIRST_PART;
const _: () = assert!(FIRST_PART < MAX_LIST);

/// Which counter an FSL exchange is charged to; as `usize`, its index in [`RequestTally`].
#[derive(Clone, Copy)]
#[repr(usize)]
pub(super) enum RayClass {
    /// Camera rays.
    Primary,
    /// Any-hit rays toward the light.
    Shadow,
    /// Mirror-reflection rays.
    Reflection,
}

/// The counter of `class`'s FSL words.
fn class_words(s: &mut FrameStats, class: RayClass) -> &mut u64 {
    match class {
        RayClass::Primary => &mut s.fsl_words_primary,
        RayClass::Shadow => &mut s.fsl_words_shadow,
        RayClass::Reflection => &mut s.fsl_words_reflection,
    }
}

/// The exchanges of the current row by class (primary, shadow, reflection), in 32 bits: one
/// add per count where [`FrameStats`]' 64-bit word counters took seven each (measured:
/// about 40 instructions per request on RV32). [`RayPath::settle`] derives the word counts
/// from them (a request is its head and 2 words per entry, a well-formed answer 8 words) and
/// adds them to the frame's. A row sends at most 4 096 pixels' requests of at most
/// [`MAX_LIST`] entries each, far below 2^32.
#[derive(Clone, Copy, Default)]
struct RequestTally {
    /// Requests the link took.
    requests: [u32; 3],
    /// Their list entries.
    entries: [u32; 3],
    /// Well-formed 8-word answers received.
    answers: [u32; 3],
}

/// The ray path: link, request buffer and counters.
pub(super) struct RayPath<L> {
    /// The co-processor link.
    pub(super) link: L,
    /// The request being built: the head, then the list entries the walk writes.
    request: [u32; REQUEST_WORDS],
    /// The answer's words, reused from ray to ray: a fresh zeroed array per ray was a
    /// `memset` call (`exchange` reads only the words an answer filled).
    result: [u32; RESULT_WORDS],
    /// Counters of the current (or last) frame; the exchanges' since the last
    /// [`settle`](Self::settle) are in `tally`.
    pub(super) stats: FrameStats,
    /// The exchanges not yet in `stats`.
    tally: RequestTally,
    /// Poll budget of every blocking put/get.
    pub(super) polls: u32,
    /// The walk's `plane − o` of the camera rays' origin (`dda::OriginPlanes`).
    eye_planes: OriginPlanes,
    /// Where the current camera ray's walk stopped after the first part of its list.
    resume: Option<Resume>,
    /// The unit normals of recent hits (`shade::UnitNormals`), on a soft-float core.
    pub(super) normals: crate::shade::UnitNormals,
}

impl<L: FslLink> RayPath<L> {
    /// A path over `link` with the default poll budget.
    pub(super) fn new(link: L) -> Self {
        Self::with_polls(link, DEFAULT_POLLS)
    }

    /// A path over `link` whose blocking calls poll at most `polls` times. Inline, so that
    /// the path (6 KiB of request words) is built where it lives: on a worker hart's 32 KiB
    /// stack each copy counts.
    #[inline(always)]
    pub(super) fn with_polls(link: L, polls: u32) -> Self {
        Self {
            link,
            request: [0; REQUEST_WORDS],
            result: [0; RESULT_WORDS],
            stats: FrameStats::default(),
            tally: RequestTally::default(),
            polls,
            eye_planes: OriginPlanes::default(),
            resume: None,
            normals: crate::shade::UnitNormals::default(),
        }
    }

    /// Traces one ray and charges its FSL words to `class`; `Ok(None)` when its list is empty
    /// (nothing sent).
    ///
    /// Inline (a call's saves and restores cost about 18 instructions per pixel with an FPU,
    /// 25 without), except with `compact-code`: a copy of the walk at each call site is
    /// 4–7 KiB.
    #[allow(clippy::too_many_arguments)]
    #[cfg_attr(not(feature = "compact-code"), inline(always))]
    pub(super) fn trace_as<C: StageClock, const N: usize>(
        &mut self,
        scene: &SceneStore<N>,
        clock: &C,
        sw: &mut Stopwatch,
        ray: &Ray,
        kind: RayKind,
        t_max: f32,
        class: RayClass,
    ) -> Result<Option<RayResult>, Fail> {
        let map = scene.map();
        // Camera rays share the eye: on a soft-float core their walks take `plane − o` from
        // one table per frame (with an FPU the subtraction costs less than the table's check).
        // Their lists go in parts (`rest_of_list`).
        let parts = matches!(class, RayClass::Primary);
        let end = if parts { FIRST_PART_END } else { REQUEST_WORDS };
        let entries = self.request.get_mut(RAY_HEADER_WORDS..end).unwrap_or(&mut []);
        let n = if parts {
            scene.walk.write_entries_from(&mut self.eye_planes, map, ray, t_max, entries, &mut self.resume)
        } else if let Some(n) = Self::light_list(scene, class, ray, t_max, entries) {
            n
        } else {
            scene.walk.write_entries(map, ray, t_max, entries)
        };
        sw.lap(clock, &mut self.stats, Stage::Traverse);
        if n == 0 {
            count(&mut self.stats.culled_rays, 1);
            return Ok(None);
        }
        let r = self.send(kind, ray, t_max, n, class);
        sw.lap(clock, &mut self.stats, Stage::FslIo);
        if r.is_err() {
            self.drain();
        }
        if parts && self.resume.is_some() && r.as_ref().is_ok_and(|r| !r.hit) {
            return self.rest_of_list(scene, clock, sw, ray, (kind, t_max), n);
        }
        r.map(Some)
    }

    /// A shadow ray's list from the light's cells (`dda::LightCells`: a superset of the walk's
    /// voxels with `t_exit` 1, the same answer); `None` where it is to be walked.
    #[inline(always)]
    fn light_list<const N: usize>(
        scene: &SceneStore<N>,
        class: RayClass,
        ray: &Ray,
        t_max: f32,
        entries: &mut [u32],
    ) -> Option<usize> {
        if LIGHT_CELLS == 0 || !matches!(class, RayClass::Shadow) {
            return None;
        }
        scene.light_cells.write_entries(ray, t_max, entries)
    }

    /// A camera ray whose first [`FIRST_PART`] entries (`listed`) missed: the rest of its
    /// walk, sent as a second request (room for [`MAX_LIST`] entries in all, as one list).
    /// The co-processor's winner is the first entry in list order with an accepted hit
    /// (SPEC.md §4.3), so a first part that hits answers as the whole list would (and its walk
    /// stops there), and one that misses leaves the answer to the rest.
    #[cold]
    #[inline(never)]
    fn rest_of_list<C: StageClock, const N: usize>(
        &mut self,
        scene: &SceneStore<N>,
        clock: &C,
        sw: &mut Stopwatch,
        ray: &Ray,
        (kind, t_max): (RayKind, f32),
        listed: usize,
    ) -> Result<Option<RayResult>, Fail> {
        // listed ≤ MAX_LIST (it is FIRST_PART): the products and sums are exact.
        let room = ENTRY_WORDS.wrapping_mul(MAX_LIST.saturating_sub(listed));
        let entries = self.request.get_mut(RAY_HEADER_WORDS..RAY_HEADER_WORDS.wrapping_add(room)).unwrap_or(&mut []);
        let n = scene.walk.resume_entries(&self.eye_planes, scene.map(), &mut self.resume, entries);
        // Whatever remains past MAX_LIST entries is dropped, as one list would drop it.
        self.resume = None;
        sw.lap(clock, &mut self.stats, Stage::Traverse);
        let r = self.send(kind, ray, t_max, n, RayClass::Primary);
        sw.lap(clock, &mut self.stats, Stage::FslIo);
        if r.is_err() {
            self.drain();
        }
        r.map(Some)
    }

    /// Sends the ray with the `n` entries the walk wrote and returns the answer (or hands
    /// them to a link that is the kernel itself).
    #[inline(always)]
    fn send(&mut self, kind: RayKind, ray: &Ray, t_max: f32, n: usize, class: RayClass) -> Result<RayResult, Fail> {
        if let Some(answer) = if L::DIRECT { self.trace_direct(kind, ray, t_max, n) } else { None } {
            return self.direct(answer, n);
        }
        // n ≤ MAX_LIST (the walk stops at the buffer's end): the casts and sums are exact.
        let head = wire::ray_request_head(kind, ray.origin.to_array(), ray.dir.to_array(), t_max, n as u16);
        if let Some(h) = self.request.get_mut(..RAY_HEADER_WORDS) {
            h.copy_from_slice(&head);
        }
        self.exchange(RAY_HEADER_WORDS.wrapping_add(ENTRY_WORDS.wrapping_mul(n)), class)
    }

    /// Puts the first `len` words of the request and gets the 8 result words. Inline: out of
    /// line its answer came back through a `memcpy` (measured: 140 instructions per ray).
    #[inline(always)]
    fn exchange(&mut self, len: usize, class: RayClass) -> Result<RayResult, Fail> {
        let request = self.request.get(..len).unwrap_or(&[]);
        let sent = self.link.put_packet(request, self.polls);
        sent.map_err(|e| Fail::link(e, "ray request"))?;
        let (t, c) = (&mut self.tally, class as usize);
        // `c` < 3 and len ≤ REQUEST_WORDS: the sums stay below 2^32 within a row (above).
        if let (Some(r), Some(e)) = (t.requests.get_mut(c), t.entries.get_mut(c)) {
            *r = r.wrapping_add(1);
            *e = e.wrapping_add((len.wrapping_sub(RAY_HEADER_WORDS) / ENTRY_WORDS) as u32);
        }
        // The checks below read only words this answer filled (`words[..n]`, n ≥ 1: a read
        // into a non-empty buffer fills at least word 0 or fails), so the reused buffer
        // reads as a fresh zeroed one.
        let words = &mut self.result;
        let got = self.link.get_packet(words, self.polls);
        let (n, ended) = got.map_err(|e| Fail::link(e, "ray result"))?;
        // An ERROR word is a whole packet; anything else must be an 8-word RESULT packet
        // whose only control bit is on the last word.
        if wire::opcode(words[0]) != op::RESULT || n != RESULT_WORDS || !ended {
            return Err(Self::malformed(&mut self.stats, class, words, n));
        }
        if let Some(a) = self.tally.answers.get_mut(c) {
            *a = a.wrapping_add(1);
        }
        let s = &mut self.stats;
        let r = RayResult::from_words(words).map_err(|_| Fail::Word(words[0], "ray result"))?;
        count(&mut s.intersection_tests, r.tests as u64);
        count(&mut s.coproc_cycles, r.cycles as u64);
        Ok(r)
    }

    /// The failure of an answer that is not one well-formed RESULT packet, its `n` words
    /// counted (the frame stops: no tally for them).
    #[cold]
    #[inline(never)]
    fn malformed(stats: &mut FrameStats, class: RayClass, words: &[u32], n: usize) -> Fail {
        count(&mut stats.fsl_words_in, n as u64);
        count(class_words(stats, class), n as u64);
        let first = words.first().copied().unwrap_or(0);
        if wire::opcode(first) != op::RESULT {
            return Fail::Word(first, "ray result");
        }
        let at = words.get(n.wrapping_sub(1)).copied().unwrap_or(0);
        Fail::Word(at, "ray result (misplaced control bit)")
    }

    /// Adds the exchanges tallied since the last call to [`stats`](Self::stats): at each
    /// row's end and before the frame's counters are read.
    pub(super) fn settle(&mut self) {
        // Copied and cleared field by field (`mem::take` of the whole tally was a `memcpy`
        // and a `memset` call).
        let t =
            RequestTally { requests: self.tally.requests, entries: self.tally.entries, answers: self.tally.answers };
        self.tally.requests = [0; 3];
        self.tally.entries = [0; 3];
        self.tally.answers = [0; 3];
        let s = &mut self.stats;
        for class in [RayClass::Primary, RayClass::Shadow, RayClass::Reflection] {
            let i = class as usize;
            let requests = u64::from(t.requests.get(i).copied().unwrap_or(0));
            let entries = u64::from(t.entries.get(i).copied().unwrap_or(0));
            let answers = u64::from(t.answers.get(i).copied().unwrap_or(0));
            // Each term < 2^32 · 800: no overflow in 64 bits.
            let out =
                requests.wrapping_mul(RAY_HEADER_WORDS as u64).wrapping_add(entries.wrapping_mul(ENTRY_WORDS as u64));
            let inw = answers.wrapping_mul(RESULT_WORDS as u64);
            count(&mut s.coproc_rays, requests);
            count(&mut s.list_entries, entries);
            count(&mut s.fsl_words_out, out);
            count(&mut s.fsl_words_in, inw);
            count(class_words(s, class), out.wrapping_add(inw));
        }
    }

    /// A link that is the kernel itself ([`FslLink::DIRECT`]): the `n` entries the walk wrote,
    /// decoded into a list for [`FslLink::trace_direct`].
    fn trace_direct(&mut self, kind: RayKind, ray: &Ray, t_max: f32, n: usize) -> Option<Result<RayResult, FslError>> {
        let mut list = [ListEntry { voxel: 0, pe: 0, t_exit: 0.0 }; MAX_LIST];
        let words = self.request.get(RAY_HEADER_WORDS..).unwrap_or(&[]);
        for (e, w) in list.iter_mut().zip(words.chunks_exact(ENTRY_WORDS)).take(n) {
            if let [w0, w1] = *w {
                *e = wire::entry_from_words(w0, w1);
            }
        }
        self.link.trace_direct(kind, ray, t_max, list.get(..n).unwrap_or(&[]))
    }

    /// Counts a ray the link answered without the word stream, like [`exchange`](Self::exchange)
    /// counts one it sent (no FSL words).
    fn direct(&mut self, answer: Result<RayResult, FslError>, entries: usize) -> Result<RayResult, Fail> {
        let r = answer.map_err(|e| Fail::Word(e.to_word(0), "ray result"))?;
        count(&mut self.stats.coproc_rays, 1);
        count(&mut self.stats.list_entries, entries as u64);
        count(&mut self.stats.intersection_tests, r.tests as u64);
        count(&mut self.stats.coproc_cycles, r.cycles as u64);
        Ok(r)
    }

    /// Drops stale answer words after an aborted ray so the next request starts clean.
    fn drain(&mut self) {
        for _ in 0..DRAIN_WORDS {
            match self.link.nget() {
                Ok(_) => continue,
                Err(_) => break,
            }
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::{RayClass, RayPath};
    use crate::fsl::{FslLink, FslWord};
    use gridrt_shared::fsl::{op, RESULT_WORDS};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::collections::VecDeque;

    /// Swallows what is put; plays back the scripted answer words.
    #[derive(Default)]
    struct Answers(VecDeque<FslWord>);

    impl FslLink for Answers {
        type Error = core::convert::Infallible;
        fn nput(&mut self, _: FslWord) -> nb::Result<(), Self::Error> {
            Ok(())
        }
        fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
            self.0.pop_front().ok_or(nb::Error::WouldBlock)
        }
    }

    /// A random answer: 1..=8 words (RESULT opcode or not), the control bit on its last word
    /// or on none (then it is cut at 8 words).
    fn random_answer(rng: &mut ChaCha8Rng) -> Vec<FslWord> {
        let n = rng.gen_range(1..=RESULT_WORDS);
        let ended = rng.gen_bool(0.8);
        (0..n)
            .map(|i| {
                let mut data: u32 = rng.gen();
                if i == 0 && rng.gen_bool(0.7) {
                    data = data & 0x0FFF_FFFF | op::RESULT << 28;
                }
                if i + 1 == n && ended {
                    FslWord::last(data)
                } else {
                    FslWord::data(data)
                }
            })
            .collect()
    }

    /// The outcome of `exchange` on `path` for `answer` (debug text: `Fail` has no `==`).
    fn outcome(path: &mut RayPath<Answers>, answer: &[FslWord]) -> String {
        path.link.0.clear();
        path.link.0.extend(answer.iter().copied());
        path.polls = 4;
        format!("{:?}", path.exchange(super::RAY_HEADER_WORDS, RayClass::Primary))
    }

    /// The answer buffer is reused from ray to ray (no zeroed array per ray): every answer,
    /// well formed or not, is judged as a fresh path with a zeroed buffer judges it, after
    /// whatever answers came before.
    #[test]
    fn a_reused_answer_buffer_judges_every_answer_as_a_fresh_one() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x5EED_0A15);
        let mut reused = RayPath::new(Answers::default());
        for _ in 0..20_000 {
            let answer = random_answer(&mut rng);
            let fresh = outcome(&mut RayPath::new(Answers::default()), &answer);
            assert_eq!(outcome(&mut reused, &answer), fresh, "{answer:?}");
        }
    }
}
