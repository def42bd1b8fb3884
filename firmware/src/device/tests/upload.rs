//! Scene upload (SPEC.md §3.5, §5): CLEAR then one LOAD_PE per PE block, an ACK per chunk,
//! and every way an upload is refused (CRC, order, size, co-processor errors).

use super::*;

#[test]
fn scene_upload_clears_then_loads_every_pe_block_and_acks_every_chunk() {
    let img = scene_image([2, 2, 1], &materials());
    let mut dev = device();
    let r = upload(&mut dev, &img, 37);
    let chunks = img.len().div_ceil(37);
    assert_eq!(r.len(), chunks, "one ack per chunk, none for SceneBegin");
    for (i, a) in r.iter().enumerate() {
        let Msg::SceneAck { next_offset, status } = a.msg() else { panic!("{a:?}") };
        assert_eq!(next_offset as usize, ((i + 1) * 37).min(img.len()));
        let want = if i + 1 == chunks { SceneStatus::Loaded } else { SceneStatus::Receiving };
        assert_eq!(status, want);
    }
    assert!(dev.scene_loaded());
    let fake = dev.link();
    assert_eq!(fake.clears, 1);
    assert!(fake.violations.is_empty(), "{:?}", fake.violations);
    let h = SceneHeader::parse(&img).unwrap();
    let b = (h.bounds_min, h.bounds_max);
    assert_eq!(fake.frames, vec![[b.0[0], b.0[1], b.0[2], b.1[0], b.1[1], b.1[2]]], "FRAME: the header's grid box");
    assert_eq!(fake.loads.len(), 2);
    for (pe, (hdr, words)) in fake.loads.iter().enumerate() {
        assert_eq!(*hdr, wire::load_header(pe as u8) as u8);
        assert_eq!(words.len(), 9 + 11);
        assert_eq!(words[5], pe as u32, "voxel id of the PE's one table entry");
    }
}

#[test]
fn any_chunking_of_the_image_loads_the_same_scene() {
    let img = scene_image([2, 2, 1], &materials());
    let mut rng = ChaCha8Rng::seed_from_u64(0xC4_0001);
    for _ in 0..50 {
        let mut dev = device();
        let mut all = send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(&img) });
        let mut off = 0;
        while off < img.len() {
            let n = rng.gen_range(0..=64).min(img.len() - off);
            all.extend(send(&mut dev, &Msg::SceneChunk { offset: off as u32, data: &img[off..off + n] }));
            off += n;
        }
        assert!(matches!(all.last().unwrap().msg(), Msg::SceneAck { status: SceneStatus::Loaded, .. }));
        assert_eq!(dev.link().loads.len(), 2);
    }
}

#[test]
fn corrupted_image_is_rejected_with_bad_crc_and_renders_get_no_scene() {
    let mut img = scene_image([2, 2, 1], &materials());
    let last = img.len() - 1;
    img[last] ^= 0x01; // inside the last PE word: the body CRC no longer matches
    let mut dev = device();
    let r = upload(&mut dev, &img, 1000);
    assert_eq!(error_of(r.last().unwrap()), (ErrorCode::SceneRejected, SceneError::BadCrc.code()));
    assert!(!dev.scene_loaded());
    let r = send(&mut dev, &Msg::RenderRequest(request(4, 3, 0)));
    assert_eq!(error_of(&r[0]).0, ErrorCode::NoScene);
    assert_eq!(r.len(), 1);
}

#[test]
fn scene_begin_crc_mismatch_is_rejected() {
    let img = scene_image([2, 2, 1], &materials());
    let mut dev = device();
    send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(&img) ^ 1 });
    let r = send(&mut dev, &Msg::SceneChunk { offset: 0, data: &img });
    assert_eq!(error_of(&r[0]), (ErrorCode::SceneRejected, SceneError::BadCrc.code()));
    assert!(!dev.scene_loaded());
}

#[test]
fn out_of_order_chunk_gets_bad_offset_and_upload_can_continue() {
    let img = scene_image([2, 2, 1], &materials());
    let mut dev = device();
    send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(&img) });
    let r = send(&mut dev, &Msg::SceneChunk { offset: 0, data: &img[..50] });
    assert!(matches!(r[0].msg(), Msg::SceneAck { next_offset: 50, status: SceneStatus::Receiving }));
    // Skips ahead, then repeats: both refused with the expected offset.
    let r = send(&mut dev, &Msg::SceneChunk { offset: 60, data: &img[60..80] });
    assert_eq!(error_of(&r[0]), (ErrorCode::BadOffset, 50));
    let r = send(&mut dev, &Msg::SceneChunk { offset: 0, data: &img[..50] });
    assert_eq!(error_of(&r[0]), (ErrorCode::BadOffset, 50));
    let r = send(&mut dev, &Msg::SceneChunk { offset: 50, data: &img[50..] });
    assert!(matches!(r[0].msg(), Msg::SceneAck { status: SceneStatus::Loaded, .. }));
    assert!(dev.scene_loaded());
}

#[test]
fn chunk_without_scene_begin_is_unexpected() {
    let mut dev = device();
    let r = send(&mut dev, &Msg::SceneChunk { offset: 0, data: &[1, 2, 3] });
    assert_eq!(error_of(&r[0]), (ErrorCode::UnexpectedMessage, MsgType::SceneChunk as u32));
}

#[test]
fn grid_larger_than_voxel_capacity_is_rejected_before_touching_the_coproc() {
    let img = scene_image([9, 9, 1], &materials()); // 81 > 64 voxels
    let mut dev = device();
    let r = upload(&mut dev, &img, 2000);
    assert_eq!(error_of(&r[0]), (ErrorCode::SceneRejected, SceneError::GridTooLarge.code()));
    assert_eq!(dev.link().clears, 0);
    assert_eq!(dev.link().words_in, 0);
}

#[test]
fn coproc_error_on_load_rejects_the_scene() {
    let img = scene_image([2, 2, 1], &materials());
    let mut dev = device();
    dev.link_mut().mode = Mode::ErrorOnLoad(FslError::PeMemoryOverflow.to_word(1));
    let r = upload(&mut dev, &img, 2000);
    assert_eq!(r.len(), 1);
    assert_eq!(error_of(&r[0]), (ErrorCode::SceneRejected, SceneError::Rejected.code()));
    let Msg::Error { text, .. } = r[0].msg() else { panic!() };
    assert!(text.contains("PE memory"), "{text}");
    assert!(!dev.scene_loaded());
}

// ---------------------------------------------------------------- windowed upload (§3.14)

fn sack_of(r: &Reply) -> (SceneStatus, gridrt_shared::msg::Sack) {
    match r.msg() {
        Msg::SceneSack { status, sack } => (status, sack),
        other => panic!("expected a SceneSack, got {other:?}"),
    }
}

/// Sends `msg` as a frame with sequence number `seq`.
fn send_seq(dev: &mut Dev, msg: &Msg<'_>, seq: u16) -> Vec<Reply> {
    exchange(dev, &frame(msg, seq))
}

#[test]
fn scene_data_in_any_order_loads_the_scene_and_every_frame_gets_a_sack() {
    let img = scene_image([2, 2, 1], &materials());
    let crc = crc32(&img);
    let mut rng = ChaCha8Rng::seed_from_u64(0x5AC_0001);
    for _ in 0..50 {
        let mut dev = device();
        send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc });
        let mut pieces: Vec<(usize, usize)> = Vec::new();
        let mut off = 0;
        while off < img.len() {
            let n = rng.gen_range(1..=40).min(img.len() - off);
            pieces.push((off, n));
            off += n;
        }
        // Shuffle within a few places, and send some twice: a lossy line's retransmissions.
        for i in 0..pieces.len() {
            let j = (i + rng.gen_range(0..4)).min(pieces.len() - 1);
            pieces.swap(i, j);
        }
        let mut seq = 100u16;
        let mut last = None;
        let mut queue = pieces.clone();
        while let Some((o, n)) = queue.first().copied() {
            queue.remove(0);
            seq += 1;
            let r = send_seq(&mut dev, &Msg::SceneData { offset: o as u32, data: &img[o..o + n] }, seq);
            assert_eq!(r.len(), 1, "{r:?}");
            let (status, sack) = sack_of(&r[0]);
            assert_eq!((sack.heard, sack.crc, sack.window as usize), (seq, crc, super::super::scene::UPLOAD_WINDOW));
            // Anything the device did not take (table full) is sent again later.
            let held = |p: usize| {
                p < sack.next_offset as usize
                    || sack.ranges.as_slice().iter().any(|&(a, b)| {
                        (sack.next_offset as usize + a as usize..sack.next_offset as usize + b as usize).contains(&p)
                    })
            };
            if !(o..o + n).all(held) {
                queue.push((o, n));
            }
            last = Some(status);
            if status == SceneStatus::Loaded {
                break;
            }
        }
        assert_eq!(last, Some(SceneStatus::Loaded));
        assert!(dev.scene_loaded());
        assert_eq!(dev.link().loads.len(), 2, "each PE block loaded once");
        // The last Sack again for a late duplicate or a probe.
        let r = send_seq(&mut dev, &Msg::SceneData { offset: 0, data: &[] }, 7);
        let (status, sack) = sack_of(&r[0]);
        assert_eq!((status, sack.next_offset, sack.heard, sack.crc), (SceneStatus::Loaded, img.len() as u32, 7, crc));
    }
}

#[test]
fn scene_sack_lists_the_ranges_held_above_a_gap() {
    let img = scene_image([2, 2, 1], &materials());
    let crc = crc32(&img);
    let mut dev = device();
    send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc });
    let r = send_seq(&mut dev, &Msg::SceneData { offset: 0, data: &img[..20] }, 1);
    assert_eq!(sack_of(&r[0]).1.next_offset, 20);
    let r = send_seq(&mut dev, &Msg::SceneData { offset: 40, data: &img[40..60] }, 3);
    let (status, s) = sack_of(&r[0]);
    assert_eq!((status, s.next_offset, s.heard, s.ranges.as_slice()), (SceneStatus::Receiving, 20, 3, &[(20, 40)][..]));
    // A duplicate changes nothing but `heard`.
    let r = send_seq(&mut dev, &Msg::SceneData { offset: 45, data: &img[45..50] }, 4);
    let (_, s) = sack_of(&r[0]);
    assert_eq!((s.next_offset, s.heard, s.ranges.as_slice()), (20, 4, &[(20, 40)][..]));
    // The gap filled: contiguous up to 60.
    let r = send_seq(&mut dev, &Msg::SceneData { offset: 20, data: &img[20..40] }, 5);
    let (_, s) = sack_of(&r[0]);
    assert_eq!((s.next_offset, s.ranges.len()), (60, 0));
}

#[test]
fn scene_data_past_the_end_rejects_the_upload_and_without_begin_is_unexpected() {
    let mut dev = device();
    let r = send(&mut dev, &Msg::SceneData { offset: 0, data: &[1, 2, 3] });
    assert_eq!(error_of(&r[0]), (ErrorCode::UnexpectedMessage, MsgType::SceneData as u32));
    let img = scene_image([2, 2, 1], &materials());
    send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(&img) });
    let r = send(&mut dev, &Msg::SceneData { offset: img.len() as u32 - 2, data: &[0; 4] });
    assert_eq!(error_of(&r[0]), (ErrorCode::SceneRejected, SceneError::TrailingBytes.code()));
    let r = send(&mut dev, &Msg::SceneData { offset: 0, data: &img });
    assert_eq!(error_of(&r[0]), (ErrorCode::UnexpectedMessage, MsgType::SceneData as u32));
}

#[test]
fn a_new_scene_begin_forgets_the_loaded_upload() {
    let img = scene_image([2, 2, 1], &materials());
    let mut dev = loaded_device();
    send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(&img) });
    let r = send(&mut dev, &Msg::SceneData { offset: 0, data: &[] });
    let (status, s) = sack_of(&r[0]);
    assert_eq!((status, s.next_offset), (SceneStatus::Receiving, 0));
    assert!(!dev.scene_loaded());
}

#[test]
fn data_frames_read_together_share_one_sack_and_a_later_corrupt_frame_is_reported_after_it() {
    let img = scene_image([2, 2, 1], &materials());
    let mut dev = device();
    send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(&img) });
    let noise = [0x13u8, 0x37, 0x00]; // a corrupt frame
    let d = |o: usize, n: usize, seq| frame(&Msg::SceneData { offset: o as u32, data: &img[o..o + n] }, seq);
    // Corrupt, data, data: one Sack for frame 2 (the corrupt frame came before it: the Sack
    // itself shows what is missing).
    let batch = [noise.to_vec(), d(0, 10, 1), d(10, 10, 2)].concat();
    let r = exchange(&mut dev, &batch);
    assert_eq!(r.len(), 1, "{r:?}");
    let (_, s) = sack_of(&r[0]);
    assert_eq!((s.heard, s.next_offset), (2, 20));
    // Data, corrupt: the Sack, then the report of the corrupt frame after it.
    let batch = [d(20, 10, 3), noise.to_vec()].concat();
    let r = exchange(&mut dev, &batch);
    assert_eq!(r.len(), 2, "{r:?}");
    assert_eq!(sack_of(&r[0]).1.heard, 3);
    assert_eq!(error_of(&r[1]).0, ErrorCode::BadFrame);
    // Data, then Hello: answered in order.
    let batch = [d(30, 10, 4), frame(&Msg::Hello { protocol: 1 }, 5)].concat();
    let r = exchange(&mut dev, &batch);
    assert_eq!(r.iter().map(|x| x.1).collect::<Vec<_>>(), [MsgType::SceneSack as u8, MsgType::Version as u8]);
}

/// FRAME after CLEAR: a co-processor without a fixed-point frame answers `UnknownOpcode` and
/// the scene still loads (SPEC §4.6); any other answer rejects the scene.
#[test]
fn frame_refused_as_unknown_still_loads_other_errors_reject_the_scene() {
    let img = scene_image([2, 2, 1], &materials());
    for (word, loads) in [(FslError::UnknownOpcode.to_word(5), true), (FslError::BadFrame.to_word(4), false)] {
        let mut dev = device();
        dev.link_mut().mode = Mode::ErrorOnFrame(word);
        let r = upload(&mut dev, &img, 64);
        assert_eq!(dev.scene_loaded(), loads, "{word:08x}: {r:?}");
        assert_eq!(dev.link().frames.len(), 1);
        assert_eq!(dev.link().loads.len(), if loads { 2 } else { 0 }, "{word:08x}");
    }
}

/// A host that resends from inside a frame the device already holds (a smaller chunk after a
/// loss) overlaps bytes that arrived: only the new bytes are parsed, each once and in order,
/// so the co-processor gets the same PE blocks as from one piece.
#[test]
fn scene_data_overlapping_what_arrived_loads_each_byte_once() {
    let img = scene_image([2, 2, 1], &materials());
    let crc = crc32(&img);
    let mut whole = device();
    send(&mut whole, &Msg::SceneBegin { total_len: img.len() as u32, crc });
    send_seq(&mut whole, &Msg::SceneData { offset: 0, data: &img }, 1);
    assert!(whole.scene_loaded());
    let mut rng = ChaCha8Rng::seed_from_u64(0x5AC_0002);
    for _ in 0..50 {
        let mut dev = device();
        send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc });
        let (mut next, mut seq) = (0usize, 1u16);
        while next < img.len() {
            let o = next - rng.gen_range(0..=next.min(30));
            let n = rng.gen_range(1..=40).min(img.len() - o);
            seq += 1;
            send_seq(&mut dev, &Msg::SceneData { offset: o as u32, data: &img[o..o + n] }, seq);
            next = next.max(o + n);
        }
        assert!(dev.scene_loaded());
        assert_eq!(dev.link().loads, whole.link().loads, "the same PE blocks, each once");
    }
}

/// A device that takes one frame at a time offers that window in every `SceneSack`, and
/// holds nothing beyond it; the window is clamped to 1..=`UPLOAD_WINDOW`.
#[test]
fn the_upload_window_set_is_offered_and_bounds_what_is_held() {
    let img = scene_image([2, 2, 1], &materials());
    let crc = crc32(&img);
    let mut dev = device();
    dev.set_upload_window(100);
    send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc });
    let r = send_seq(&mut dev, &Msg::SceneData { offset: 0, data: &img[..60] }, 1);
    let (_, sack) = sack_of(&r[0]);
    assert_eq!((sack.window, sack.next_offset), (100, 60));
    // Past next_offset + window: dropped, not held.
    let r = send_seq(&mut dev, &Msg::SceneData { offset: 170, data: &img[170..180] }, 2);
    let (_, sack) = sack_of(&r[0]);
    assert!(sack.ranges.as_slice().is_empty(), "{sack:?}");
    // Inside it: held above the gap.
    let r = send_seq(&mut dev, &Msg::SceneData { offset: 150, data: &img[150..160] }, 3);
    let (_, sack) = sack_of(&r[0]);
    assert_eq!(sack.ranges.as_slice(), &[(90, 100)]);
    for (set, offered) in [(0u16, 1u16), (u16::MAX, super::super::scene::UPLOAD_WINDOW as u16)] {
        let mut dev = device();
        dev.set_upload_window(set);
        send(&mut dev, &Msg::SceneBegin { total_len: img.len() as u32, crc });
        let r = send_seq(&mut dev, &Msg::SceneData { offset: 0, data: &img[..1] }, 1);
        assert_eq!(sack_of(&r[0]).1.window, offered);
    }
}
