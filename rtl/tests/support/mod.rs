//! Test support for the co-simulation: random scenes as PE images, packets, and the model
//! configured as the RTL.

#![allow(dead_code)]

use gridrt_coproc::{
    CoprocConfig, Coprocessor, FixedFrame, FslWord, KernelKind, ListEntry, NumberFormat, RayKind, TimingProfile,
};
use gridrt_rtl::sim::{CoprocSim, RtlParams};
use gridrt_shared::fsl;
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::PeImage;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

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

/// A FRAME packet (SPEC §4.6).
pub fn frame_packet(min: [f32; 3], max: [f32; 3]) -> Vec<FslWord> {
    framed(&fsl::frame_packet(min, max))
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

/// The model configured as the RTL build `params` is: watertight fixed64-q23, the `rtl`
/// timing profile of its pipeline sharing, the reset frame (identity).
pub fn model(params: RtlParams) -> Coprocessor<'static> {
    let cfg = model_config(params);
    let backing: &'static mut [u32] = vec![0u32; cfg.required_backing_words()].leak();
    let mut m = Coprocessor::new(cfg, backing).expect("valid configuration");
    m.set_number_format(NumberFormat::Fixed64Q23, FixedFrame::IDENTITY);
    m
}

/// The model's configuration for the RTL build `params`: its PEs and memories, the `rtl`
/// timing profile of its pipeline sharing, the watertight kernel.
pub fn model_config(params: RtlParams) -> CoprocConfig {
    CoprocConfig {
        pe_count: params.pes,
        pe_mem_words: params.pe_mem_words,
        max_list: params.max_list,
        timing: TimingProfile::rtl(params.pes_per_pipeline.into()),
        kernel: KernelKind::Watertight,
    }
}

/// Every reply word of the model to `words`.
pub fn run_model(m: &mut Coprocessor, words: &[FslWord]) -> Vec<FslWord> {
    let mut out = Vec::new();
    for &w in words {
        m.push(w);
        while let Some(o) = m.pop() {
            out.push(o);
        }
    }
    out
}

/// Every reply word of the RTL to `words`.
pub fn run_rtl(s: &mut CoprocSim, words: &[FslWord]) -> Vec<FslWord> {
    for &w in words {
        s.push(w).expect("RTL simulation alive");
    }
    let mut out = Vec::new();
    while let Some(w) = s.pop().expect("RTL simulation alive") {
        out.push(w);
    }
    out
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
