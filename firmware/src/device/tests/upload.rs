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
