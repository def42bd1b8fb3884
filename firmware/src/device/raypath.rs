//! The ray path: one ray from its 3D-DDA traversal list to the co-processor's answer
//! (GridRT seed 004 §1.4 with the extended request of `shared::fsl`, SPEC.md §4): put the 8
//! head words and 2 words per list entry, control bit on the last; get the 8 result words.
//! A ray whose list is empty sends nothing; a link that is the kernel itself (no
//! co-processor, `FslLink::trace_direct`) answers without words. Every wait is a bounded poll; a failed exchange
//! drains stale answer words so the next request starts clean. Each ray's FSL words are
//! charged to its class (primary, shadow, reflection) in [`FrameStats`].

use super::fail::Fail;
use super::scene::SceneStore;
use super::stats::{count, FrameStats, Stage, StageClock, Stopwatch};
use crate::dda::{build_list, TraversalList};
use crate::fsl::{FslLink, FslWord};
use gridrt_shared::fsl::{self as wire, op, FslError, RayKind, RayResult, RESULT_WORDS};
use gridrt_shared::math::Ray;

/// Default poll budget of every blocking FSL put/get (≈ 4 M polls: seconds on a 50 MHz
/// soft-core, far above the longest legitimate co-processor answer).
pub const DEFAULT_POLLS: u32 = 1 << 22;

/// Most stale words read back (and dropped) after an aborted ray, to resynchronise.
const DRAIN_WORDS: u32 = 4096;

/// Which counter an FSL exchange is charged to.
#[derive(Clone, Copy)]
pub(super) enum RayClass {
    /// Camera rays.
    Primary,
    /// Any-hit rays toward the light.
    Shadow,
    /// Mirror-reflection rays.
    Reflection,
}

/// The ray path: link, list buffer and counters.
pub(super) struct RayPath<L> {
    /// The co-processor link.
    pub(super) link: L,
    list: TraversalList,
    /// Counters of the current (or last) frame.
    pub(super) stats: FrameStats,
    /// Poll budget of every blocking put/get.
    pub(super) polls: u32,
}

impl<L: FslLink> RayPath<L> {
    /// A path over `link` with the default poll budget.
    pub(super) fn new(link: L) -> Self {
        Self { link, list: TraversalList::new(), stats: FrameStats::default(), polls: DEFAULT_POLLS }
    }

    /// Traces one ray and charges its FSL words to `class` (see [`trace`](Self::trace)).
    #[allow(clippy::too_many_arguments)]
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
        let words_so_far = |s: &FrameStats| s.fsl_words_out.wrapping_add(s.fsl_words_in);
        let before = words_so_far(&self.stats);
        let r = self.trace(scene, ray, kind, t_max, clock, sw);
        let words = words_so_far(&self.stats).wrapping_sub(before);
        let s = &mut self.stats;
        let counter = match class {
            RayClass::Primary => &mut s.fsl_words_primary,
            RayClass::Shadow => &mut s.fsl_words_shadow,
            RayClass::Reflection => &mut s.fsl_words_reflection,
        };
        count(counter, words);
        r
    }

    /// Traces one ray; `Ok(None)` when its list is empty (nothing sent).
    #[inline]
    fn trace<C: StageClock, const N: usize>(
        &mut self,
        scene: &SceneStore<N>,
        ray: &Ray,
        kind: RayKind,
        t_max: f32,
        clock: &C,
        sw: &mut Stopwatch,
    ) -> Result<Option<RayResult>, Fail> {
        let map = scene.voxel_pe.get(..scene.voxels).unwrap_or(&[]);
        build_list(&scene.grid, map, ray, 0.0, t_max, &mut self.list);
        sw.lap(clock, &mut self.stats, Stage::Traverse);
        if self.list.is_empty() {
            count(&mut self.stats.culled_rays, 1);
            return Ok(None);
        }
        // A link that is the kernel itself answers without FSL words (`FslLink::trace_direct`).
        let r = match self.link.trace_direct(kind, ray, t_max, &self.list) {
            Some(answer) => self.direct(answer),
            None => self.exchange(ray, kind, t_max),
        };
        sw.lap(clock, &mut self.stats, Stage::FslIo);
        if r.is_err() {
            self.drain();
        }
        r.map(Some)
    }

    /// Puts the request and gets the 8 result words.
    fn exchange(&mut self, ray: &Ray, kind: RayKind, t_max: f32) -> Result<RayResult, Fail> {
        let n = self.list.len();
        let head = wire::ray_request_head(kind, ray.origin.to_array(), ray.dir.to_array(), t_max, n as u16);
        for w in head {
            self.link.put(FslWord::data(w), self.polls).map_err(|e| Fail::link(e, "ray request"))?;
            count(&mut self.stats.fsl_words_out, 1);
        }
        for (left, e) in (0..n).rev().zip(self.list.iter()) {
            let [w0, w1] = wire::entry_words(*e);
            // The last entry's last word carries the control bit.
            let w1 = if left == 0 { FslWord::last(w1) } else { FslWord::data(w1) };
            for w in [FslWord::data(w0), w1] {
                self.link.put(w, self.polls).map_err(|e| Fail::link(e, "ray request"))?;
                count(&mut self.stats.fsl_words_out, 1);
            }
        }
        count(&mut self.stats.coproc_rays, 1);
        count(&mut self.stats.list_entries, n as u64);
        let mut words = [0u32; RESULT_WORDS];
        for (i, slot) in words.iter_mut().enumerate() {
            let w = self.link.get(self.polls).map_err(|e| Fail::link(e, "ray result"))?;
            count(&mut self.stats.fsl_words_in, 1);
            let opc = wire::opcode(w.data);
            // An ERROR word is a whole packet; anything else must be an 8-word RESULT packet
            // whose only control bit is on the last word.
            if i == 0 && opc != op::RESULT {
                return Err(Fail::Word(w.data, "ray result"));
            }
            if w.control != (i == RESULT_WORDS - 1) {
                return Err(Fail::Word(w.data, "ray result (misplaced control bit)"));
            }
            *slot = w.data;
        }
        let r = RayResult::from_words(&words).map_err(|_| Fail::Word(words[0], "ray result"))?;
        count(&mut self.stats.intersection_tests, r.tests as u64);
        count(&mut self.stats.coproc_cycles, r.cycles as u64);
        Ok(r)
    }

    /// Counts a ray the link answered without the word stream, like [`exchange`](Self::exchange)
    /// counts one it sent (no FSL words).
    fn direct(&mut self, answer: Result<RayResult, FslError>) -> Result<RayResult, Fail> {
        let r = answer.map_err(|e| Fail::Word(e.to_word(0), "ray result"))?;
        count(&mut self.stats.coproc_rays, 1);
        count(&mut self.stats.list_entries, self.list.len() as u64);
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
