//! Test support for the co-simulation: random scenes as PE images, packets, and the
//! reference RESULT of a ray (the model's search and timeline with the twin kernel and the
//! RTL's timing constants).

#![allow(dead_code)]

use gridrt_coproc::isect::geometric_normal;
use gridrt_coproc::{FslWord, ListEntry, RayKind, RayResult};
use gridrt_rtl::twin::{self, Frame, Test};
use gridrt_shared::fsl;
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::PeImage;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// RTL timing (rtl/README.md §4.5): cycles from the last request word to the first exec
/// cycle, from the decision to the first result word, and from an entry's last issue to its
/// done event (issue interval 1, one setup cycle per entry).
pub const RAY_SETUP_CYCLES: u64 = 33;
pub const ARBITRATION_CYCLES: u64 = 7;
pub const TEST_LATENCY: u64 = 56;
pub const VOXEL_SETUP: u64 = 1;

/// One triangle of a PE image.
#[derive(Debug, Clone, Copy)]
pub struct Tri {
    pub v: [Vec3; 3],
    pub prim: u32,
    pub material: u32,
}

/// A PE image built from voxels (sorted ids), each a list of local triangle refs.
#[derive(Debug, Clone, Default)]
pub struct PeScene {
    pub voxels: Vec<(u32, Vec<u32>)>,
    pub tris: Vec<Tri>,
}

impl PeScene {
    /// The PE memory image (SPEC §5.4).
    pub fn image(&self) -> Vec<u32> {
        let refs: Vec<u32> = self.voxels.iter().flat_map(|(_, r)| r.iter().copied()).collect();
        let mut w = vec![0xFFFF_0002, self.tris.len() as u32, self.voxels.len() as u32, refs.len() as u32, 0];
        let mut first = 0u32;
        for (id, r) in &self.voxels {
            w.extend([*id, first, r.len() as u32]);
            first += r.len() as u32;
        }
        w.extend(&refs);
        for t in &self.tris {
            for v in t.v {
                w.extend(v.to_array().map(f32::to_bits));
            }
            w.extend([t.prim, t.material]);
        }
        w
    }
}

/// A LOAD_PE packet.
pub fn load_packet(pe: u8, image: &[u32]) -> Vec<FslWord> {
    let mut words = vec![fsl::load_header(pe), image.len() as u32];
    words.extend(image);
    framed(&words)
}

/// A FRAME packet (rtl/README.md §2).
pub fn frame_packet(min: [f32; 3], max: [f32; 3]) -> Vec<FslWord> {
    let mut words = vec![0x5000_0000];
    words.extend(min.map(f32::to_bits));
    words.extend(max.map(f32::to_bits));
    framed(&words)
}

/// A ray request.
pub fn ray_packet(kind: RayKind, ray: &Ray, t_max: f32, list: &[ListEntry]) -> Vec<FslWord> {
    let mut words =
        fsl::ray_request_head(kind, ray.origin.to_array(), ray.dir.to_array(), t_max, list.len() as u16).to_vec();
    for e in list {
        words.extend(fsl::entry_words(*e));
    }
    framed(&words)
}

/// Control bit on the last word only.
pub fn framed(words: &[u32]) -> Vec<FslWord> {
    words.iter().enumerate().map(|(i, &d)| FslWord { data: d, control: i + 1 == words.len() }).collect()
}

/// The scene the reference sees: frame and the loaded PE images.
pub struct Loaded<'a> {
    pub frame: Frame,
    pub pes: &'a [PeScene],
}

fn canonical(x: f32) -> f32 {
    if x.is_nan() {
        f32::NAN
    } else {
        x
    }
}

/// The RESULT the RTL must send for a valid ray request.
pub fn reference(s: &Loaded, kind: RayKind, ray: &Ray, t_max: f32, list: &[ListEntry]) -> RayResult {
    let setup = twin::setup(&s.frame, ray);
    // Per entry: (tests, accepted hit (t bits, prim, index in entry, tri)).
    let mut found: Option<(usize, u32, usize, usize)> = None; // (k, t bits, hit index, tri)
    let mut counts = Vec::with_capacity(list.len());
    for (k, e) in list.iter().enumerate() {
        let pe = &s.pes[e.pe as usize];
        let (_, refs) = pe.voxels.iter().find(|(id, _)| *id == e.voxel).expect("listed voxel is loaded");
        counts.push(refs.len() as u64);
        if found.is_some() {
            continue;
        }
        let hi = e.t_exit * f32::from_bits(0x3F80_0800);
        let mut best: Option<(u32, u32, usize, usize)> = None; // (t, prim, index, tri)
        for (i, &r) in refs.iter().enumerate() {
            let tri = &pe.tris[r as usize];
            let (rec, _) = twin::record(&s.frame, &tri.v, tri.prim);
            let Some(Test::Hit(t)) = setup.map(|st| twin::intersect(&st, &rec)) else { continue };
            let tf = f32::from_bits(t);
            if !(tf > 0.0 && tf < t_max && tf <= hi) {
                continue;
            }
            match kind {
                RayKind::Any => {
                    best = Some((t, tri.prim, i, r as usize));
                    break;
                }
                RayKind::Closest => {
                    if best.is_none_or(|(bt, bp, _, _)| t < bt || (t == bt && tri.prim < bp)) {
                        best = Some((t, tri.prim, i, r as usize));
                    }
                }
            }
        }
        if let Some((t, _, i, r)) = best {
            found = Some((k, t, i, r));
        }
    }
    // Timeline: every entry scheduled with all its tests; the winner is done when its
    // accepted test is known (Any) or after its last test (Closest).
    let mut clock = vec![0u64; s.pes.len()];
    let mut first_issue = vec![0u64; list.len()];
    let mut end = 0u64;
    let last = found.map_or(list.len(), |f| f.0 + 1);
    for (k, e) in list.iter().enumerate() {
        let c = &mut clock[e.pe as usize];
        first_issue[k] = *c + VOXEL_SETUP;
        let n = counts[k];
        *c = first_issue[k] + n;
        let done = match found {
            Some((w, _, i, _)) if w == k && kind == RayKind::Any => first_issue[k] + i as u64 + 1 + TEST_LATENCY,
            _ if n > 0 => *c + TEST_LATENCY,
            _ => *c,
        };
        if k < last {
            end = end.max(done);
        }
    }
    let tests: u64 = (0..list.len()).map(|k| end.saturating_sub(first_issue[k]).min(counts[k])).sum();
    let cycles = 16 + 2 * list.len() as u64 + RAY_SETUP_CYCLES + ARBITRATION_CYCLES + end;
    let mut r = RayResult::MISS;
    if let Some((k, t, _, tri)) = found {
        let e = &list[k];
        let tr = &s.pes[e.pe as usize].tris[tri];
        let n = geometric_normal(&tr.v);
        r = RayResult {
            hit: true,
            pe: e.pe,
            list_pos: k as u16,
            t: f32::from_bits(t),
            prim: tr.prim,
            material: tr.material as u16,
            tests: 0,
            normal: [canonical(n.x), canonical(n.y), canonical(n.z)],
            cycles: 0,
        };
    }
    r.tests = tests.min(u16::MAX as u64) as u16;
    r.cycles = cycles.min(u32::MAX as u64) as u32;
    r
}

/// A random scene: `pes` PEs, each with a few voxels of random triangles inside `[-ext, ext]³`
/// (some shared between voxels, a few degenerate), and the voxel ids of each PE.
pub fn random_scene(rng: &mut ChaCha8Rng, pes: usize, ext: f32) -> Vec<PeScene> {
    let mut out = Vec::new();
    let mut prim = 0u32;
    for _ in 0..pes {
        let mut pe = PeScene::default();
        let ntri = rng.gen_range(1..40);
        for _ in 0..ntri {
            let c = Vec3::new(rng.gen_range(-ext..ext), rng.gen_range(-ext..ext), rng.gen_range(-ext..ext));
            let size = ext * rng.gen_range(0.02f32..0.8);
            let mut p =
                || c + Vec3::new(rng.gen_range(-size..size), rng.gen_range(-size..size), rng.gen_range(-size..size));
            let mut v = [p(), p(), p()];
            if rng.gen_bool(0.05) {
                v[2] = v[0] + (v[1] - v[0]) * 0.25;
            }
            pe.tris.push(Tri { v, prim: prim + rng.gen_range(0..3), material: rng.gen_range(0..70_000u32).min(65535) });
            prim += 3;
            // Ties: the same triangle again under another prim id (lower or higher), and a
            // neighbour sharing an edge (rays at the edge hit both at about the same t).
            if rng.gen_bool(0.2) {
                let twin = Tri { v, prim: rng.gen_range(0..prim + 3), material: rng.gen_range(0..65536) };
                pe.tris.push(twin);
            }
            if rng.gen_bool(0.2) {
                let apex =
                    c + Vec3::new(rng.gen_range(-size..size), rng.gen_range(-size..size), rng.gen_range(-size..size));
                pe.tris.push(Tri { v: [v[1], v[0], apex], prim: rng.gen_range(0..prim + 3), material: 1 });
            }
        }
        let ntri = pe.tris.len();
        let nvox = rng.gen_range(1..8);
        let mut id = rng.gen_range(0..5u32);
        for _ in 0..nvox {
            let nref = rng.gen_range(1..16.min(ntri + 1));
            // Mostly runs of neighbouring triangles, so duplicates and neighbours meet.
            let start = rng.gen_range(0..ntri);
            let refs = (0..nref)
                .map(|j| if rng.gen_bool(0.7) { ((start + j) % ntri) as u32 } else { rng.gen_range(0..ntri as u32) })
                .collect();
            pe.voxels.push((id, refs));
            id += rng.gen_range(1..50);
        }
        out.push(pe);
    }
    out
}

/// A random valid list over the loaded voxels of `scene` (up to `max` entries).
pub fn random_list(rng: &mut ChaCha8Rng, scene: &[PeScene], max: usize) -> Vec<ListEntry> {
    let n = rng.gen_range(0..=max);
    (0..n)
        .map(|_| {
            let pe = rng.gen_range(0..scene.len());
            let (voxel, _) = scene[pe].voxels[rng.gen_range(0..scene[pe].voxels.len())];
            let t_exit = match rng.gen_range(0..10) {
                0 => f32::INFINITY,
                1 => -rng.gen_range(0.0f32..5.0),
                2 => 0.0,
                _ => rng.gen_range(0.0f32..20.0),
            };
            ListEntry { voxel, pe: pe as u8, t_exit }
        })
        .collect()
}

/// A seeded generator.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

/// Checks that `image` parses (the generators must make valid images).
pub fn assert_valid(image: &[u32]) {
    PeImage::parse(image).expect("generated PE image is valid");
}
