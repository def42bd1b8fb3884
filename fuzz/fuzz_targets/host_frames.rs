//! Host frame decoder: arbitrary device → host bytes through the accumulator, `Msg::decode`,
//! the pixel decoders, and the session's own frame handling (hello, a reliable band render,
//! a scene upload), which must end in an error or a result, never a panic or a hang.
#![no_main]

use std::io::{self, Read, Write};
use std::time::Duration;

use gridrt_host::session::{decode_colour, Canvas, Session, SessionConfig};
use gridrt_shared::frame::{FeedResult, FrameAccumulator};
use gridrt_shared::msg::{Msg, PixelEncoding, Region, RenderRequest};
use libfuzzer_sys::fuzz_target;

/// Replays `data` as the device's output in pieces of `step` bytes, then reports the link gone.
struct Replay<'a> {
    data: &'a [u8],
    step: usize,
}

impl Read for Replay<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.step.min(buf.len()).min(self.data.len());
        if n == 0 {
            return Ok(0); // end of stream: the session reports `Disconnected`
        }
        buf[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        Ok(n)
    }
}

impl Write for Replay<'_> {
    fn write(&mut self, b: &[u8]) -> io::Result<usize> {
        Ok(b.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

fn request(encoding: PixelEncoding) -> RenderRequest {
    RenderRequest {
        frame: 1,
        width: 16,
        height: 8,
        flags: 0,
        eye: [0.0, 0.0, 5.0],
        target: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        fov_y_deg: 45.0,
        light_pos: [1.0; 3],
        light_intensity: 1.0,
        ambient: 0.1,
        encoding,
    }
}

fn config() -> SessionConfig {
    SessionConfig::new("fuzz")
        .hello_timeout(Duration::from_millis(1))
        // Every other wait derives from the line rate (SPEC §3.14): a fast line, short waits.
        .baud(10_000_000)
        .turnaround(Duration::from_millis(1))
        .max_probes(2)
        .render_timeout(Duration::from_millis(2))
        .max_requests_per_band(4)
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, stream)) = data.split_first() else { return };

    // 1. The decoders on their own.
    let mut acc = FrameAccumulator::<{ gridrt_shared::frame::MAX_ENCODED }>::new();
    let mut input = stream;
    for _ in 0..=stream.len() {
        match acc.feed(input) {
            FeedResult::Consumed => break,
            FeedResult::Overflow { rest } | FeedResult::BadFrame { rest, .. } => input = rest,
            FeedResult::Frame { frame, rest } => {
                if let Ok(m) = Msg::decode(frame.kind, frame.payload) {
                    if let Msg::PixelSpan { count, encoding, data, .. } = m {
                        if encoding.is_colour() {
                            let mut out = vec![0u8; 3 * count as usize];
                            // Msg::decode validated the span: decoding cannot fail.
                            assert!(decode_colour(encoding, count as usize, data, &mut out).is_ok());
                        }
                    }
                    let mut p = vec![0u8; 4096];
                    let n = m.encode(&mut p).expect("a decoded message re-encodes");
                    assert_eq!(Msg::decode(frame.kind, &p[..n]), Ok(m));
                }
                input = rest;
            }
        }
    }

    // 2. The session on the same bytes.
    let step = 1 + (mode as usize >> 2) % 97;
    let mut s = Session::new(Replay { data: stream, step }, config());
    match mode & 3 {
        0 => {
            let _ = s.hello(&mut |_| {});
        }
        1 => {
            let enc = [PixelEncoding::Rgb888, PixelEncoding::Rgb565, PixelEncoding::Rle][(mode as usize >> 4) % 3];
            let req = request(enc);
            let mut canvas = Canvas::new(16, 8, mode & 0x40 != 0);
            let _ = s.render_band(&req, Region::full(16, 8), &mut canvas, &mut |_| {});
        }
        2 => {
            let _ = s.render(&request(PixelEncoding::Rgb888), &mut |_| {});
        }
        _ => {
            let _ = s.upload_scene(&[0x47; 300], &mut |_| {});
        }
    }
});
