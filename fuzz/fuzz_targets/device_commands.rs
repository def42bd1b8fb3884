//! Firmware command parser: arbitrary host → device bytes into `Device::feed`, with a fake
//! co-processor link that acknowledges loads and answers every ray with a miss. The device
//! must answer with well-formed frames only, never panic, never hang.
#![no_main]

use gridrt_firmware::device::{Device, NoClock};
use gridrt_firmware::embedded_io::{ErrorType, Write};
use gridrt_firmware::fsl::{FslLink, FslWord};
use gridrt_shared::frame::{FeedResult, FrameAccumulator, MAX_ENCODED};
use gridrt_shared::fsl::{ack_word, op, opcode, RayResult};
use gridrt_shared::msg::{DeviceInfo, Msg};
use libfuzzer_sys::fuzz_target;

/// Answers packets as a well-behaved co-processor would, without computing anything.
#[derive(Default)]
struct FakeLink {
    first: Option<u32>,
    out: std::collections::VecDeque<FslWord>,
}

impl FslLink for FakeLink {
    type Error = core::convert::Infallible;
    fn nput(&mut self, w: FslWord) -> nb::Result<(), Self::Error> {
        let first = *self.first.get_or_insert(w.data);
        if w.control {
            self.first = None;
            match opcode(first) {
                op::LOAD_PE => self.out.push_back(FslWord::last(ack_word(op::LOAD_PE, (first & 0xFF) as u8))),
                op::CLEAR => self.out.push_back(FslWord::last(ack_word(op::CLEAR, 0))),
                op::RAY_CLOSEST | op::RAY_ANY => {
                    let words = RayResult::MISS.to_words();
                    for (i, &d) in words.iter().enumerate() {
                        self.out.push_back(if i + 1 == words.len() { FslWord::last(d) } else { FslWord::data(d) });
                    }
                }
                _ => {}
            }
        }
        Ok(())
    }
    fn nget(&mut self) -> nb::Result<FslWord, Self::Error> {
        self.out.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

/// Checks that everything the device sends is a valid frame with a decodable message.
struct Check(FrameAccumulator<MAX_ENCODED>);

impl ErrorType for Check {
    type Error = core::convert::Infallible;
}

/// Takes every byte at once (the device's `write_all` never waits).
impl Write for Check {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Self::Error> {
        let mut input = bytes;
        for _ in 0..=bytes.len() {
            match self.0.feed(input) {
                FeedResult::Consumed => break,
                FeedResult::Frame { frame, rest } => {
                    assert!(Msg::decode(frame.kind, frame.payload).is_ok(), "device sent an undecodable message");
                    input = rest;
                }
                other => panic!("device sent a bad frame: {other:?}"),
            }
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Renders larger than this many pixels are left out (they only cost time).
const MAX_PIXELS: u64 = 32 * 32;

fn too_big(segment: &[u8]) -> bool {
    let mut buf = segment.to_vec();
    let Some(end) = buf.iter().position(|&b| b == 0) else { return false };
    let Ok(n) = cobs::decode_in_place(&mut buf[..end]) else { return false };
    let Ok(f) = gridrt_shared::frame::parse_raw(&buf[..n]) else { return false };
    match Msg::decode(f.kind, f.payload) {
        Ok(Msg::RenderRequest(r)) => r.width as u64 * r.height as u64 > MAX_PIXELS,
        Ok(Msg::RenderRegion { region, request, .. }) => {
            region.pixels() > MAX_PIXELS || request.width as u64 * request.height as u64 > 4096 * 4096
        }
        _ => false,
    }
}

fuzz_target!(|data: &[u8]| {
    let info = DeviceInfo { protocol: 0, firmware: [0, 1, 0], board: 0, max_payload: 0, pe_count: 4, voxel_capacity: 0, pe_mem_words: 4096, features: 0 };
    let mut dev: Box<Device<FakeLink, NoClock, 4096>> = Box::new(Device::new(FakeLink::default(), NoClock, info));
    dev.set_poll_budget(64);
    let mut out = Check(FrameAccumulator::new());
    dev.announce(&mut out);
    // Feed frame by frame (segments ending in 0x00), leaving out oversized renders.
    for segment in data.split_inclusive(|&b| b == 0) {
        if !too_big(segment) {
            dev.feed(segment, &mut out);
        }
    }
});
