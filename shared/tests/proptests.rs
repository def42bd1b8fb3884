//! Property tests: every message survives encode → frame → noisy, arbitrarily split byte
//! stream → accumulator → decode; the scene stream is independent of chunking; and random
//! byte soup never panics any decoder.

mod common;

use common::*;
use gridrt_shared::frame::{self, FrameAccumulator};
use gridrt_shared::fsl::{self, FslError, ListEntry, RayKind, RayResult};
use gridrt_shared::msg::{self, DeviceInfo, ErrorCode, Msg, PixelEncoding, RenderRequest, SceneStatus};
use gridrt_shared::scene::{
    LightingRecord, Material, MaterialModel, ObjectRecord, PeImage, PrimRecord, SceneError, SceneHeader, SceneStream,
    PE_IMAGE_TAG,
};
use proptest::collection::vec;
use proptest::prelude::*;

// ---------------------------------------------------------------- message round trips

/// Frames `m`, surrounds it with noise, feeds it in `chunk`-byte pieces and returns what the
/// receiver decodes (payload bytes), checking kind and seq on the way.
fn transmit(m: &Msg<'_>, seq: u16, noise: &[u8], chunk: usize) -> Vec<u8> {
    let payload = encode_payload(m);
    let mut stream = noise.to_vec();
    stream.push(0);
    stream.extend_from_slice(&wire(m.kind() as u8, seq, &payload));
    stream.extend_from_slice(noise);
    let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
    let frames: Vec<_> = feed_all(&mut acc, &stream, chunk)
        .into_iter()
        .filter_map(|o| match o {
            Outcome::Frame { kind, seq, payload } => Some((kind, seq, payload)),
            _ => None,
        })
        .collect();
    // Noise is short and cannot carry a valid CRC-checked frame of this size by accident.
    assert_eq!(frames.len(), 1, "exactly one frame");
    let (kind, s, p) = frames.into_iter().next().unwrap();
    assert_eq!((kind, s), (m.kind() as u8, seq));
    assert_eq!(p, payload);
    p
}

/// Full round trip; compares messages directly, or re-encoded bytes when floats are NaN.
fn round_trip(m: Msg<'_>, seq: u16, noise: &[u8], chunk: usize) -> Result<(), TestCaseError> {
    let p = transmit(&m, seq, noise, chunk);
    let d = Msg::decode(m.kind() as u8, &p).map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
    if nan_free(&m) {
        prop_assert_eq!(d, m);
    } else {
        prop_assert_eq!(encode_payload(&d), p);
    }
    Ok(())
}

/// False when the message holds a NaN (then `m != m`).
#[allow(clippy::eq_op)]
fn nan_free(m: &Msg<'_>) -> bool {
    m == m
}

fn f32_any() -> impl Strategy<Value = f32> {
    prop_oneof![any::<f32>(), any::<u32>().prop_map(f32::from_bits)]
}

fn vec3() -> impl Strategy<Value = [f32; 3]> {
    [f32_any(), f32_any(), f32_any()]
}

fn noise() -> impl Strategy<Value = Vec<u8>> {
    vec(1u8..=255, 0..24)
}

fn encoding() -> impl Strategy<Value = PixelEncoding> {
    prop_oneof![Just(PixelEncoding::Rgb888), Just(PixelEncoding::PrimId32)]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn rt_hello(protocol: u16, seq: u16, n in noise(), chunk in 1usize..40) {
        round_trip(Msg::Hello { protocol }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_version(protocol: u16, firmware: [u8; 3], board: u8, max_payload: u16, pe_count: u16,
                  voxel_capacity: u32, pe_mem_words: u32, features: u32, seq: u16, n in noise(), chunk in 1usize..40) {
        let d = DeviceInfo { protocol, firmware, board, max_payload, pe_count, voxel_capacity, pe_mem_words, features };
        round_trip(Msg::Version(d), seq, &n, chunk)?;
    }

    #[test]
    fn rt_scene_begin(total_len: u32, crc: u32, seq: u16, n in noise(), chunk in 1usize..40) {
        round_trip(Msg::SceneBegin { total_len, crc }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_scene_chunk(offset: u32, data in vec(any::<u8>(), 0..=2044), seq: u16, n in noise(), chunk in 1usize..600) {
        round_trip(Msg::SceneChunk { offset, data: &data }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_scene_ack(next_offset: u32, loaded: bool, seq: u16, n in noise(), chunk in 1usize..40) {
        let status = if loaded { SceneStatus::Loaded } else { SceneStatus::Receiving };
        round_trip(Msg::SceneAck { next_offset, status }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_render_request(ints in any::<(u16, u16, u16, u16)>(), cam in (vec3(), vec3(), vec3(), f32_any()),
                         light in (vec3(), f32_any(), f32_any()), enc in encoding(),
                         seq: u16, n in noise(), chunk in 1usize..100) {
        let (frame, width, height, flags) = ints;
        let (eye, target, up, fov_y_deg) = cam;
        let (light_pos, light_intensity, ambient) = light;
        let r = RenderRequest { frame, width, height, flags, eye, target, up, fov_y_deg, light_pos,
                                light_intensity, ambient, encoding: enc };
        round_trip(Msg::RenderRequest(r), seq, &n, chunk)?;
    }

    #[test]
    fn rt_pixel_span(frame: u16, y: u16, x0: u16, enc in encoding(), count_seed: u16,
                     bytes in vec(any::<u8>(), 2038), seq: u16, n in noise(), chunk in 1usize..600) {
        let max = (frame::MAX_PAYLOAD - 10) / enc.bytes_per_pixel();
        let count = (count_seed as usize % (max + 1)) as u16;
        let data = &bytes[..count as usize * enc.bytes_per_pixel()];
        round_trip(Msg::PixelSpan { frame, y, x0, count, encoding: enc, data }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_frame_end(frame: u16, spans: u32, image_crc: u32, seq: u16, n in noise(), chunk in 1usize..40) {
        round_trip(Msg::FrameEnd { frame, spans, image_crc }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_stats(frame: u16, entries in vec((any::<u8>(), any::<u64>()), 0..=227), seq: u16, n in noise(), chunk in 1usize..600) {
        let raw: Vec<u8> = entries.iter().flat_map(|(k, v)| std::iter::once(*k).chain(v.to_le_bytes())).collect();
        round_trip(Msg::Stats { frame, entries: &raw }, seq, &n, chunk)?;
        prop_assert_eq!(msg::stat_entries(&raw).collect::<Vec<_>>(), entries);
    }

    #[test]
    fn rt_error(code: u16, detail: u32, text in "[a-zA-Z0-9 é中🦀]{0,32}", seq: u16, n in noise(), chunk in 1usize..60) {
        prop_assume!(text.len() <= msg::MAX_ERROR_TEXT);
        // Codes as the decoder produces them (Unknown(1..=7) is not canonical).
        round_trip(Msg::Error { code: ErrorCode::from_code(code), detail, text: &text }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_raw_frames_any_kind(kind: u8, seq: u16, payload in vec(any::<u8>(), 0..=frame::MAX_PAYLOAD), chunk in 1usize..3000) {
        let w = wire(kind, seq, &payload);
        let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
        prop_assert_eq!(feed_all(&mut acc, &w, chunk), vec![Outcome::Frame { kind, seq, payload }]);
    }
}

// ---------------------------------------------------------------- FSL round trips

proptest! {
    #[test]
    fn rt_fsl_entry(voxel in 0u32..(1 << 24), pe: u8, t_bits: u32) {
        let e = ListEntry { voxel, pe, t_exit: f32::from_bits(t_bits) };
        let [w0, w1] = fsl::entry_words(e);
        prop_assert_eq!((w0 & fsl::VOXEL_MASK, w0 >> 24, w1), (voxel, pe as u32, t_bits));
        let d = fsl::entry_from_words(w0, w1);
        prop_assert_eq!((d.voxel, d.pe, d.t_exit.to_bits()), (voxel, pe, t_bits));
    }

    #[test]
    fn rt_fsl_request_head(any_hit: bool, o in vec3(), d in vec3(), t_max in f32_any(), count: u16) {
        let kind = if any_hit { RayKind::Any } else { RayKind::Closest };
        let h = fsl::ray_request_head(kind, o, d, t_max, count);
        prop_assert_eq!(fsl::opcode(h[0]), kind.opcode());
        prop_assert_eq!(h[0] & 0x0FFF_0000, 0);
        prop_assert_eq!(h[0] & 0xFFFF, count as u32);
        let bits: Vec<u32> = o.iter().chain(d.iter()).chain(std::iter::once(&t_max)).map(|v| v.to_bits()).collect();
        prop_assert_eq!(&h[1..], &bits[..]);
    }

    #[test]
    fn rt_fsl_result(hit: bool, pe: u8, list_pos in 0u16..4096, t: u32, prim: u32, material: u16, tests: u16,
                     n0: u32, n1: u32, n2: u32, cycles: u32) {
        let r = RayResult { hit, pe, list_pos, t: f32::from_bits(t), prim, material, tests,
                            normal: [f32::from_bits(n0), f32::from_bits(n1), f32::from_bits(n2)], cycles };
        let w = r.to_words();
        let back = RayResult::from_words(&w).map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
        prop_assert_eq!(back.to_words(), w);
        prop_assert_eq!((back.hit, back.pe, back.list_pos, back.prim, back.material, back.tests, back.cycles),
                        (hit, pe, list_pos, prim, material, tests, cycles));
    }

    #[test]
    fn rt_fsl_error_word(code in 1u16..=11, detail: u16) {
        let e = FslError::from_code(code);
        prop_assert_eq!(FslError::from_word(e.to_word(detail)), (e, detail));
        prop_assert_eq!(fsl::opcode(e.to_word(detail)), fsl::op::ERROR);
    }

    #[test]
    fn fsl_decoders_never_panic(w: [u32; 8], x: u32) {
        let _ = RayResult::from_words(&w);
        let _ = FslError::from_word(x);
        let _ = fsl::entry_from_words(w[0], w[1]);
        let _ = fsl::opcode(x);
    }

    #[test]
    fn gridrt_list_packing(ids in vec(-1i8..=7, 0..=8)) {
        let w = fsl::pack_gridrt_list(&ids).unwrap();
        for k in 0..8 {
            let nib = ((w >> (4 * k)) & 0xF) as u8;
            let expected = ids.get(k).map_or(0xF, |&id| (id as u8) & 0xF);
            prop_assert_eq!(nib, expected);
        }
    }
}

// ---------------------------------------------------------------- scene stream

/// Streaming the image in every chunk size 1..=17 gives the same sink calls as one chunk.
#[test]
fn scene_stream_every_chunk_size_gives_same_calls() {
    for image in [TINY_IMAGE.to_vec(), ImageSpec::two_pe().build(), ImageSpec::sphere().build()] {
        let (r, whole, s) = stream_in_chunks(&image, image.len());
        assert_eq!(r, Ok(()));
        assert!(s.is_done());
        // Chunk sizes that split the voxel map split its sink calls; nothing else may differ.
        let expected = coalesce(&whole.events);
        for chunk in 1..=17 {
            let (r, sink, s) = stream_in_chunks(&image, chunk);
            assert_eq!(r, Ok(()), "chunk {chunk}");
            assert!(s.is_done(), "chunk {chunk}");
            assert_eq!(s.offset() as usize, image.len());
            assert_eq!(coalesce(&sink.events), expected, "chunk {chunk}");
        }
    }
}

/// nx·ny·nz of the dims at bytes 8..14 of `image` (missing bytes count as 1).
fn voxels_of(image: &[u8]) -> u64 {
    let d = |i: usize| image.get(i..i + 2).map_or(1, |b| u16::from_le_bytes([b[0], b[1]]) as u64);
    d(8) * d(10) * d(12)
}

/// One grid axis: small, near the 2^24-voxel limit (2^8, 2^12, 2^16 ± 1), or anything.
fn axis() -> impl Strategy<Value = u16> {
    prop_oneof![0u16..=300, prop::sample::select(vec![255u16, 256, 257, 4095, 4096, 4097, 65534, 65535]), any::<u16>(),]
}

proptest! {
    #[test]
    fn scene_stream_any_split_gives_same_calls(cuts in vec(0usize..500, 0..12), which in 0u8..3) {
        let image = match which {
            0 => TINY_IMAGE.to_vec(),
            1 => ImageSpec::two_pe().build(),
            _ => ImageSpec::sphere().build(),
        };
        let (_, whole, _) = stream_in_chunks(&image, image.len());
        let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c % (image.len() + 1)).collect();
        cuts.push(0);
        cuts.push(image.len());
        cuts.sort_unstable();
        let mut s = SceneStream::new();
        let mut sink = RecordingSink::default();
        for w in cuts.windows(2) {
            prop_assert_eq!(s.feed(&image[w[0]..w[1]], &mut sink), Ok(()));
        }
        prop_assert!(s.is_done());
        prop_assert_eq!(coalesce(&sink.events), coalesce(&whole.events));
    }

    /// Random damage to a valid image: an error or a finished stream, never a panic. Damage
    /// to the dims that makes the grid larger than 2^24 voxels (up to 65535³, which overflows
    /// u32) is `BadHeader`.
    #[test]
    fn scene_stream_mutations_never_panic(flips in vec((0usize..TINY_IMAGE.len(), 1u8..=255), 1..6),
                                          chunk in 1usize..40) {
        let mut image = TINY_IMAGE;
        for (i, x) in &flips {
            image[*i] ^= x;
        }
        let (r, _, s) = stream_in_chunks(&image, chunk);
        // The body is CRC-protected; the header is protected by SceneBegin's whole-image CRC
        // (checked by the device), so only header damage may go unnoticed here.
        if r.is_ok() && s.is_done() {
            prop_assert_eq!(&image[64..], &TINY_IMAGE[64..]);
        }
        if voxels_of(&image) > 1 << 24 {
            prop_assert!(r.is_err() && !s.is_done());
            if SceneHeader::parse(&image[..64]).is_err() {
                prop_assert_eq!(r, SceneHeader::parse(&image[..64]).map(|_| ()));
            }
        }
    }

    /// A valid header with arbitrary fields followed by soup: the header is judged exactly as
    /// §5.7 says (in particular every grid over 2^24 voxels is `BadHeader`), then no panic.
    #[test]
    fn scene_stream_header_and_soup_never_panic(dims in [axis(), axis(), axis()], pe_count: u16,
                                                  materials: u16, objects: u16, pe_mem_words: u32, total_len: u32,
                                                  soup in vec(any::<u8>(), 0..600), chunk in 1usize..64) {
        let mut h = SceneHeader::parse(&TINY_IMAGE[..64]).unwrap();
        h.dims = dims;
        h.pe_count = pe_count;
        h.material_count = materials;
        h.object_count = objects;
        h.pe_mem_words = pe_mem_words;
        h.total_len = total_len;
        let mut image = h.to_bytes().to_vec();
        image.extend_from_slice(&soup);
        let (r, _, s) = stream_in_chunks(&image, chunk);
        let voxels: u64 = dims.iter().map(|&d| d as u64).product();
        let header_ok = (1..=1u64 << 24).contains(&voxels) && (1..=255).contains(&pe_count) && total_len >= 64;
        prop_assert_eq!(SceneHeader::parse(&image[..64]).is_ok(), header_ok);
        if !header_ok {
            prop_assert_eq!(r, Err(SceneError::BadHeader));
            prop_assert!(!s.is_done());
        }
    }

    /// The 2^24-voxel limit alone: every product of three u16 is judged without overflow.
    #[test]
    fn scene_header_voxel_limit(dims in [axis(), axis(), axis()]) {
        let mut h = SceneHeader::parse(&TINY_IMAGE[..64]).unwrap();
        h.dims = dims;
        let voxels: u64 = dims.iter().map(|&d| d as u64).product();
        let expected = if (1..=1u64 << 24).contains(&voxels) { Ok(h) } else { Err(SceneError::BadHeader) };
        prop_assert_eq!(SceneHeader::parse(&h.to_bytes()), expected);
    }

    #[test]
    fn scene_decoders_never_panic_on_soup(soup in vec(any::<u8>(), 0..400), chunk in 1usize..64) {
        let _ = stream_in_chunks(&soup, chunk);
        let _ = SceneHeader::parse(&soup);
        let _ = Material::parse(&soup);
        let _ = MaterialModel::parse(&soup);
        let _ = ObjectRecord::parse(&soup);
        let _ = LightingRecord::parse(&soup);
        let words: Vec<u32> = soup.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        let _ = PrimRecord::from_words(&words);
        // Soup behind a valid magic and version reaches the header checks (any dims).
        let mut with_magic = b"GRTS\x02\x00\x40\x00".to_vec();
        with_magic.extend_from_slice(&soup);
        let (r, _, _) = stream_in_chunks(&with_magic, chunk);
        if with_magic.len() >= 64 && voxels_of(&with_magic) > 1 << 24 {
            prop_assert!(matches!(r, Err(SceneError::BadHeader | SceneError::NonFinite)), "{:?}", r);
        }
    }

    #[test]
    fn pe_image_parse_never_panics(words in vec(any::<u32>(), 0..64), t in 0u32..4, v in 0u32..4, r in 0u32..6,
                                   p in 0u32..3) {
        let _ = PeImage::parse(&words);
        // Tag and plausible counts so the deeper checks run too.
        let mut w = vec![PE_IMAGE_TAG, t, v, r, p];
        w.extend_from_slice(&words);
        if let Ok(img) = PeImage::parse(&w) {
            for i in 0..img.voxel_count() {
                let (_, first, count) = img.voxel_entry(i).unwrap();
                prop_assert!((first + count) as usize <= img.ref_table().len());
            }
            for &x in img.ref_table() {
                prop_assert!((x as usize) < img.triangle_count() + img.primitive_count());
            }
            for i in 0..img.triangle_count() {
                prop_assert!(img.triangle(i).unwrap().vertices.iter().flatten().all(|c| c.is_finite()));
            }
            for i in 0..img.primitive_count() {
                prop_assert!(img.primitive(i).unwrap().world_to_object.iter().all(|c| c.is_finite()));
            }
        }
    }
}

// ---------------------------------------------------------------- byte soup on the UART side

proptest! {
    #[test]
    fn accumulator_never_panics_on_soup(soup in vec(any::<u8>(), 0..3000), chunk in 1usize..512) {
        let mut small = FrameAccumulator::<64>::new();
        let mut big = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
        for o in feed_all(&mut small, &soup, chunk).into_iter().chain(feed_all(&mut big, &soup, chunk)) {
            if let Outcome::Frame { payload, .. } = o {
                prop_assert!(payload.len() <= frame::MAX_PAYLOAD);
            }
        }
    }

    #[test]
    fn accumulator_resyncs_after_soup(soup in vec(any::<u8>(), 0..300), seq: u16) {
        let mut stream = soup;
        stream.push(0);
        let w = wire(0x22, seq, &[1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0]);
        stream.extend_from_slice(&w);
        let mut acc = FrameAccumulator::<{ frame::MAX_ENCODED }>::new();
        let out = feed_all(&mut acc, &stream, 17);
        prop_assert_eq!(out.last(), Some(&Outcome::Frame { kind: 0x22, seq, payload: w_payload() }));
    }

    #[test]
    fn parse_raw_never_panics(raw in vec(any::<u8>(), 0..64)) {
        let _ = frame::parse_raw(&raw);
    }

    #[test]
    fn msg_decode_never_panics(kind: u8, payload in vec(any::<u8>(), 0..200)) {
        if let Ok(m) = Msg::decode(kind, &payload) {
            // Whatever decodes re-encodes to a payload that decodes to the same message.
            let p = encode_payload(&m);
            let again = Msg::decode(kind, &p).map_err(|e| TestCaseError::fail(format!("{e:?}")))?;
            prop_assert_eq!(encode_payload(&again), p);
        }
    }

    #[test]
    fn msg_decode_never_panics_on_plausible_lengths(kind in prop::sample::select(vec![0x01u8, 0x02, 0x10, 0x11, 0x12, 0x20, 0x21, 0x22, 0x23, 0x7F]),
                                                    head in vec(any::<u8>(), 0..12), count in 0u16..8, tail in vec(any::<u8>(), 0..80)) {
        // Put small counts where the variable-length messages keep them.
        let mut p = head;
        p.resize(12, 0);
        p[6..8].copy_from_slice(&count.to_le_bytes()); // PixelSpan count
        p[2..4].copy_from_slice(&count.to_le_bytes()); // Stats count / Error text_len
        p.extend_from_slice(&tail);
        let _ = Msg::decode(kind, &p);
    }
}

fn w_payload() -> Vec<u8> {
    vec![1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0]
}

// ---------------------------------------------------------------- link additions (§3.7.1, §3.12)

fn colour_encoding() -> impl Strategy<Value = PixelEncoding> {
    prop_oneof![Just(PixelEncoding::Rgb888), Just(PixelEncoding::Rgb565), Just(PixelEncoding::Rle)]
}

fn request() -> impl Strategy<Value = RenderRequest> {
    let ints = any::<(u16, u16, u16, u16)>();
    let cam = (vec3(), vec3(), vec3(), f32_any());
    let light = (vec3(), f32_any(), f32_any());
    (ints, cam, light, colour_encoding()).prop_map(|(i, c, l, encoding)| RenderRequest {
        frame: i.0,
        width: i.1,
        height: i.2,
        flags: i.3,
        eye: c.0,
        target: c.1,
        up: c.2,
        fov_y_deg: c.3,
        light_pos: l.0,
        light_intensity: l.1,
        ambient: l.2,
        encoding,
    })
}

/// Pixels with long runs, small steps and jumps (what shaded frames look like).
fn pixels(max: usize) -> impl Strategy<Value = Vec<[u8; 3]>> {
    vec((0u8..4, any::<[u8; 3]>(), 1usize..100), 0..max).prop_map(|ops| {
        let mut px: Vec<[u8; 3]> = Vec::new();
        let mut cur = [0u8; 3];
        for (kind, v, n) in ops {
            match kind {
                0 => px.extend(std::iter::repeat_n(cur, n)),
                1 => {
                    cur = [cur[0].wrapping_add(v[0] % 3), cur[1].wrapping_sub(v[1] % 3), cur[2].wrapping_add(v[2] % 2)];
                    px.push(cur);
                }
                2 => {
                    let d = v[0] % 20;
                    cur = [cur[0].wrapping_add(d), cur[1].wrapping_add(d), cur[2].wrapping_sub(v[2] % 9)];
                    px.push(cur);
                }
                _ => {
                    cur = v;
                    px.push(cur);
                }
            }
        }
        px
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn rt_render_region(x0: u16, y0: u16, cols: u16, rows: u16, max_span: u16, options: u16, req in request(),
                        seq: u16, n in noise(), chunk in 1usize..100) {
        let region = msg::Region { x0, y0, cols, rows };
        round_trip(Msg::RenderRegion { region, max_span, options, request: req }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_region_end(frame: u16, x0: u16, y0: u16, cols: u16, rows: u16, spans: u32, crc: u32,
                     seq: u16, n in noise(), chunk in 1usize..40) {
        round_trip(Msg::RegionEnd { frame, region: msg::Region { x0, y0, cols, rows }, spans, crc }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_pixel_span_rle(frame: u16, y: u16, x0: u16, px in pixels(60), seq: u16, n in noise(), chunk in 1usize..600) {
        prop_assume!(px.len() <= u16::MAX as usize);
        let mut data = vec![0u8; 4 * px.len() + 2];
        let len = gridrt_shared::pixel::rle_encode(&px, &mut data).unwrap();
        prop_assume!(len <= frame::MAX_PAYLOAD - 10);
        let data = &data[..len];
        let count = px.len() as u16;
        round_trip(Msg::PixelSpan { frame, y, x0, count, encoding: PixelEncoding::Rle, data }, seq, &n, chunk)?;
        let mut out = vec![0u8; 3 * px.len()];
        gridrt_shared::pixel::rle_decode(px.len(), data, &mut out).unwrap();
        prop_assert_eq!(out, px.iter().flatten().copied().collect::<Vec<_>>());
    }

    #[test]
    fn rt_pixel_span_rgb565(frame: u16, y: u16, x0: u16, words in vec(any::<u16>(), 0..=1019), seq: u16, n in noise(), chunk in 1usize..600) {
        let data: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        let count = words.len() as u16;
        round_trip(Msg::PixelSpan { frame, y, x0, count, encoding: PixelEncoding::Rgb565, data: &data }, seq, &n, chunk)?;
    }

    #[test]
    fn rle_compresses_runs_to_a_few_bytes(len in 1usize..4096, colour: [u8; 3]) {
        let px = vec![colour; len];
        let mut data = vec![0u8; 16];
        let n = gridrt_shared::pixel::rle_encode(&px, &mut data).unwrap();
        prop_assert!(n <= 4 + 2, "{len} pixels of one colour in {n} bytes");
    }
}

// ---------------------------------------------------------------- §3.11 flashing messages

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    #[test]
    fn rt_flash_begin(version: u16, total_len: u32, crc: u32, load_addr: u32, entry: u32, seq: u16, n in noise(), chunk in 1usize..40) {
        round_trip(Msg::FlashBegin { version, total_len, crc, load_addr, entry }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_flash_chunk(offset: u32, data in vec(any::<u8>(), 0..=2044), seq: u16, n in noise(), chunk in 1usize..600) {
        round_trip(Msg::FlashChunk { offset, data: &data }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_flash_ack(next_offset: u32, s in 0u8..3, crc: u32, seq: u16, n in noise(), chunk in 1usize..40) {
        let status = [msg::FlashStatus::Receiving, msg::FlashStatus::Verified, msg::FlashStatus::Booting][s as usize];
        round_trip(Msg::FlashAck { next_offset, status, crc }, seq, &n, chunk)?;
    }

    #[test]
    fn rt_flash_boot(crc: u32, seq: u16, n in noise(), chunk in 1usize..40) {
        round_trip(Msg::FlashBoot { crc }, seq, &n, chunk)?;
    }
}
