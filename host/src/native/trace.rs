//! One ray through the fast path, and whole frames of primary rays.

use core::ops::ControlFlow;

use gridrt_coproc::isect::watertight::Watertight;
use gridrt_coproc::{FixedFrame, Kernel, RayKind, RayResult, T_EXIT_REL_TOL};
use gridrt_shared::math::Ray;

use super::filter::{LaneFilter, LaneRay, Portable, LANES};
use super::scene::{NativeScene, OrderedRef, Span};

/// What the firmware and the co-processor make of one ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Trace {
    /// The traversal list is empty: the firmware sends nothing.
    Culled,
    /// The co-processor's answer (as `Coprocessor::trace_untimed` gives it).
    Result(RayResult),
}

/// Totals of a frame of primary rays.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Hits {
    /// Rays with an accepted hit.
    pub hits: u64,
    /// Rays with an empty traversal list.
    pub culled: u64,
    /// Wrapping sum of the hit prim ids.
    pub prim_sum: u64,
    /// Wrapping sum of every result word (a fingerprint of the frame's answers: keeps every
    /// word of the result computed in a timed pass).
    pub word_sum: u64,
    /// Ray–triangle tests the PEs perform.
    pub tests: u64,
}

impl Hits {
    /// Counts one ray.
    pub fn add(&mut self, t: &Trace) {
        match t {
            Trace::Culled => self.culled += 1,
            Trace::Result(r) => {
                self.tests += r.tests as u64;
                for w in r.to_words() {
                    self.word_sum = self.word_sum.wrapping_add(w as u64);
                }
                if r.hit {
                    self.hits += 1;
                    self.prim_sum = self.prim_sum.wrapping_add(r.prim as u64);
                }
            }
        }
    }

    /// Totals of two disjoint sets of rays.
    pub fn merge(mut self, o: Self) -> Self {
        self.hits += o.hits;
        self.culled += o.culled;
        self.prim_sum = self.prim_sum.wrapping_add(o.prim_sum);
        self.word_sum = self.word_sum.wrapping_add(o.word_sum);
        self.tests += o.tests;
        self
    }
}

// Copied from `coproc/src/coproc.rs` (module doc of `native`).
#[inline(always)]
fn accept(t: f32, t_max: f32, hi: f32) -> bool {
    t > 0.0 && t < t_max && t <= hi
}

#[inline(always)]
fn inflate(x: f32) -> f32 {
    if x.is_finite() {
        x + x.abs() * (1.0 / 65536.0)
    } else {
        x
    }
}

/// One query's state while the DDA walks.
struct Query<'r> {
    /// The ray in memory that was written well before (a row buffer): reading it back does
    /// not stall on the stores that made it.
    ray: &'r Ray,
    kind: RayKind,
    t_max: f32,
    /// Set at the first entry: the kernel's and the filter's ray setup.
    prepared: Option<(Option<<Watertight as Kernel>::RayData>, LaneRay)>,
    /// Tests the PEs perform, over the entries so far.
    tests: u64,
    /// List position of the current entry.
    k: usize,
}

/// The accepted hit of an entry and what it names.
#[derive(Debug, Clone, Copy)]
enum Winner {
    /// Lane `lane` of group `group`.
    Lane {
        t: f32,
        group: u32,
        lane: u32,
    },
    Tri {
        t: f32,
        slot: u32,
    },
    Prim {
        t: f32,
        prim: u32,
    },
}

/// One entry's triangle-group search: the arguments of [`NativeScene::entry_groups`].
struct EntryArgs<'a> {
    scene: &'a NativeScene,
    pre: &'a <Watertight as Kernel>::RayData,
    lane_ray: &'a LaneRay,
    kind: RayKind,
    span: &'a Span,
    t_max: f32,
    hi: f32,
}

impl EntryArgs<'_> {
    /// The search with filter `F`, inlined into the caller (and so compiled with its target
    /// features).
    #[inline(always)]
    fn search<F: LaneFilter>(&self) -> (Option<Winner>, u32) {
        self.scene.entry_groups::<F>(self.pre, self.lane_ray, self.kind, self.span, self.t_max, self.hi)
    }
}

/// How an entry's triangle groups are searched: the filter, compiled with its target features
/// (the DDA around it needs none). Kept out of line so the walk's loop stays small.
trait EntrySearch {
    fn entry(args: &EntryArgs) -> (Option<Winner>, u32);
}

struct PortableSearch;

impl EntrySearch for PortableSearch {
    #[inline(never)]
    fn entry(args: &EntryArgs) -> (Option<Winner>, u32) {
        args.search::<Portable>()
    }
}

#[cfg(target_arch = "x86_64")]
struct Avx2Search;

#[cfg(target_arch = "x86_64")]
impl EntrySearch for Avx2Search {
    #[inline(always)]
    fn entry(args: &EntryArgs) -> (Option<Winner>, u32) {
        // SAFETY: `Avx2Search` is only chosen when AVX2 and FMA were detected
        // (`NativeScene::avx2`, set by `simd_available`).
        unsafe { entry_avx2(args) }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn entry_avx2(args: &EntryArgs) -> (Option<Winner>, u32) {
    args.search::<super::filter::Avx2>()
}

impl NativeScene {
    /// Traces `ray` as the firmware's ray path does: the DDA over `[0, t_max]`, then (unless
    /// the list is empty) the co-processor's query of `kind` with `t_max`.
    pub fn trace(&self, kind: RayKind, ray: &Ray, t_max: f32) -> Trace {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            return self.trace_with::<Avx2Search>(kind, ray, t_max);
        }
        self.trace_with::<PortableSearch>(kind, ray, t_max)
    }

    /// The frame functions' dispatch: `f` runs with the entry search this CPU supports.
    #[inline(always)]
    pub(crate) fn with_search<R>(&self, f: impl FnOnce(&dyn Fn(&Ray) -> Trace) -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            return f(&|ray| self.trace_with::<Avx2Search>(RayKind::Closest, ray, f32::INFINITY));
        }
        f(&|ray| self.trace_with::<PortableSearch>(RayKind::Closest, ray, f32::INFINITY))
    }

    #[inline(always)]
    fn trace_with<S: EntrySearch>(&self, kind: RayKind, ray: &Ray, t_max: f32) -> Trace {
        let mut found = None;
        let walk = self.walk.start_at(ray.origin.to_array(), ray.dir.to_array(), 0.0, t_max);
        let mut q = Query { ray, kind, t_max, prepared: None, tests: 0, k: 0 };
        if let Some(mut walk) = walk {
            while let Some((span, t_exit)) = self.walk.next_entry(&mut walk, &self.cell_span) {
                if let ControlFlow::Break(b) = self.visit_entry::<S>(&mut q, span, t_exit) {
                    found = Some(b);
                    break;
                }
            }
        }
        let Query { prepared, tests, .. } = q;
        let any_entry = prepared.is_some();
        if !any_entry {
            return Trace::Culled;
        }
        let tests = tests.min(u16::MAX as u64) as u16;
        let Some((k, pe, w)) = found else { return Trace::Result(RayResult { tests, ..RayResult::MISS }) };
        let list_pos = k.min(u16::MAX as usize) as u16;
        let r = match w {
            Winner::Lane { t, group, lane } => {
                let g = &self.groups[group as usize];
                let l = lane as usize;
                RayResult {
                    hit: true,
                    pe,
                    list_pos,
                    t,
                    prim: g.prim[l],
                    material: g.material[l] as u16,
                    tests,
                    normal: [g.normal[0][l], g.normal[1][l], g.normal[2][l]],
                    cycles: 0,
                }
            }
            Winner::Tri { t, slot } => {
                let s = &self.slots[slot as usize];
                RayResult {
                    hit: true,
                    pe,
                    list_pos,
                    t,
                    prim: s.prim,
                    material: s.material,
                    tests,
                    normal: s.normal,
                    cycles: 0,
                }
            }
            Winner::Prim { t, prim } => {
                let words = &self.prims[prim as usize];
                RayResult {
                    hit: true,
                    pe,
                    list_pos,
                    t,
                    prim: words[1],
                    material: words[2] as u16,
                    tests,
                    normal: gridrt_coproc::isect::analytic::normal(words, ray, t),
                    cycles: 0,
                }
            }
        };
        Trace::Result(r)
    }

    /// One list entry (out of line: the DDA loop around it stays in registers).
    #[inline(never)]
    fn visit_entry<S: EntrySearch>(
        &self,
        q: &mut Query<'_>,
        span: u32,
        t_exit: f32,
    ) -> ControlFlow<(usize, u8, Winner)> {
        // The kernel's per-ray setup and the filter's, at the first entry (most rays have none).
        let ray = q.ray;
        let (pre, lane_ray) =
            q.prepared.get_or_insert_with(|| (Watertight::prepare(ray, &FixedFrame::IDENTITY).ok(), LaneRay::new(ray)));
        // Always in range: spans are built with the table.
        let Some(span) = self.spans.get(span as usize) else { return ControlFlow::Continue(()) };
        let Some(pre) = pre else {
            // The model's answer to a ray the kernel cannot prepare (fixed point only; f32
            // always prepares): every entry's tests counted, no hit.
            q.tests += span.refs as u64;
            return ControlFlow::Continue(());
        };
        let hi = t_exit * (1.0 + T_EXIT_REL_TOL);
        let (w, n) = if span.ordered_len > 0 {
            self.entry_ordered(pre, ray, q.kind, span, q.t_max, hi)
        } else {
            S::entry(&EntryArgs { scene: self, pre, lane_ray, kind: q.kind, span, t_max: q.t_max, hi })
        };
        q.tests += n as u64;
        match w {
            Some(w) => ControlFlow::Break((q.k, span.pe, w)),
            None => {
                q.k += 1;
                ControlFlow::Continue(())
            }
        }
    }

    /// One entry of triangles only: the filter on each group, the kernel on the survivors in
    /// reference order (`View::test_entry`). Returns the entry's winner and the tests the PE
    /// performs (all references for Closest; up to the hit for Any).
    #[inline(always)]
    fn entry_groups<F: LaneFilter>(
        &self,
        pre: &<Watertight as Kernel>::RayData,
        lane_ray: &LaneRay,
        kind: RayKind,
        span: &Span,
        t_max: f32,
        hi: f32,
    ) -> (Option<Winner>, u32) {
        let limit = if t_max < hi { t_max } else { hi };
        let mut bound = inflate(limit);
        let mut best: Option<(f32, Winner, u32)> = None;
        let first = span.group as usize;
        let n_groups = (span.lanes as usize).div_ceil(LANES);
        let groups = self.groups.get(first..first + n_groups).unwrap_or(&[]);
        for (gi, g) in groups.iter().enumerate() {
            let used = (span.lanes as usize - gi * LANES).min(LANES);
            let mut m = F::survivors(g, lane_ray) & ((1u32 << used) - 1);
            while m != 0 {
                let lane = m.trailing_zeros() as usize;
                m &= m - 1;
                let Ok(Some(t)) = Watertight::intersect(pre, &g.words(lane), bound) else { continue };
                if !accept(t, t_max, hi) {
                    continue;
                }
                let prim = g.prim[lane];
                let w = Winner::Lane { t, group: (first + gi) as u32, lane: lane as u32 };
                match kind {
                    RayKind::Any => return (Some(w), (gi * LANES + lane) as u32 + 1),
                    RayKind::Closest => {
                        if best.is_none_or(|(bt, _, bp)| t < bt || (t == bt && prim < bp)) {
                            best = Some((t, w, prim));
                            bound = inflate(t);
                        }
                    }
                }
            }
        }
        (best.map(|(_, w, _)| w), span.refs)
    }

    /// One entry holding analytic primitives: the model's loop, reference by reference.
    fn entry_ordered(
        &self,
        pre: &<Watertight as Kernel>::RayData,
        ray: &Ray,
        kind: RayKind,
        span: &Span,
        t_max: f32,
        hi: f32,
    ) -> (Option<Winner>, u32) {
        let limit = if t_max < hi { t_max } else { hi };
        let mut bound = inflate(limit);
        let mut best: Option<(f32, u32, Winner)> = None;
        let first = span.ordered as usize;
        let refs = self.ordered.get(first..first + span.ordered_len as usize).unwrap_or(&[]);
        for (i, r) in refs.iter().enumerate() {
            let (t, prim, w) = match *r {
                OrderedRef::Prim(p) => {
                    let words = &self.prims[p as usize];
                    let Some(t) = gridrt_coproc::isect::analytic::intersect(words, ray) else { continue };
                    (t, words[1], Winner::Prim { t, prim: p })
                }
                OrderedRef::Tri(slot) => {
                    let s = &self.slots[slot as usize];
                    let Ok(Some(t)) = Watertight::intersect(pre, &s.words, bound) else { continue };
                    (t, s.prim, Winner::Tri { t, slot })
                }
            };
            if !accept(t, t_max, hi) {
                continue;
            }
            match kind {
                RayKind::Any => return (Some(w), i as u32 + 1),
                RayKind::Closest => {
                    if best.is_none_or(|(bt, bp, _)| t < bt || (t == bt && prim < bp)) {
                        best = Some((t, prim, w));
                        bound = inflate(t);
                    }
                }
            }
        }
        (best.map(|(_, _, w)| w), span.refs)
    }
}
