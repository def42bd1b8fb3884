//! Link features of the device (SPEC.md §3.7.1, §3.12): pixel encodings, `RenderRegion`,
//! the boot banner, and what a failing UART does to a frame.

use super::*;
use gridrt_shared::msg::{region_options, Region};
use gridrt_shared::pixel;

/// Decodes every colour span of `replies` into a `w`×`h` RGB888 canvas (untouched pixels
/// stay 0x55); returns the canvas, the stats and the terminator.
fn canvas(replies: &[Reply], w: u16, h: u16) -> (Vec<u8>, Vec<bool>, Option<Msg<'_>>) {
    let mut img = vec![0x55u8; 3 * w as usize * h as usize];
    let mut seen = vec![false; w as usize * h as usize];
    let mut end = None;
    for r in replies {
        match r.msg() {
            Msg::PixelSpan { encoding: PixelEncoding::PrimId32, .. } | Msg::Stats { .. } => {}
            Msg::PixelSpan { y, x0, count, encoding, data, .. } => {
                let at = y as usize * w as usize + x0 as usize;
                let dst = &mut img[3 * at..3 * (at + count as usize)];
                match encoding {
                    PixelEncoding::Rgb888 => dst.copy_from_slice(data),
                    PixelEncoding::Rgb565 => {
                        for (d, c) in dst.chunks_mut(3).zip(data.chunks(2)) {
                            d.copy_from_slice(&pixel::rgb565_unpack(u16::from_le_bytes([c[0], c[1]])));
                        }
                    }
                    PixelEncoding::Rle => pixel::rle_decode(count as usize, data, dst).unwrap(),
                    _ => panic!(),
                }
                for s in &mut seen[at..at + count as usize] {
                    assert!(!*s, "pixel sent twice");
                    *s = true;
                }
            }
            m @ (Msg::FrameEnd { .. } | Msg::RegionEnd { .. }) => end = Some(m),
            other => panic!("unexpected {other:?}"),
        }
    }
    (img, seen, end)
}

fn render_with(dev: &mut Dev, req: &RenderRequest) -> (Vec<u8>, u32, usize) {
    let r = send(dev, &Msg::RenderRequest(*req));
    let (img, seen, end) = canvas(&r, req.width, req.height);
    assert!(seen.iter().all(|&s| s));
    let Some(Msg::FrameEnd { image_crc, .. }) = end else { panic!("{end:?}") };
    let bytes = r.iter().map(|x| x.2.len()).sum();
    (img, image_crc, bytes)
}

#[test]
fn every_encoding_gives_the_same_image_and_the_crc_covers_what_the_host_decodes() {
    let mut dev = loaded_device();
    let base = request(37, 11, render_flags::SHADOWS);
    let (raw, raw_crc, raw_bytes) = render_with(&mut dev, &base);
    assert_eq!(raw_crc, crc32(&raw));
    let (rle, rle_crc, rle_bytes) = render_with(&mut dev, &RenderRequest { encoding: PixelEncoding::Rle, ..base });
    assert_eq!(rle, raw, "Rle is lossless");
    assert_eq!(rle_crc, raw_crc);
    assert!(rle_bytes * 2 < raw_bytes, "{rle_bytes} vs {raw_bytes}");
    let (q, q_crc, _) = render_with(&mut dev, &RenderRequest { encoding: PixelEncoding::Rgb565, ..base });
    let expect: Vec<u8> = raw.chunks(3).flat_map(|c| pixel::rgb565_quantise([c[0], c[1], c[2]])).collect();
    assert_eq!(q, expect);
    assert_eq!(q_crc, crc32(&expect), "Rgb565 CRC is over the expanded pixels");
}

#[test]
fn regions_reproduce_the_full_frame_pixel_for_pixel() {
    let mut dev = loaded_device();
    let req = request(23, 17, render_flags::SHADOWS | render_flags::PRIM_IDS);
    let (full, _, _) = render_with(&mut dev, &req);
    for (region, max_span, enc) in [
        (Region { x0: 0, y0: 0, cols: 23, rows: 17 }, 0, PixelEncoding::Rgb888),
        (Region { x0: 5, y0: 3, cols: 9, rows: 4 }, 2, PixelEncoding::Rle),
        (Region { x0: 22, y0: 16, cols: 1, rows: 1 }, 0, PixelEncoding::Rle),
        (Region { x0: 0, y0: 8, cols: 23, rows: 9 }, 7, PixelEncoding::Rgb888),
    ] {
        let rq = RenderRequest { encoding: enc, ..req };
        let r = send(&mut dev, &Msg::RenderRegion { region, max_span, options: 0, request: rq });
        let (img, seen, end) = canvas(&r, 23, 17);
        let Some(Msg::RegionEnd { frame, region: got, spans, crc }) = end else { panic!("{end:?}") };
        assert_eq!((frame, got), (9, region));
        let mut expect = Vec::new();
        for y in region.y0..region.y0 + region.rows {
            for x in region.x0..region.x0 + region.cols {
                let i = (y as usize * 23 + x as usize) * 3;
                assert!(seen[i / 3], "({x}, {y}) missing");
                assert_eq!(img[i..i + 3], full[i..i + 3], "({x}, {y})");
                expect.extend_from_slice(&full[i..i + 3]);
            }
        }
        assert_eq!(seen.iter().filter(|&&s| s).count() as u64, region.pixels(), "nothing outside the region");
        assert_eq!(crc, crc32(&expect));
        let colour_spans =
            r.iter().filter(|x| matches!(x.msg(), Msg::PixelSpan { encoding, .. } if encoding.is_colour())).count();
        assert_eq!(spans as usize, 2 * colour_spans, "with PRIM_IDS every colour span has an id span");
        if max_span > 0 {
            let per_row = region.cols.div_ceil(max_span) as usize;
            assert_eq!(colour_spans, per_row * region.rows as usize);
        }
        let stats = stats_map(r.iter().find(|x| x.1 == MsgType::Stats as u8).unwrap());
        assert_eq!(stats[&stat::PRIMARY_RAYS], region.pixels());
        assert_eq!(r.last().unwrap().1, MsgType::RegionEnd as u8, "RegionEnd comes last");
    }
}

/// `SPAN_BYTES`: `max_span` limits each span's data bytes, not its pixels; the pixels are
/// those of the full frame all the same.
#[test]
fn span_bytes_limit_the_data_of_each_span_not_its_pixels() {
    let mut dev = loaded_device();
    let req = request(40, 12, render_flags::SHADOWS);
    let (full, _, _) = render_with(&mut dev, &req);
    let region = Region::full(40, 12);
    for (enc, limit) in [(PixelEncoding::Rle, 24u16), (PixelEncoding::Rle, 9), (PixelEncoding::Rgb888, 30)] {
        let rq = RenderRequest { encoding: enc, ..req };
        let options = region_options::SPAN_BYTES;
        let r = send(&mut dev, &Msg::RenderRegion { region, max_span: limit, options, request: rq });
        let (img, seen, end) = canvas(&r, 40, 12);
        assert!(matches!(end, Some(Msg::RegionEnd { .. })), "{end:?}");
        assert!(seen.iter().all(|&s| s));
        assert_eq!(img, full, "{enc:?} ≤ {limit} B");
        let mut longest_pixels = 0;
        for x in &r {
            if let Msg::PixelSpan { count, data, .. } = x.msg() {
                assert!(data.len() <= limit as usize, "{enc:?}: {} B > {limit}", data.len());
                longest_pixels = longest_pixels.max(count);
            }
        }
        if enc == PixelEncoding::Rgb888 {
            assert_eq!(longest_pixels, 10, "30 B of Rgb888");
        } else if limit >= 24 {
            // (A tighter limit leaves room for one worst-case pixel only.)
            assert!(longest_pixels > limit, "{enc:?} ≤ {limit} B: runs make spans longer in pixels than in bytes");
        }
    }
}

#[test]
fn regions_outside_the_image_name_the_field() {
    let mut dev = loaded_device();
    let req = request(8, 6, 0);
    for (region, detail) in [
        (Region { x0: 0, y0: 0, cols: 9, rows: 1 }, 0),
        (Region { x0: 8, y0: 0, cols: 1, rows: 1 }, 0),
        (Region { x0: 0, y0: 0, cols: 0, rows: 1 }, 0),
        (Region { x0: 0, y0: 5, cols: 1, rows: 2 }, 2),
        (Region { x0: 0, y0: 0, cols: 1, rows: 0 }, 2),
        (Region { x0: u16::MAX, y0: 0, cols: 2, rows: 1 }, 0),
    ] {
        let r = send(&mut dev, &Msg::RenderRegion { region, max_span: 0, options: 0, request: req });
        assert_eq!(r.len(), 1, "{region:?}");
        assert_eq!(error_of(&r[0]), (ErrorCode::BadRequest, detail), "{region:?}");
    }
    // A bad field of the embedded request is reported at its offset in RenderRegion (12 + 2).
    let r = send(
        &mut dev,
        &Msg::RenderRegion { region: Region::full(1, 1), max_span: 0, options: 0, request: request(0, 6, 0) },
    );
    assert_eq!(error_of(&r[0]), (ErrorCode::BadRequest, 14));
    // Without a scene: NoScene, as for RenderRequest.
    let mut fresh = device();
    let r = send(&mut fresh, &Msg::RenderRegion { region: Region::full(8, 6), max_span: 0, options: 0, request: req });
    assert_eq!(error_of(&r[0]).0, ErrorCode::NoScene);
}

#[test]
fn rle_spans_fit_a_frame_even_for_incompressible_rows() {
    // Widest image, every pixel a literal: spans must split before the payload overflows.
    let mut tx = crate::pixels::FrameTx::new();
    let mut enc = crate::pixels::SpanEncoder::new();
    let mut wire = Wire::new();
    enc.begin_with(1, false, PixelEncoding::Rle, 0);
    let mut image = Vec::new();
    for x in 0..4096u16 {
        let p = [
            x.wrapping_mul(97) as u8,
            x.wrapping_mul(31).wrapping_add(7) as u8,
            x.wrapping_mul(13).wrapping_add(200) as u8,
        ];
        image.extend_from_slice(&p);
        enc.push(x, 0, p, 0, &mut tx, &mut wire).unwrap();
    }
    enc.flush(&mut tx, &mut wire).unwrap();
    let (spans, crc) = enc.finish();
    assert_eq!(crc, crc32(&image));
    let r = replies(&wire);
    assert_eq!(r.len() as u32, spans);
    assert!(spans >= 8, "4096 literals of 4 bytes need at least 8 spans: {spans}");
    let (img, seen, _) = canvas(&r, 4096, 1);
    assert!(seen.iter().all(|&s| s));
    assert_eq!(img, image);
}

#[test]
fn announce_sends_a_delimiter_and_an_unsolicited_version() {
    let mut dev = device();
    let mut w = Wire::new();
    dev.announce(&mut w);
    assert_eq!(w[0], 0x00);
    let r = replies(&w);
    assert_eq!(r.len(), 1);
    let Msg::Version(v) = r[0].msg() else { panic!() };
    assert_eq!(r[0].0, 0, "the first frame after a reset has sequence number 0");
    let want = feature::RENDER_REGION | feature::RGB565 | feature::RLE | feature::PRIM_IDS;
    assert_eq!(v.features & want, want);
}

#[test]
fn crc_only_regions_send_no_spans_but_the_same_crc() {
    let mut dev = loaded_device();
    let req = request(16, 9, render_flags::SHADOWS | render_flags::PRIM_IDS);
    let region = Region { x0: 3, y0: 2, cols: 10, rows: 5 };
    let full = send(&mut dev, &Msg::RenderRegion { region, max_span: 0, options: 0, request: req });
    let quiet = send(
        &mut dev,
        &Msg::RenderRegion { region, max_span: 0, options: gridrt_shared::msg::region_options::CRC_ONLY, request: req },
    );
    assert_eq!(quiet.len(), 2, "Stats and RegionEnd only: {quiet:?}");
    let (Msg::RegionEnd { crc: a, .. }, Msg::RegionEnd { crc: b, spans, .. }) =
        (full.last().unwrap().msg(), quiet[1].msg())
    else {
        panic!()
    };
    assert_eq!((a, spans), (b, 0));
}

#[test]
fn no_stats_regions_send_the_same_spans_and_end_without_stats() {
    use gridrt_shared::msg::region_options::{CRC_ONLY, NO_STATS};
    let mut dev = loaded_device();
    let req = request(16, 9, render_flags::SHADOWS);
    let region = Region { x0: 3, y0: 2, cols: 10, rows: 5 };
    let full = send(&mut dev, &Msg::RenderRegion { region, max_span: 0, options: 0, request: req });
    let lean = send(&mut dev, &Msg::RenderRegion { region, max_span: 0, options: NO_STATS, request: req });
    let kinds = |r: &[Reply]| r.iter().map(|x| x.1).collect::<Vec<_>>();
    let mut want = kinds(&full);
    want.retain(|&k| k != MsgType::Stats as u8);
    assert_eq!(kinds(&lean), want);
    assert_eq!(full.last().unwrap().2, lean.last().unwrap().2, "same RegionEnd");
    let bare = send(&mut dev, &Msg::RenderRegion { region, max_span: 0, options: NO_STATS | CRC_ONLY, request: req });
    assert_eq!(kinds(&bare), [MsgType::RegionEnd as u8]);
}

/// A UART that takes `room` bytes, then fails every write.
struct BrokenUart {
    room: usize,
    got: Vec<u8>,
}

impl embedded_io::ErrorType for BrokenUart {
    type Error = embedded_io::ErrorKind;
}

impl embedded_io::Write for BrokenUart {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        let n = buf.len().min(self.room);
        if n == 0 && !buf.is_empty() {
            return Err(embedded_io::ErrorKind::BrokenPipe);
        }
        self.room -= n;
        self.got.extend_from_slice(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

#[test]
fn a_write_error_stops_the_frame_is_counted_and_the_device_recovers() {
    let mut dev = loaded_device();
    let before = dev.write_errors();
    let mut uart = BrokenUart { room: 200, got: Vec::new() };
    dev.feed(&frame(&Msg::RenderRequest(request(16, 9, 0)), 0), &mut uart);
    assert_eq!(dev.write_errors(), before + 1, "one failed write, then the frame stopped");
    assert!(dev.stats().pixels < 16 * 9, "rendering stopped at the failed span");
    // What got out before the failure: whole spans only (the cut frame is no frame); no
    // Stats, FrameEnd or Error after it.
    let r = replies(&uart.got);
    assert!(!r.is_empty() && r.iter().all(|x| x.1 == MsgType::PixelSpan as u8), "{r:?}");
    // The next request is answered in full.
    let out = rendered(&send(&mut dev, &Msg::RenderRequest(request(4, 3, 0))), 4, 3);
    assert_eq!(out.spans, 3);
    assert_eq!(dev.write_errors(), before + 1);
}
