//! The PE-memory read observer: it changes no answer or counter, and it reports the reads
//! the RTL makes, in its order.

use super::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Every read, and the answers it was told of.
#[derive(Default)]
struct Log {
    reads: Vec<PeRead>,
    results: Vec<RayResult>,
}

impl PeReadObserver for Log {
    fn read(&mut self, read: PeRead) {
        self.reads.push(read);
    }
    fn ray_end(&mut self, result: &RayResult) {
        self.results.push(*result);
    }
}

/// Two co-processors loaded alike: `trace` on one, `trace_observed` on the other, and the
/// same packets through `push` and `push_observed`: the same result words (cycles and tests
/// included), the same reply words and the same counters, for every kernel, in f32 and in
/// the RTL's fixed64-q23 with its timing. Each ray's observed ref reads are its tests.
#[test]
fn an_observer_changes_no_result_word_or_counter() {
    let scene = GridScene::random(0x0B5E, 40);
    let map = |id: u32| (id % 4) as u8;
    let images = scene.images(4, map);
    let setups = KernelKind::ALL.iter().map(|&k| (k, NumberFormat::F32, TimingProfile::GRIDRT)).chain([(
        KernelKind::Watertight,
        NumberFormat::Fixed64Q23,
        TimingProfile::RTL,
    )]);
    for (kernel, format, timing) in setups {
        let cfg = CoprocConfig { kernel, timing, ..config(4, 4096) };
        let (mut b1, mut b2) = (Vec::new(), Vec::new());
        let mut plain = loaded_in(cfg, &mut b1, &images, format);
        let mut watched = loaded_in(cfg, &mut b2, &images, format);
        let mut rng = ChaCha8Rng::seed_from_u64(0x5EE + kernel as u64);
        let mut log = Log::default();
        for i in 0..2000 {
            let (ray, t_max) = random_ray(&mut rng);
            let list = scene.list(&ray, map);
            let kind = if i % 3 == 0 { RayKind::Any } else { RayKind::Closest };
            let a = plain.trace(kind, &ray, t_max, &list).unwrap();
            let before = log.reads.len();
            let b = watched.trace_observed(kind, &ray, t_max, &list, &mut log).unwrap();
            assert_eq!(a.to_words(), b.to_words(), "{kernel:?} {format:?} ray {i}");
            assert_eq!(log.results.last(), Some(&b));
            let refs = log.reads[before..].iter().filter(|r| r.kind == PeReadKind::Ref).count();
            assert_eq!(refs, b.tests as usize, "{kernel:?} ray {i}");
            // The word interface.
            let packet = ray_packet(kind, &ray, t_max, &list);
            push_all(&mut plain, &packet);
            for &w in &packet {
                watched.push_observed(w, &mut log);
            }
            assert_eq!(drain(&mut plain), drain(&mut watched), "{kernel:?} ray {i} (words)");
        }
        assert_eq!(plain.stats(), watched.stats(), "{kernel:?} {format:?}");
        assert!(log.reads.len() > 4000, "{kernel:?}: {} reads", log.reads.len());
    }
}

/// One ray on a two-PE scene, every read worked out by hand (RTL kernel, format and timing:
/// 10-word records after the image).
///
/// PE 0: voxels 1 (refs 0, 1) and 3 (ref 2); triangles 0 and 2 miss, 1 is hit at t = 3.
/// Layout: voxel table at 5 (voxel 1) and 8 (voxel 3), refs at 11..14, triangles (11 words)
/// at 14, 25, 36, image length 47, records (10 words) at 47, 57, 67.
/// PE 1: voxel 2 (ref 0), one triangle that misses: table at 5, ref at 8, triangle at 9,
/// length 20, record at 20.
/// The list is (voxel 1, PE 0), (voxel 2, PE 1).
#[test]
fn the_reads_of_one_ray_are_those_worked_out_by_hand() {
    let pe0 = image(&[(1, vec![0, 1]), (3, vec![2])], &[miss_tri(0.0, 0), hit_tri(2.0, 1), miss_tri(0.5, 2)]);
    let pe1 = image(&[(2, vec![0])], &[miss_tri(1.0, 3)]);
    assert_eq!((pe0.len(), pe1.len()), (47, 20));
    let cfg = CoprocConfig { kernel: KernelKind::Watertight, timing: TimingProfile::RTL, ..config(2, 256) };
    let mut backing = Vec::new();
    let mut cp = loaded_in(cfg, &mut backing, &[pe0, pe1], NumberFormat::Fixed64Q23);
    let list = [entry(1, 0, 10.0), entry(2, 1, 10.0)];
    let mut log = Log::default();
    let r = cp.trace_observed(RayKind::Closest, &probe_ray(), f32::INFINITY, &list, &mut log).unwrap();
    assert!(r.hit && r.t == 3.0 && r.prim == 1 && r.list_pos == 0, "{r:?}");
    use PeReadKind::*;
    let read = |pe, addr, words, kind| PeRead { pe, addr, words, kind };
    let want = vec![
        // PE 0 looks up voxel 1: probe entry 1 (voxel 3, too high), then entry 0 (a match).
        read(0, 8, 1, VoxelTable),
        read(0, 5, 1, VoxelTable),
        read(0, 6, 2, VoxelTable),
        // PE 1 looks up voxel 2: entry 0 matches.
        read(1, 5, 1, VoxelTable),
        read(1, 6, 2, VoxelTable),
        // PE 0's entry: both tests (ref word, record).
        read(0, 11, 1, Ref),
        read(0, 47, 10, Record),
        read(0, 12, 1, Ref),
        read(0, 57, 10, Record),
        // PE 1 issued its test before the winner was known (RTL timeline): charged and read.
        read(1, 8, 1, Ref),
        read(1, 20, 10, Record),
        // The winner, triangle 1 of PE 0 at 25: prim and material, then the normal.
        read(0, 34, 2, Result),
        read(0, 25, 3, Result),
    ];
    assert_eq!(log.reads, want);
    assert_eq!(r.tests, 3);
}

/// A co-processor in `format` (the frame of the 2×2×2 scene's box, padded) with `images`.
fn loaded_in<'m>(
    cfg: CoprocConfig,
    backing: &'m mut Vec<u32>,
    images: &[Vec<u32>],
    format: NumberFormat,
) -> Coprocessor<'m> {
    backing.clear();
    backing.resize(cfg.required_backing_words(), 0);
    let mut cp = Coprocessor::new(cfg, backing).unwrap();
    cp.set_number_format(format, FixedFrame::IDENTITY);
    cp.set_frame_box([-1.0; 3], [7.0; 3]).unwrap();
    for (pe, img) in images.iter().enumerate() {
        cp.load_pe(pe as u8, img).unwrap();
    }
    cp
}
