//! Device tests against a small scripted co-processor (`fake::FakeCoproc`), independent of
//! the `gridrt-coproc` model: it checks packet framing strictly and answers with canned
//! results.

mod fake;

use super::*;
use crate::camera::Camera;
use crate::dda::{build_list, GridDesc, TraversalList};
use crate::shade::{self, Light};
use fake::{FakeCoproc, Mode};
use gridrt_shared::frame::{crc32, encode_frame, MAX_ENCODED};
use gridrt_shared::frame::{FrameError, MAX_PAYLOAD};
use gridrt_shared::fsl::{self as wire, op, FslError};
use gridrt_shared::math::Vec3;
use gridrt_shared::msg::{
    feature, render_flags, stat, DeviceInfo, ErrorCode, Msg, MsgError, MsgType, RenderRequest, SceneStatus,
};
use gridrt_shared::msg::{stat_entries, PixelEncoding, STAT_ENTRY_LEN};
use gridrt_shared::scene::{LightingRecord, Material, MaterialModel, SceneError, SceneHeader, EMPTY_VOXEL};
use gridrt_shared::scene::{TriangleRecord, HEADER_LEN, PE_IMAGE_TAG};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::vec::Vec;

// ---------------------------------------------------------------- host side helpers

/// What the device wrote to its UART.
type Wire = Vec<u8>;

/// One frame the device sent: (seq, kind, payload).
#[derive(Debug, Clone)]
struct Reply(u16, u8, Vec<u8>);

impl Reply {
    fn msg(&self) -> Msg<'_> {
        Msg::decode(self.1, &self.2).unwrap()
    }
}

const VOXELS: usize = 64;
type Dev = Device<FakeCoproc, NoClock, VOXELS>;

fn info() -> DeviceInfo {
    DeviceInfo {
        protocol: 0,
        firmware: [0, 1, 0],
        board: 0,
        max_payload: 0,
        pe_count: 4,
        voxel_capacity: 0,
        pe_mem_words: 4096,
        features: 0,
    }
}

fn device() -> Dev {
    Device::new(FakeCoproc::new(), NoClock, info())
}

use crate::pixels::tests::frame_of as frame;

fn replies(wire: &[u8]) -> Vec<Reply> {
    crate::pixels::tests::frames(wire).into_iter().map(|(seq, kind, payload)| Reply(seq, kind, payload)).collect()
}

fn exchange(dev: &mut Dev, bytes: &[u8]) -> Vec<Reply> {
    let mut w = Wire::new();
    dev.feed(bytes, &mut w);
    replies(&w)
}

fn send(dev: &mut Dev, msg: &Msg<'_>) -> Vec<Reply> {
    exchange(dev, &frame(msg, 0))
}

fn error_of(r: &Reply) -> (ErrorCode, u32) {
    match r.msg() {
        Msg::Error { code, detail, .. } => (code, detail),
        other => panic!("expected an error, got {other:?}"),
    }
}

/// A 2×2×1 grid over [0,2]×[0,2]×[0,1]; voxel 2 is empty, PE 0 owns voxels 0 and 3, PE 1
/// owns voxel 1. Each PE image holds one triangle per voxel it owns (realistic layout; the
/// fake does not parse it).
fn scene_image(dims: [u16; 3], materials: &[Material]) -> Vec<u8> {
    let voxels = dims.iter().map(|&d| d as usize).product::<usize>();
    let mut map: Vec<u8> = (0..voxels).map(|v| [0u8, 1, EMPTY_VOXEL, 0][v % 4]).collect();
    while !map.len().is_multiple_of(4) {
        map.push(0);
    }
    let mut body = map;
    for m in materials {
        body.extend_from_slice(&m.to_bytes());
    }
    for _ in materials {
        body.extend_from_slice(&MaterialModel::MATTE.to_bytes());
    }
    body.extend_from_slice(&LightingRecord::DEFAULT.to_bytes());
    for pe in 0..2u16 {
        let tri = TriangleRecord {
            vertices: [[0.1, 0.1, 0.5], [0.9, 0.1, 0.5], [0.1, 0.9, 0.5]],
            prim: pe as u32,
            material: 0,
        };
        let mut words = vec![PE_IMAGE_TAG, 1, 1, 1, 0, pe as u32, 0, 1, 0];
        words.extend_from_slice(&tri.to_words());
        body.extend_from_slice(&pe.to_le_bytes());
        body.extend_from_slice(&0u16.to_le_bytes());
        body.extend_from_slice(&(words.len() as u32).to_le_bytes());
        for w in words {
            body.extend_from_slice(&w.to_le_bytes());
        }
    }
    let header = SceneHeader {
        dims,
        pe_count: 2,
        bounds_min: [0.0, 0.0, 0.0],
        bounds_max: [2.0, 2.0, 1.0],
        material_count: materials.len() as u16,
        flags: 0,
        triangle_count: 2,
        pe_mem_words: 1024,
        total_len: (HEADER_LEN + body.len()) as u32,
        body_crc: crc32(&body),
        object_count: 0,
    };
    let mut img = header.to_bytes().to_vec();
    img.extend_from_slice(&body);
    img
}

fn materials() -> [Material; 2] {
    [Material { diffuse: [0.8, 0.4, 0.2], reflect: 0.0 }, Material { diffuse: [0.1, 0.9, 0.5], reflect: 0.0 }]
}

/// Uploads `img` in chunks of `chunk` bytes; returns all replies.
fn upload(dev: &mut Dev, img: &[u8], chunk: usize) -> Vec<Reply> {
    let mut all = send(dev, &Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(img) });
    for (i, c) in img.chunks(chunk).enumerate() {
        all.extend(send(dev, &Msg::SceneChunk { offset: (i * chunk) as u32, data: c }));
    }
    all
}

fn loaded_device() -> Dev {
    let mut dev = device();
    let r = upload(&mut dev, &scene_image([2, 2, 1], &materials()), 100);
    assert!(matches!(r.last().unwrap().msg(), Msg::SceneAck { status: SceneStatus::Loaded, .. }), "{r:?}");
    dev
}

fn request(w: u16, h: u16, flags: u16) -> RenderRequest {
    RenderRequest {
        frame: 9,
        width: w,
        height: h,
        flags,
        eye: [1.0, 1.0, 6.0],
        target: [1.0, 1.0, 0.5],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 20.0,
        light_pos: [1.0, 3.0, 8.0],
        light_intensity: 1.0,
        ambient: 0.15,
        encoding: PixelEncoding::Rgb888,
    }
}

fn stats_map(r: &Reply) -> std::collections::BTreeMap<u8, u64> {
    let Msg::Stats { entries, .. } = r.msg() else { panic!("not stats: {r:?}") };
    stat_entries(entries).collect()
}

/// Splits a render's replies into (colour spans' bytes, prim-id bytes, span count, stats,
/// frame end (spans, crc)).
struct Rendered {
    rgb: Vec<u8>,
    ids: Vec<u32>,
    spans: u32,
    stats: std::collections::BTreeMap<u8, u64>,
    end: (u32, u32),
}

fn rendered(replies: &[Reply], w: u16, h: u16) -> Rendered {
    let mut out = Rendered { rgb: Vec::new(), ids: Vec::new(), spans: 0, stats: Default::default(), end: (0, 0) };
    let mut next = (0u16, 0u16);
    for (i, r) in replies.iter().enumerate() {
        match r.msg() {
            Msg::PixelSpan { frame, y, x0, count, encoding, data } => {
                assert_eq!(frame, 9);
                out.spans += 1;
                match encoding {
                    PixelEncoding::Rgb888 => {
                        assert_eq!((x0, y), next, "spans in row-major order");
                        let nx = x0 + count;
                        next = if nx == w { (0, y + 1) } else { (nx, y) };
                        out.rgb.extend_from_slice(data);
                    }
                    PixelEncoding::PrimId32 => {
                        // Right after the colour span of the same pixels.
                        let Msg::PixelSpan { y: py, x0: px, count: pc, encoding: PixelEncoding::Rgb888, .. } =
                            replies[i - 1].msg()
                        else {
                            panic!("prim span not after colour span")
                        };
                        assert_eq!((py, px, pc), (y, x0, count));
                        out.ids.extend(data.chunks(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())));
                    }
                    _ => panic!(),
                }
            }
            Msg::Stats { frame, .. } => {
                assert_eq!(frame, 9);
                out.stats = stats_map(r);
            }
            Msg::FrameEnd { frame, spans, image_crc } => {
                assert_eq!(frame, 9);
                assert_eq!(i, replies.len() - 1, "FrameEnd comes last");
                out.end = (spans, image_crc);
            }
            other => panic!("unexpected reply {other:?}"),
        }
    }
    assert_eq!(next, (0, h), "every pixel sent once");
    out
}

// ---------------------------------------------------------------- tests

#[test]
fn hello_is_answered_with_version_reporting_capacity_and_features() {
    let mut dev = device();
    let r = send(&mut dev, &Msg::Hello { protocol: 1 });
    assert_eq!(r.len(), 1);
    let Msg::Version(v) = r[0].msg() else { panic!() };
    assert_eq!(v.voxel_capacity, VOXELS as u32);
    assert_eq!(v.protocol, gridrt_shared::PROTOCOL_VERSION as u16);
    assert_eq!(v.max_payload as usize, MAX_PAYLOAD);
    assert_eq!((v.board, v.pe_count, v.pe_mem_words, v.firmware), (0, 4, 4096, [0, 1, 0]));
    assert_eq!(v.features & gridrt_shared::msg::feature::SHADOWS != 0, cfg!(feature = "shadows"));
    assert_ne!(v.features & gridrt_shared::msg::feature::PRIM_IDS, 0);
    // Sequence numbers count up per frame sent.
    let r2 = send(&mut dev, &Msg::Hello { protocol: 1 });
    assert_eq!((r[0].0, r2[0].0), (0, 1));
}

#[test]
fn render_4x3_sends_one_span_per_row_then_stats_then_frame_end_with_image_crc() {
    let mut dev = loaded_device();
    let r = send(&mut dev, &Msg::RenderRequest(request(4, 3, 0)));
    let out = rendered(&r, 4, 3);
    assert_eq!(out.spans, 3);
    assert_eq!(out.end, (3, crc32(&out.rgb)));
    assert_eq!(out.rgb.len(), 4 * 3 * 3);
    let s = &out.stats;
    assert_eq!(s.len(), STAT_COUNT);
    assert_eq!((s[&stat::PIXELS], s[&stat::PRIMARY_RAYS], s[&stat::SHADOW_RAYS]), (12, 12, 0));
    assert_eq!(s[&stat::COPROC_RAYS] + s[&stat::CULLED_RAYS], 12);
    assert!(s[&stat::COPROC_RAYS] > 0 && s[&stat::CULLED_RAYS] > 0, "{s:?}");
    let fake = dev.link();
    assert!(fake.violations.is_empty(), "{:?}", fake.violations);
    let entries: usize = fake.rays.iter().map(|r| r.list.len()).sum();
    assert_eq!(s[&stat::COPROC_RAYS], fake.rays.len() as u64);
    assert_eq!(s[&stat::LIST_ENTRIES], entries as u64);
    assert_eq!(s[&stat::FSL_WORDS_OUT], (8 * fake.rays.len() + 2 * entries) as u64);
    assert_eq!(s[&stat::FSL_WORDS_IN], 8 * fake.rays.len() as u64);
    assert_eq!(s[&stat::INTERSECTION_TESTS], entries as u64);
    assert_eq!(s[&stat::COPROC_CYCLES], 648 * entries as u64);
    // Camera rays only: every word is charged to the primary class.
    let words = (s[&stat::FSL_WORDS_PRIMARY], s[&stat::FSL_WORDS_SHADOW], s[&stat::FSL_WORDS_REFLECTION]);
    assert_eq!(words, (s[&stat::FSL_WORDS_OUT] + s[&stat::FSL_WORDS_IN], 0, 0));
    for st in Stage::ALL {
        assert_eq!((s[&st.instret_key()], s[&st.cycles_key()]), (0, 0), "NoClock counts nothing");
    }
    // Rays are primary rays from the eye with t_max = ∞; lists skip the empty voxel 2.
    for ray in &fake.rays {
        assert_eq!((ray.kind, ray.origin, ray.t_max), (op::RAY_CLOSEST, [1.0, 1.0, 6.0], f32::INFINITY));
        assert!(ray.list.iter().all(|e| e.voxel != 2 && e.voxel < 4));
    }
}

#[test]
fn rendered_pixels_follow_the_shading_contract() {
    let mut dev = loaded_device();
    let req = request(4, 3, render_flags::PRIM_IDS);
    let r = send(&mut dev, &Msg::RenderRequest(req));
    let out = rendered(&r, 4, 3);
    assert_eq!(out.spans, 6, "a prim-id span after each colour span");
    assert_eq!(out.end.1, crc32(&out.rgb));
    let cam =
        Camera::new(Vec3::from(req.eye), Vec3::from(req.target), Vec3::from(req.up), req.fov_y_deg, 4, 3).unwrap();
    let light = Light { pos: Vec3::from(req.light_pos), intensity: 1.0, ambient: 0.15 };
    let mats = materials();
    let mut list = TraversalList::new();
    let grid = GridDesc { min: Vec3::ZERO, max: Vec3::new(2.0, 2.0, 1.0), dims: [2, 2, 1] };
    for y in 0..3u32 {
        for x in 0..4u32 {
            let i = (y * 4 + x) as usize;
            let ray = cam.primary_ray(x, y);
            build_list(&grid, &[0, 1, EMPTY_VOXEL, 0], &ray, 0.0, f32::INFINITY, &mut list);
            let (want, id) = match list.first() {
                None => (shade::to_rgb8(shade::BACKGROUND), u32::MAX),
                Some(e) => {
                    // The fake hits at 0.95 of the first entry's exit with normal +z.
                    let p = shade::hit_point(&ray, e.t_exit * 0.95);
                    let n = shade::facing_normal([0.0, 0.0, 2.0], ray.dir).unwrap();
                    // docs/CONTRACTS.md: albedo · (ambient + intensity · max(0, n·l)).
                    let ndotl = n.dot((light.pos - p).normalize()).max(0.0);
                    let c = mats[(e.voxel % 2) as usize].diffuse.map(|a| a * (light.ambient + light.intensity * ndotl));
                    (shade::to_rgb8(c), e.voxel + 100)
                }
            };
            assert_eq!(&out.rgb[3 * i..3 * i + 3], &want, "pixel ({x}, {y})");
            assert_eq!(out.ids[i], id, "prim id of ({x}, {y})");
        }
    }
}

#[cfg(feature = "shadows")]
#[test]
fn shadow_rays_are_any_hit_queries_toward_the_light_and_darken_occluded_pixels() {
    let mut dev = loaded_device();
    dev.link_mut().shadow_hit = true;
    let r = send(&mut dev, &Msg::RenderRequest(request(4, 3, render_flags::SHADOWS)));
    let shadowed = rendered(&r, 4, 3);
    let s = &shadowed.stats;
    assert!(s[&stat::SHADOW_RAYS] > 0);
    assert_eq!(s[&stat::COPROC_RAYS] + s[&stat::CULLED_RAYS], s[&stat::PRIMARY_RAYS] + s[&stat::SHADOW_RAYS]);
    let fake = dev.link();
    let any: Vec<_> = fake.rays.iter().filter(|r| r.kind == op::RAY_ANY).collect();
    assert!(!any.is_empty());
    for ray in &any {
        assert_eq!(ray.t_max, shade::SHADOW_T_MAX);
        // Direction ends at the light.
        let end = Vec3::from(ray.origin) + Vec3::from(ray.dir);
        assert!((end - Vec3::new(1.0, 3.0, 8.0)).length() < 1e-5);
    }
    // Same frame with the light unoccluded is brighter wherever a shadow ray was sent.
    dev.link_mut().shadow_hit = false;
    let r = send(&mut dev, &Msg::RenderRequest(request(4, 3, render_flags::SHADOWS)));
    let lit = rendered(&r, 4, 3);
    assert!(shadowed.rgb.iter().zip(&lit.rgb).all(|(a, b)| a <= b));
    assert!(shadowed.rgb.iter().zip(&lit.rgb).any(|(a, b)| a < b));
}

#[cfg(not(feature = "shadows"))]
#[test]
fn without_shadows_feature_no_any_hit_query_is_ever_sent() {
    let mut dev = loaded_device();
    let r = send(&mut dev, &Msg::RenderRequest(request(4, 3, render_flags::SHADOWS)));
    let out = rendered(&r, 4, 3);
    assert_eq!(out.stats[&stat::SHADOW_RAYS], 0);
    assert!(dev.link().rays.iter().all(|r| r.kind == op::RAY_CLOSEST));
}

#[test]
fn ray_missing_the_grid_costs_zero_fsl_words() {
    let mut dev = loaded_device();
    let words_after_load = dev.link().words_in;
    let mut req = request(4, 3, render_flags::SHADOWS | render_flags::PRIM_IDS);
    req.target = [1.0, 1.0, 20.0]; // looking away from the grid
    let r = send(&mut dev, &Msg::RenderRequest(req));
    let out = rendered(&r, 4, 3);
    assert_eq!(dev.link().words_in, words_after_load);
    assert_eq!(out.stats[&stat::FSL_WORDS_OUT], 0);
    assert_eq!(out.stats[&stat::FSL_WORDS_IN], 0);
    assert_eq!(out.stats[&stat::CULLED_RAYS], 12);
    assert!(out.rgb.chunks(3).all(|p| p == shade::to_rgb8(shade::BACKGROUND)));
    assert!(out.ids.iter().all(|&i| i == u32::MAX));
}

#[test]
fn a_link_that_answers_rays_directly_gets_no_ray_words_and_the_same_frame() {
    let req = request(4, 3, render_flags::SHADOWS | render_flags::PRIM_IDS);
    let mut over_fsl = loaded_device();
    let fsl = rendered(&send(&mut over_fsl, &Msg::RenderRequest(req)), 4, 3);
    let mut direct = loaded_device();
    direct.link_mut().direct = true;
    let words_after_load = direct.link().words_in;
    let d = rendered(&send(&mut direct, &Msg::RenderRequest(req)), 4, 3);
    assert_eq!(direct.link().words_in, words_after_load);
    assert_eq!(direct.link().rays, over_fsl.link().rays);
    assert_eq!((d.rgb, d.ids), (fsl.rgb, fsl.ids));
    assert_eq!((d.stats[&stat::FSL_WORDS_OUT], d.stats[&stat::FSL_WORDS_IN]), (0, 0));
    assert!(fsl.stats[&stat::FSL_WORDS_OUT] > 0);
    for k in [stat::COPROC_RAYS, stat::LIST_ENTRIES, stat::INTERSECTION_TESTS, stat::COPROC_CYCLES, stat::CULLED_RAYS] {
        assert_eq!(d.stats[&k], fsl.stats[&k], "stat {k}");
    }
}

#[test]
fn coproc_error_word_aborts_the_frame_with_an_error_message_then_device_recovers() {
    let mut dev = loaded_device();
    let word = FslError::VoxelNotLoaded.to_word(3);
    dev.link_mut().mode = Mode::ErrorOnRay(word);
    let r = send(&mut dev, &Msg::RenderRequest(request(4, 3, 0)));
    let last = r.last().unwrap();
    assert_eq!(error_of(last), (ErrorCode::Coprocessor, word));
    assert!(!r.iter().any(|x| x.1 == MsgType::FrameEnd as u8), "aborted frame has no FrameEnd");
    assert_eq!(dev.link().rays.len(), 1, "stops at the first failing ray");
    dev.link_mut().mode = Mode::Normal;
    let r = send(&mut dev, &Msg::RenderRequest(request(4, 3, 0)));
    rendered(&r, 4, 3);
}

#[test]
fn link_timeout_aborts_the_frame_with_an_error_and_does_not_hang() {
    let mut dev = loaded_device();
    dev.set_poll_budget(10_000);
    dev.link_mut().mode = Mode::SilentOnRay;
    let r = send(&mut dev, &Msg::RenderRequest(request(4, 3, 0)));
    assert_eq!(error_of(r.last().unwrap()), (ErrorCode::Coprocessor, DETAIL_LINK_TIMEOUT));
    assert!(!r.iter().any(|x| x.1 == MsgType::FrameEnd as u8));
    // The device still answers.
    let r = send(&mut dev, &Msg::Hello { protocol: 1 });
    assert!(matches!(r[0].msg(), Msg::Version(_)));
}

#[test]
fn garbage_between_frames_is_survived() {
    let mut rng = ChaCha8Rng::seed_from_u64(0x6A6B_0001);
    let mut dev = device();
    let hello = frame(&Msg::Hello { protocol: 1 }, 3);
    for round in 0..200 {
        let mut bytes = Vec::new();
        let n = rng.gen_range(1..300);
        bytes.extend((0..n).map(|_| rng.gen::<u8>()));
        bytes.push(0); // the host's flush delimiter ends the noise
        bytes.extend_from_slice(&hello);
        // Feed in random pieces: reassembly must not depend on read boundaries.
        let mut w = Wire::new();
        let mut rest = &bytes[..];
        while !rest.is_empty() {
            let k = rng.gen_range(1..=rest.len());
            dev.feed(&rest[..k], &mut w);
            rest = &rest[k..];
        }
        let r = replies(&w);
        let last = r.last().unwrap_or_else(|| panic!("round {round}: no reply"));
        assert!(matches!(last.msg(), Msg::Version(_)), "round {round}: {r:?}");
        for e in &r[..r.len() - 1] {
            let (code, _) = error_of(e);
            assert!(
                matches!(code, ErrorCode::BadFrame | ErrorCode::UnexpectedMessage | ErrorCode::BadRequest),
                "{code:?}"
            );
        }
    }
}

#[test]
fn oversize_frame_is_reported_and_the_next_frame_handled() {
    let mut dev = device();
    let mut bytes = vec![0x55u8; MAX_ENCODED + 10];
    bytes.push(0);
    bytes.extend_from_slice(&frame(&Msg::Hello { protocol: 1 }, 0));
    let r = exchange(&mut dev, &bytes);
    assert_eq!(error_of(&r[0]), (ErrorCode::BadFrame, FrameError::DecodeOversize.code()));
    assert!(matches!(r[1].msg(), Msg::Version(_)));
}

#[test]
fn bad_render_requests_name_the_offending_field() {
    let mut dev = loaded_device();
    type Edit = fn(&mut RenderRequest);
    let cases: [(Edit, u32); 8] = [
        (|r| r.width = 0, 2),
        (|r| r.height = 4097, 4),
        (|r| r.eye = [f32::NAN, 0.0, 0.0], 8),
        (|r| r.target = r.eye, 20),
        (|r| r.up = [0.0, 0.0, 1.0], 32),
        (|r| r.fov_y_deg = 0.0, 44),
        (|r| r.ambient = f32::INFINITY, 64),
        (|r| r.encoding = PixelEncoding::PrimId32, 68),
    ];
    for (edit, field) in cases {
        let mut req = request(4, 3, 0);
        edit(&mut req);
        let r = send(&mut dev, &Msg::RenderRequest(req));
        assert_eq!(r.len(), 1);
        assert_eq!(error_of(&r[0]), (ErrorCode::BadRequest, field));
    }
    assert!(dev.link().rays.is_empty(), "no ray for an invalid request");
}

#[test]
fn device_to_host_messages_and_unknown_types_are_unexpected() {
    let mut dev = device();
    let r = send(&mut dev, &Msg::SceneAck { next_offset: 0, status: SceneStatus::Receiving });
    assert_eq!(error_of(&r[0]), (ErrorCode::UnexpectedMessage, MsgType::SceneAck as u32));
    let mut out = [0u8; 64];
    let n = encode_frame(0x55, 0, &[], &mut out).unwrap();
    let r = exchange(&mut dev, &out[..n]);
    assert_eq!(error_of(&r[0]), (ErrorCode::UnexpectedMessage, 0x55));
}

#[test]
fn malformed_payloads_name_the_decoder_error_not_the_type() {
    // SPEC.md §1 and §3.9: detail = 0xFFFF_0000 | MsgError number (the text names the type).
    let mut dev = device();
    let mut out = [0u8; 128];
    let cases: [(&[u8], MsgError); 3] = [
        (&[0u8; 71], MsgError::DecodeTruncated),
        (&[0u8; 73], MsgError::DecodeTrailingBytes),
        (&[1, 2, 3], MsgError::DecodeTruncated),
    ];
    for (payload, e) in cases {
        let n = encode_frame(MsgType::RenderRequest as u8, 0, payload, &mut out).unwrap();
        let r = exchange(&mut dev, &out[..n]);
        assert_eq!(r.len(), 1, "{r:?}");
        assert_eq!(error_of(&r[0]), (ErrorCode::BadRequest, 0xFFFF_0000 | e.code()));
        assert_eq!(error_of(&r[0]).1, DETAIL_MSG_ERROR | e.code());
    }
    // A RenderRequest with an encoding byte out of range: DecodeBadField (4).
    let mut payload = [0u8; 72];
    let n = Msg::RenderRequest(request(4, 3, 0)).encode(&mut payload).unwrap();
    assert_eq!(n, 72);
    payload[68] = 0x7E;
    let n = encode_frame(MsgType::RenderRequest as u8, 0, &payload, &mut out).unwrap();
    let r = exchange(&mut dev, &out[..n]);
    assert_eq!(error_of(&r[0]), (ErrorCode::BadRequest, 0xFFFF_0004));
}

#[test]
fn an_error_from_the_host_is_never_answered() {
    // SPEC.md §1: a device never answers an Error with an Error (nor with anything else).
    let mut dev = device();
    let r = send(&mut dev, &Msg::Error { code: ErrorCode::BadFrame, detail: 3, text: "host saw a bad frame" });
    assert!(r.is_empty(), "{r:?}");
    let r = send(&mut dev, &Msg::Error { code: ErrorCode::Unknown(0x1234), detail: 0, text: "" });
    assert!(r.is_empty(), "{r:?}");
    // The device still answers the next request.
    let r = send(&mut dev, &Msg::Hello { protocol: 1 });
    assert!(matches!(r[0].msg(), Msg::Version(_)), "{r:?}");
}

/// A clock that advances by a fixed amount per read: stage counters must add up to the
/// total of all laps.
/// It starts just below 2^32, so laps across the wrap of the 32-bit stamps are charged too.
#[derive(Clone)]
struct TickClock(core::cell::Cell<u64>);
impl StageClock for TickClock {
    fn now(&self) -> StageStamp {
        let t = self.0.get() + 10;
        self.0.set(t);
        StageStamp { cycles: t as u32, instret: (t / 2) as u32 }
    }
}

#[test]
fn stage_counters_are_reported_under_stage_keys() {
    let mut dev: Device<FakeCoproc, TickClock, VOXELS> =
        Device::new(FakeCoproc::new(), TickClock((u64::from(u32::MAX) - 95).into()), info());
    let mut w = Wire::new();
    let img = scene_image([2, 2, 1], &materials());
    dev.feed(&frame(&Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(&img) }, 0), &mut w);
    dev.feed(&frame(&Msg::SceneChunk { offset: 0, data: &img }, 1), &mut w);
    let mut w = Wire::new();
    dev.feed(&frame(&Msg::RenderRequest(request(4, 3, 0)), 2), &mut w);
    let out = rendered(&replies(&w), 4, 3);
    let s = &out.stats;
    for st in Stage::ALL {
        assert!(s[&st.cycles_key()] > 0, "{st:?}");
        assert_eq!(s[&st.instret_key()], s[&st.cycles_key()] / 2, "{st:?}");
    }
    assert_eq!(Stage::RayGen.instret_key(), stat::STAGE_BASE);
    assert_eq!(Stage::Encode.cycles_key(), stat::STAGE_BASE + 9);
}

/// The upload's cycles: every input batch from the one holding `SceneBegin` to the one that
/// completed the image, and the waits between them; the feed cycles only the batches; the
/// parse cycles only the scene parser's share of them. Sent with every later frame, and not at
/// all by a device without a cycle counter.
/// A clock that advances by 10 per read, shared with the test, which can let time pass.
#[derive(Clone)]
struct SharedClock(std::rc::Rc<core::cell::Cell<u64>>);
impl StageClock for SharedClock {
    fn now(&self) -> StageStamp {
        let t = self.0.get() + 10;
        self.0.set(t);
        StageStamp { cycles: t as u32, instret: t as u32 }
    }
}

/// The upload's cycles: every input batch from the one holding `SceneBegin` to the one that
/// completed the image, and the waits between them; the feed cycles only the batches; the
/// parse cycles only the scene parser's share of them. Sent with every later frame, and not at
/// all by a device without a cycle counter.
#[test]
fn upload_cycles_count_the_batches_and_the_waits_between_them() {
    let time = std::rc::Rc::new(core::cell::Cell::new(0u64));
    let mut dev: Device<FakeCoproc, SharedClock, VOXELS> =
        Device::new(FakeCoproc::new(), SharedClock(time.clone()), info());
    // The host's bytes take a while: the device waits on its UART between the batches.
    let wait = || time.set(time.get() + 1000);
    let mut w = Wire::new();
    let img = scene_image([2, 2, 1], &materials());
    let (first, rest) = img.split_at(img.len() / 2);
    dev.feed(&frame(&Msg::SceneBegin { total_len: img.len() as u32, crc: crc32(&img) }, 0), &mut w);
    wait();
    dev.feed(&frame(&Msg::SceneChunk { offset: 0, data: first }, 1), &mut w);
    wait();
    dev.feed(&frame(&Msg::SceneChunk { offset: first.len() as u32, data: rest }, 2), &mut w);
    let acks = replies(&w);
    assert!(matches!(acks.last().unwrap().msg(), Msg::SceneAck { status: SceneStatus::Loaded, .. }), "{acks:?}");
    // After the upload the clock runs on: none of it is the upload's.
    wait();
    let mut w = Wire::new();
    dev.feed(&frame(&Msg::RenderRequest(request(4, 3, 0)), 3), &mut w);
    let s = rendered(&replies(&w), 4, 3).stats;
    let (cycles, feed, parse) = (s[&stat::UPLOAD_CYCLES], s[&stat::UPLOAD_FEED_CYCLES], s[&stat::UPLOAD_PARSE_CYCLES]);
    // Each parse is one lap of 10 cycles; each batch has a few more reads around it.
    assert_eq!(parse, 2 * 10, "two chunks parsed");
    assert!(feed > parse, "feed {feed}, parse {parse}");
    // The two waits inside the upload, not the one after it.
    assert_eq!(cycles - feed, 2 * 1000 + 2 * 10, "cycles {cycles}, feed {feed}");

    // A device without a cycle counter sends no upload entries.
    let mut plain = loaded_device();
    let mut w = Wire::new();
    plain.feed(&frame(&Msg::RenderRequest(request(4, 3, 0)), 3), &mut w);
    let s = rendered(&replies(&w), 4, 3).stats;
    assert!(!s.contains_key(&stat::UPLOAD_CYCLES) && !s.contains_key(&stat::UPLOAD_PARSE_CYCLES), "{s:?}");
}

mod link;
mod upload;

#[test]
fn stats_carry_per_hart_entries_only_for_a_frame_several_harts_traced() {
    let mut s = FrameStats::default();
    s.harts[0] = HartWork { rows: 5, busy_cycles: 500, wait_cycles: 50 };
    // One hart: the base entries only.
    assert_eq!(s.hart_entries().count(), 0);
    assert_eq!(s.to_bytes().1, STAT_COUNT * STAT_ENTRY_LEN);
    s.harts[2] = HartWork { rows: 3, busy_cycles: 300, wait_cycles: 7 };
    let mut other = FrameStats::default();
    other.harts[2] = HartWork { rows: 1, busy_cycles: 100, wait_cycles: 1 };
    s.accumulate(&other);
    let hart: Vec<(u8, u64)> = s.hart_entries().collect();
    assert_eq!(
        hart,
        [
            (stat::HART_ROWS_BASE, 5),
            (stat::HART_BUSY_BASE, 500),
            (stat::HART_WAIT_BASE, 50),
            (stat::HART_ROWS_BASE + 2, 4),
            (stat::HART_BUSY_BASE + 2, 400),
            (stat::HART_WAIT_BASE + 2, 8),
        ]
    );
    let (bytes, len) = s.to_bytes();
    assert_eq!(len, (STAT_COUNT + 6) * STAT_ENTRY_LEN);
    let sent: Vec<(u8, u64)> = stat_entries(&bytes[..len]).skip(STAT_COUNT).collect();
    assert_eq!(sent, hart);
}
