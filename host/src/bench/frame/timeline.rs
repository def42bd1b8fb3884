//! The frame timeline of the modelled board: soft-core, co-processor and UART, and what
//! overlaps with what, from per-frame quantities ([`FrameWork`] → [`Timeline`]).
//!
//! # What overlaps with what
//! 1. **Request in.** The host's `RenderRequest` crosses the line before the device starts:
//!    serial, `request_bytes · 10 / baud` (8N1).
//! 2. **Soft-core and co-processor** (each on its own clock: one domain by default, the `rtl`
//!    configuration's co-processor on its profile's). The soft-core puts each ray's request words as it
//!    builds them; the co-processor takes them at its FSL rate meanwhile, so the request
//!    streaming (`coproc_request_cycles`) hides behind the soft-core's own put instructions,
//!    which `cpu_cycles` already counts. The rest of a ray's co-processor time (voxel setup,
//!    tests, arbitration, result words) is what the soft-core waits for:
//!    - **one ray in flight** (`rays_in_flight` = 1, the firmware as GridRT built it): the
//!      soft-core idles until the result is back, so the two add up:
//!      `work = cpu + wait`;
//!    - **a ray queue of depth Q ≥ 2**: the PEs test ray *i* while the soft-core builds the
//!      lists of the next rays and shades the previous ones, a two-stage pipeline over the
//!      frame's co-processor rays R. With the per-frame totals spread evenly over the rays
//!      the pipeline ends one ray's worth of the faster stage after the slower one:
//!      `work = max(cpu, wait) + min(cpu, wait) / R`. Depth 2 already reaches it for even
//!      rays; deeper queues absorb ray-to-ray variance, which per-frame totals cannot see,
//!      so for uneven rays this is a bound that deeper queues approach.
//! 3. **UART out.** The firmware writes each message (pixel spans, then `Stats` and
//!    `FrameEnd`) with blocking writes into the UART's transmit buffer of `tx_buffer_bytes`
//!    (the 16-byte FIFO of an NS16550A or AXI UART Lite, driven by polling, as the firmware
//!    does today; a DMA or interrupt-driven ring would be larger). A burst of b bytes
//!    returns once all but min(b, B) of them have left, so at most min(b, B) of each burst's
//!    line time overlaps the rendering that follows it, and never more than the rendering
//!    itself: `hidden = min(work, bursts · min(B, span_bytes / bursts) · byte_time)`. The
//!    tail (`Stats` + `FrameEnd`) leaves after the last pixel: serial.
//!
//! `frame = request + work + answer − hidden`.
//!
//! The scene upload is not part of the frame (it is done once per scene); the bench reports
//! it on its own line.

use serde::Serialize;

/// Per-frame quantities of one configuration (all counted over the whole frame).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FrameWork {
    /// Soft-core cycles of the render (instructions × CPI, or measured `mcycle`).
    pub cpu_cycles: f64,
    /// Co-processor cycles the timing model charged for the frame's rays (0 without one).
    pub coproc_cycles: f64,
    /// Of those, the cycles of request words streaming in (words × `word_in_cycles`).
    pub coproc_request_cycles: f64,
    /// Rays given to the co-processor.
    pub coproc_rays: u64,
    /// Rays the firmware keeps in flight in the co-processor (1: one at a time).
    pub rays_in_flight: u32,
    /// Clock of the soft-core, Hz.
    pub clock_hz: f64,
    /// Clock of the co-processor, Hz (the soft-core's in one clock domain).
    pub coproc_clock_hz: f64,
    /// Line rate, baud (8N1: 10 bit times per byte).
    pub baud: u32,
    /// Host → device wire bytes of the render (the request).
    pub request_bytes: u64,
    /// Device → host wire bytes of the render (spans, `Stats`, `FrameEnd`).
    pub answer_bytes: u64,
    /// Of `answer_bytes`, those sent after the last pixel (`Stats` + `FrameEnd`).
    pub tail_bytes: u64,
    /// Messages the device wrote while rendering (its pixel spans).
    pub bursts: u64,
    /// Bytes the board's UART holds while the line drains them.
    pub tx_buffer_bytes: u64,
}

/// The timeline of one frame, in seconds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Timeline {
    /// Soft-core busy time.
    pub cpu_s: f64,
    /// Co-processor time the model charged (busy or not overlapped).
    pub coproc_s: f64,
    /// Co-processor time the soft-core would wait for with one ray in flight.
    pub coproc_wait_s: f64,
    /// Soft-core and co-processor together (item 2 of the module docs).
    pub work_s: f64,
    /// Line time of the render, both directions.
    pub link_s: f64,
    /// Line time of the answer that overlapped the work.
    pub link_hidden_s: f64,
    /// The frame: request, work, and the answer not hidden behind the work.
    pub frame_s: f64,
}

impl Timeline {
    /// Frames per second.
    pub fn fps(&self) -> f64 {
        if self.frame_s > 0.0 {
            1.0 / self.frame_s
        } else {
            f64::INFINITY
        }
    }
}

/// The timeline of `w` (module docs).
pub fn timeline(w: &FrameWork) -> Timeline {
    let hz = w.clock_hz.max(1.0);
    let coproc_hz = w.coproc_clock_hz.max(1.0);
    let byte_s = 10.0 / w.baud.max(1) as f64;
    let cpu_s = w.cpu_cycles / hz;
    let coproc_s = w.coproc_cycles / coproc_hz;
    let coproc_wait_s = (w.coproc_cycles - w.coproc_request_cycles).max(0.0) / coproc_hz;
    let work_s = if w.rays_in_flight <= 1 || w.coproc_rays == 0 {
        cpu_s + coproc_wait_s
    } else {
        cpu_s.max(coproc_wait_s) + cpu_s.min(coproc_wait_s) / w.coproc_rays as f64
    };
    let request_s = w.request_bytes as f64 * byte_s;
    let answer_s = w.answer_bytes as f64 * byte_s;
    let span_bytes = w.answer_bytes.saturating_sub(w.tail_bytes);
    let per_burst = if w.bursts > 0 { span_bytes as f64 / w.bursts as f64 } else { 0.0 };
    let overlappable = w.bursts as f64 * per_burst.min(w.tx_buffer_bytes as f64) * byte_s;
    let link_hidden_s = overlappable.min(work_s);
    Timeline {
        cpu_s,
        coproc_s,
        coproc_wait_s,
        work_s,
        link_s: request_s + answer_s,
        link_hidden_s,
        frame_s: request_s + work_s + answer_s - link_hidden_s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 + 1e-9 * b.abs()
    }

    /// A 2×1 frame, one ray in flight, 16-byte UART FIFO, 100 MHz, 10 Mbaud (1 µs a byte).
    #[test]
    fn two_by_one_frame_with_one_ray_in_flight_adds_cpu_and_wait_and_hides_one_fifo() {
        // Soft-core: 2 pixels × 1000 instructions at CPI 2 = 4000 cycles = 40 µs.
        // Co-processor: one ray (the other culled), 1000 cycles, of which the request of
        // 8 + 2·2 words at 1 cycle = 12 streams in during the puts: wait 988 cycles = 9.88 µs.
        // Work = 40 + 9.88 = 49.88 µs.
        // Link: request 100 B = 100 µs; answer 100 B = 100 µs: one span message of 30 B, the
        // tail 70 B. Hidden: min(work 49.88, 1 burst · min(16, 30) B · 1 µs = 16) = 16 µs.
        // Frame = 100 + 49.88 + 100 − 16 = 233.88 µs.
        let w = FrameWork {
            cpu_cycles: 4000.0,
            coproc_cycles: 1000.0,
            coproc_request_cycles: 12.0,
            coproc_rays: 1,
            rays_in_flight: 1,
            clock_hz: 100e6,
            coproc_clock_hz: 100e6,
            baud: 10_000_000,
            request_bytes: 100,
            answer_bytes: 100,
            tail_bytes: 70,
            bursts: 1,
            tx_buffer_bytes: 16,
        };
        let t = timeline(&w);
        assert!(close(t.cpu_s, 40e-6), "{t:?}");
        assert!(close(t.coproc_s, 10e-6), "{t:?}");
        assert!(close(t.coproc_wait_s, 9.88e-6), "{t:?}");
        assert!(close(t.work_s, 49.88e-6), "{t:?}");
        assert!(close(t.link_s, 200e-6), "{t:?}");
        assert!(close(t.link_hidden_s, 16e-6), "{t:?}");
        assert!(close(t.frame_s, 233.88e-6), "{t:?}");
        // At 1 Mbaud (10 µs a byte) the FIFO could hide 160 µs, more than the 49.88 µs of
        // work: the whole work hides. Frame = 1000 + 49.88 + 1000 − 49.88 = 2000 µs.
        let t = timeline(&FrameWork { baud: 1_000_000, ..w });
        assert!(close(t.link_hidden_s, 49.88e-6) && close(t.frame_s, 2000e-6), "{t:?}");
        // A co-processor on its own 50 MHz clock: its 1000 cycles take 20 µs, the wait 988
        // cycles = 19.76 µs; the soft-core's 40 µs stay. Work = 59.76 µs, hidden 16 µs,
        // frame = 100 + 59.76 + 100 − 16 = 243.76 µs.
        let t = timeline(&FrameWork { coproc_clock_hz: 50e6, ..w });
        assert!(close(t.cpu_s, 40e-6) && close(t.coproc_s, 20e-6) && close(t.coproc_wait_s, 19.76e-6), "{t:?}");
        assert!(close(t.work_s, 59.76e-6) && close(t.frame_s, 243.76e-6), "{t:?}");
    }

    /// A 4×2 frame with a ray queue: the soft-core and the PEs overlap.
    #[test]
    fn four_by_two_frame_with_a_ray_queue_overlaps_cpu_and_coprocessor() {
        // Soft-core 8000 cycles = 80 µs; co-processor 6000 cycles for 4 rays, their requests
        // 4 · (8 + 2) words = 40 cycles: wait 5960 cycles = 59.6 µs.
        // One ray in flight: 80 + 59.6 = 139.6 µs.
        // Queue of 2: max(80, 59.6) + min(80, 59.6) / 4 rays = 80 + 14.9 = 94.9 µs.
        // Link at 1 µs a byte, a buffer larger than any burst: request 100 µs; answer 150 B
        // in 2 span messages of 40 B and a 70 B tail. Hidden: min(94.9, 2 · 40 · 1) = 80 µs.
        // Frame = 100 + 94.9 + 150 − 80 = 264.9 µs.
        let w = FrameWork {
            cpu_cycles: 8000.0,
            coproc_cycles: 6000.0,
            coproc_request_cycles: 40.0,
            coproc_rays: 4,
            rays_in_flight: 1,
            clock_hz: 100e6,
            coproc_clock_hz: 100e6,
            baud: 10_000_000,
            request_bytes: 100,
            answer_bytes: 150,
            tail_bytes: 70,
            bursts: 2,
            tx_buffer_bytes: 1 << 20,
        };
        let serial = timeline(&w);
        assert!(close(serial.work_s, 139.6e-6), "{serial:?}");
        let queued = timeline(&FrameWork { rays_in_flight: 2, ..w });
        assert!(close(queued.work_s, 94.9e-6), "{queued:?}");
        assert!(close(queued.link_hidden_s, 80e-6), "{queued:?}");
        assert!(close(queued.frame_s, 264.9e-6), "{queued:?}");
        // Deeper queues give the same figure for even rays (module docs).
        assert_eq!(timeline(&FrameWork { rays_in_flight: 8, ..w }).work_s, queued.work_s);
        // A co-processor slower than the soft-core bounds the frame the other way round:
        // 30000 cycles, wait 299.6 µs: 299.6 + 80 / 4 = 319.6 µs.
        let pe_bound = timeline(&FrameWork { rays_in_flight: 2, coproc_cycles: 30000.0, ..w });
        assert!(close(pe_bound.work_s, 319.6e-6), "{pe_bound:?}");
        assert!(close(pe_bound.fps(), 1.0 / pe_bound.frame_s));
    }

    /// Without a co-processor the work is the soft-core's alone, whatever the queue says.
    #[test]
    fn soft_core_only_frame_is_the_cpu_time_plus_the_unhidden_link() {
        // 1 pixel, 500 cycles at 50 MHz = 10 µs; request 10 B, answer 30 B (tail 20 B, one
        // 10 B span), 100 kbaud = 100 µs a byte, 16-byte FIFO: hidden = min(10, 1 · 10 · 100)
        // = 10 µs. Frame = 1000 + 10 + 3000 − 10 = 4000 µs.
        let w = FrameWork {
            cpu_cycles: 500.0,
            coproc_cycles: 0.0,
            coproc_request_cycles: 0.0,
            coproc_rays: 0,
            rays_in_flight: 4,
            clock_hz: 50e6,
            coproc_clock_hz: 50e6,
            baud: 100_000,
            request_bytes: 10,
            answer_bytes: 30,
            tail_bytes: 20,
            bursts: 1,
            tx_buffer_bytes: 16,
        };
        let t = timeline(&w);
        assert!(close(t.work_s, 10e-6) && close(t.link_hidden_s, 10e-6), "{t:?}");
        assert!(close(t.frame_s, 4000e-6), "{t:?}");
    }
}
