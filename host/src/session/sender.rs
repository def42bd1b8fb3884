//! The sender of a windowed transfer (SPEC.md §3.14), without I/O: which bytes go out next,
//! what a `Sack` says arrived, and which transmissions it proves lost.
//!
//! # Loss detection
//! The line is a FIFO, and a `Sack` names the data frame it answers (`heard`). So when a
//! `Sack` for frame `h` arrives, every frame sent before `h` has either been taken by the
//! receiver (its bytes are below `next_offset` or inside a listed range) or is lost. Lost
//! chunks are sent again at once; nothing waits for a timer. Only the tail of a transfer —
//! the last frames, with no later frame to reveal their loss — needs a probe: an empty data
//! frame whose `Sack` settles everything sent before it. The session sends one when the
//! receiver reports a corrupt frame (`Error{BadFrame}`, a NAK) or, as a last resort, when the
//! line has been quiet for longer than the bytes in flight take to cross it.
//!
//! # Frames in flight
//! Besides the receiver's window, the sender keeps in flight only what keeps the line busy
//! for a round trip — four times the shortest seen from a data frame to its `Sack` — and at least
//! three frames. A deeper queue gains no speed; it delays the `Sack`s that reveal a loss, and
//! the holes waiting for their resent chunk pile up beyond the four ranges a receiver holds
//! (a frame that would need a fifth is dropped and must be sent again).
//!
//! # Chunk size
//! Each transmission, once settled, is a sample (wire bytes, arrived) for the direction's
//! [`LossEstimator`]; new chunks get the payload with the best selective-repeat efficiency at
//! the estimated byte error rate ([`best_payload`]). A lost chunk larger than that goes again
//! in pieces of the current size.

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use gridrt_shared::msg::Sack;

use super::estimate::{arrival, best_payload, wire_len, LossEstimator};

/// Bytes of a data message before its data (`offset`).
pub(crate) const DATA_HEAD: usize = 4;

/// Round trips in flight, in units of the shortest seen. The usual round trip on a host with
/// other work is several times the shortest (thread wakeups, the serial driver): with small
/// chunks on a noisy fast line, 1.5 left a 3 Mbaud upload at BER 1e-4 idle 27 % of the time
/// (docs/bench-link.md).
const RTT_MARGIN: f64 = 4.0;

/// First chunk size, before anything is known about the line.
const FIRST_CHUNK: usize = 512;

/// One chunk in flight.
#[derive(Debug, Clone, Copy)]
struct Flight {
    len: u32,
    /// Sequence number, wire bytes and time of its latest transmission, until a `Sack`
    /// settles it.
    pending: Option<(u16, usize, Instant)>,
    /// Wire bytes unsettled when it was last sent, its own included (queued ahead of it).
    queued: usize,
    sends: u32,
}

/// What a `Sack` meant to the sender.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SackEffect {
    /// It names another transfer (its CRC differs): the receiver lost our begin message.
    Foreign,
    /// Older than what we know (an answer from before a restart).
    Stale,
    /// Taken into account; `advanced` when `next_offset` moved.
    Applied {
        /// `next_offset` moved.
        advanced: bool,
        /// Transmissions it proved lost.
        lost: usize,
    },
}

/// A chunk to send.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Chunk {
    /// Image offset.
    pub offset: u32,
    /// Bytes.
    pub len: u32,
    /// Sent before.
    pub resend: bool,
}

/// Sender state of one windowed transfer of `total` bytes named by `crc`.
#[derive(Debug, Clone)]
pub(crate) struct WindowSender {
    total: u32,
    crc: u32,
    min_chunk: usize,
    max_chunk: usize,
    /// Bytes the sender keeps in flight at most (besides the receiver's window).
    max_flight: u32,
    /// Line rate, bytes per second (sizes the flight from the round trip).
    rate: f64,
    /// Shortest time seen from a data frame to the `Sack` that answers it.
    min_rtt: Option<Duration>,
    /// The latest round trip from a data frame to its `Sack`, with the wire bytes that were
    /// queued up to that frame, until [`Self::take_round_trip`].
    round_trip: Option<(Duration, usize)>,
    acked: u32,
    held: Vec<(u32, u32)>,
    window: u32,
    next_new: u32,
    /// Payload of the last new chunk sized.
    last_chunk: usize,
    flights: BTreeMap<u32, Flight>,
    lost: BTreeSet<u32>,
    /// Transmissions, all of them.
    pub frames_sent: u64,
    /// Of those, chunks sent again.
    pub frames_resent: u64,
    /// Image bytes sent again.
    pub bytes_resent: u64,
}

impl WindowSender {
    /// A transfer of `total` bytes (CRC `crc`) to a receiver with window `window`, in chunks of
    /// `min_chunk..=max_chunk` bytes, at most `max_flight` bytes in flight, over a line that
    /// carries `rate` bytes per second.
    pub(crate) fn new(
        total: u32,
        crc: u32,
        window: u16,
        (min_chunk, max_chunk): (usize, usize),
        max_flight: u32,
        rate: f64,
    ) -> Self {
        let max_chunk = max_chunk.max(1);
        Self {
            total,
            crc,
            min_chunk: min_chunk.clamp(1, max_chunk),
            max_chunk,
            max_flight: max_flight.max(1),
            rate: rate.max(1.0),
            min_rtt: None,
            round_trip: None,
            acked: 0,
            held: Vec::new(),
            window: u32::from(window.max(1)),
            next_new: 0,
            last_chunk: 0,
            flights: BTreeMap::new(),
            lost: BTreeSet::new(),
            frames_sent: 0,
            frames_resent: 0,
            bytes_resent: 0,
        }
    }

    /// Every byte below this offset has arrived.
    pub(crate) fn acked(&self) -> u32 {
        self.acked
    }

    /// The transfer's length.
    pub(crate) fn total(&self) -> u32 {
        self.total
    }

    /// The CRC-32 that names the transfer.
    pub(crate) fn crc(&self) -> u32 {
        self.crc
    }

    /// Payload of the last new chunk sized (0 before the first).
    pub(crate) fn last_chunk(&self) -> usize {
        self.last_chunk
    }

    /// True when every byte has arrived.
    pub(crate) fn complete(&self) -> bool {
        self.acked >= self.total
    }

    /// Bytes sent and not yet known to have arrived.
    pub(crate) fn in_flight(&self) -> u32 {
        self.flights.values().map(|f| f.len).sum()
    }

    /// Wire bytes of the transmissions not settled yet.
    pub(crate) fn unsettled_wire(&self) -> usize {
        self.flights.values().filter_map(|f| f.pending.map(|p| p.1)).sum()
    }

    /// Image bytes allowed in flight now: [`RTT_MARGIN`] round trips' worth at the line rate, at least
    /// three chunks of `chunk` bytes, but no more frames than make two holes on average at
    /// byte error rate `q` (the receiver holds four), at most `max_flight`.
    fn flight_limit(&self, chunk: usize, q: f64) -> u32 {
        let rtt = self.min_rtt.map_or(0.0, |d| d.as_secs_f64() * self.rate * RTT_MARGIN) as u32;
        let loss = 1.0 - arrival(wire_len(DATA_HEAD + chunk), q);
        let frames = if loss > 0.0 { (2.0 / loss).clamp(2.0, 1e6) as u32 } else { u32::MAX / 4 / chunk.max(1) as u32 };
        rtt.max(3 * chunk as u32).min(frames.saturating_mul(chunk as u32)).min(self.max_flight)
    }

    /// The chunk size for new data at the estimated byte error rate.
    pub(crate) fn chunk_size(&self, est: &mut LossEstimator) -> usize {
        // A receiver whose window is one chunk or less takes one frame at a time (its UART
        // holds less than arrives while it parses a frame): every frame fills the window,
        // so that the next goes only after its `Sack`.
        if self.window as usize <= self.max_chunk {
            return self.window.max(1) as usize;
        }
        if est.samples() < 4 {
            return FIRST_CHUNK.clamp(self.min_chunk, self.max_chunk);
        }
        best_payload(DATA_HEAD, est.byte_error_rate(), self.min_chunk, self.max_chunk)
    }

    /// The next chunk to send: a lost one again, else new data inside the receiver's window
    /// and the flight limit; `None` when nothing may go now.
    pub(crate) fn next(&mut self, est: &mut LossEstimator) -> Option<Chunk> {
        if let Some(offset) = self.lost.pop_first() {
            if let Some(f) = self.flights.get(&offset).copied() {
                // A chunk sized for a better line than the one measured now goes again in
                // pieces of the current size (a receiver takes any byte range).
                let n = self.chunk_size(est) as u32;
                if f.len > n {
                    self.flights.remove(&offset);
                    let mut at = offset;
                    while at < offset + f.len {
                        let len = n.min(offset + f.len - at);
                        self.flights.insert(at, Flight { len, pending: None, queued: 0, sends: f.sends });
                        self.lost.insert(at);
                        at += len;
                    }
                    self.lost.remove(&offset);
                    return Some(Chunk { offset, len: n, resend: true });
                }
                return Some(Chunk { offset, len: f.len, resend: true });
            }
        }
        if self.next_new >= self.total {
            return None;
        }
        self.last_chunk = self.chunk_size(est);
        let q = est.byte_error_rate();
        let room = self.flight_limit(self.last_chunk, q).saturating_sub(self.in_flight());
        let limit = (self.acked as u64 + self.window as u64).min(self.total as u64) as u32;
        // A window smaller than the chunk (a device that takes one frame at a time) gets
        // chunks of its size; a larger one waits for room for a whole chunk.
        let n = (self.last_chunk as u32).min(self.total - self.next_new).min(self.window);
        let end = self.next_new + n;
        if end > limit || n > room {
            return None;
        }
        Some(Chunk { offset: self.next_new, len: n, resend: false })
    }

    /// `chunk` went out as the frame with sequence number `seq` of `wire` bytes.
    pub(crate) fn sent(&mut self, chunk: Chunk, seq: u16, wire: usize) {
        self.frames_sent += 1;
        if chunk.resend {
            self.frames_resent += 1;
            self.bytes_resent += chunk.len as u64;
        }
        let queued = self.unsettled_wire() + wire;
        let f =
            self.flights.entry(chunk.offset).or_insert(Flight { len: chunk.len, pending: None, queued: 0, sends: 0 });
        f.pending = Some((seq, wire, Instant::now()));
        f.queued = queued;
        f.sends += 1;
        self.next_new = self.next_new.max(chunk.offset + chunk.len);
    }

    fn covered(&self, offset: u32, len: u32) -> bool {
        let end = offset + len;
        end <= self.acked || self.held.iter().any(|&(s, e)| s <= offset.max(self.acked) && end <= e)
    }

    /// Takes a `Sack` into account: settles every transmission up to `heard` (arrived or lost,
    /// recorded in `est`) and queues the lost chunks for sending again.
    pub(crate) fn sack(&mut self, sack: &Sack, est: &mut LossEstimator) -> SackEffect {
        if sack.crc != self.crc {
            return SackEffect::Foreign;
        }
        if sack.next_offset < self.acked || sack.next_offset > self.total {
            return SackEffect::Stale;
        }
        let advanced = sack.next_offset > self.acked;
        self.acked = sack.next_offset;
        self.window = u32::from(sack.window.max(1));
        self.held = sack
            .ranges
            .as_slice()
            .iter()
            .map(|&(s, e)| (self.acked.saturating_add(s as u32), self.acked.saturating_add(e as u32)))
            .collect();
        let mut lost = 0;
        let offsets: Vec<u32> = self.flights.keys().copied().collect();
        for offset in offsets {
            let Some(f) = self.flights.get(&offset).copied() else { continue };
            if self.covered(offset, f.len) {
                if let Some((seq, wire, at)) = f.pending {
                    est.record(wire, true);
                    if seq == sack.heard {
                        let rtt = at.elapsed();
                        self.min_rtt = Some(self.min_rtt.map_or(rtt, |m| m.min(rtt)));
                        self.round_trip = Some((rtt, f.queued));
                    }
                }
                self.flights.remove(&offset);
                self.lost.remove(&offset);
                continue;
            }
            if let Some((seq, wire, _)) = f.pending {
                // Sent before (or as) the frame this answers, and not held: lost on the way.
                if sack.heard.wrapping_sub(seq) < 0x8000 {
                    est.record(wire, false);
                    lost += 1;
                    self.lost.insert(offset);
                    if let Some(f) = self.flights.get_mut(&offset) {
                        f.pending = None;
                    }
                }
            }
        }
        SackEffect::Applied { advanced, lost }
    }

    /// The latest round trip a `Sack` measured (time, wire bytes queued up to the frame it
    /// answers), once.
    pub(crate) fn take_round_trip(&mut self) -> Option<(Duration, usize)> {
        self.round_trip.take()
    }

    /// Forgets everything sent (the receiver lost the transfer): all bytes are new again.
    pub(crate) fn restart(&mut self, window: u16) {
        self.acked = 0;
        self.held.clear();
        self.next_new = 0;
        self.flights.clear();
        self.lost.clear();
        self.window = u32::from(window.max(1));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gridrt_shared::window::ReceiveWindow;
    use rand::{Rng, SeedableRng};

    fn data_wire_len(len: usize) -> usize {
        wire_len(DATA_HEAD + len)
    }

    /// Runs a transfer over a lossy FIFO to a real [`ReceiveWindow`]: every data frame is lost
    /// with probability `p`, every `Sack` with probability `p_ack`; probes when nothing is in
    /// the pipe. Returns (frames sent, resent, probes).
    fn transfer(total: u32, window: u16, p: f64, p_ack: f64, seed: u64) -> (u64, u64, u64) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut rx = ReceiveWindow::new(total, window);
        let mut tx = WindowSender::new(total, 7, window, (16, 2044), 8192, 11_520.0);
        let mut est = LossEstimator::default();
        let mut seq = 0u16;
        let mut probes = 0;
        // The pipe: frames sent, in order (None = a probe).
        let mut pipe: std::collections::VecDeque<(u16, Option<(u32, u32)>)> = Default::default();
        for _ in 0..1_000_000 {
            while let Some(c) = tx.next(&mut est) {
                seq = seq.wrapping_add(1);
                tx.sent(c, seq, data_wire_len(c.len as usize));
                pipe.push_back((seq, Some((c.offset, c.len))));
            }
            if tx.complete() {
                return (tx.frames_sent, tx.frames_resent, probes);
            }
            if pipe.is_empty() {
                // The tail: nothing left to reveal a loss but a probe.
                probes += 1;
                seq = seq.wrapping_add(1);
                pipe.push_back((seq, None));
            }
            let Some((s, frame)) = pipe.pop_front() else { continue };
            if rng.gen::<f64>() < p {
                continue;
            }
            if let Some((o, n)) = frame {
                rx.arrive(o, n);
            }
            if rng.gen::<f64>() >= p_ack {
                tx.sack(&rx.sack(s, 7), &mut est);
            }
        }
        panic!("transfer did not finish: {tx:?}");
    }

    #[test]
    fn the_flight_covers_four_shortest_round_trips_within_the_other_limits() {
        // 3 Mbaud, 300-byte chunks, the shortest round trip 3 ms (900 B of line): 3 600 B.
        let mut tx = WindowSender::new(1 << 20, 7, 16_384, (16, 2044), 8192, 300_000.0);
        tx.min_rtt = Some(Duration::from_millis(3));
        assert!(tx.flight_limit(300, 0.0).abs_diff(3600) <= 1, "{}", tx.flight_limit(300, 0.0));
        // Never under three chunks, never over the cap or two expected holes.
        assert_eq!(tx.flight_limit(2000, 0.0), 6000);
        tx.min_rtt = Some(Duration::from_millis(100));
        assert_eq!(tx.flight_limit(300, 0.0), 8192);
        assert!(tx.flight_limit(300, 1e-2) < 3600, "two holes at 1 % per byte");
    }

    /// A device that takes one frame at a time offers a window of at most one chunk: every
    /// frame fills the window, one frame is in flight, and the transfer ends, on a clean
    /// line and a lossy one.
    #[test]
    fn a_window_of_one_chunk_gets_one_frame_at_a_time() {
        let (sent, resent, probes) = transfer(20_000, 300, 0.0, 0.0, 5);
        assert_eq!((resent, probes), (0, 0));
        assert_eq!(sent, 20_000u64.div_ceil(300), "one window per frame");
        let mut tx = WindowSender::new(20_000, 7, 300, (16, 2044), 8192, 11_520.0);
        let mut est = LossEstimator::default();
        let first = tx.next(&mut est).unwrap();
        tx.sent(first, 1, data_wire_len(first.len as usize));
        assert_eq!(first.len, 300);
        assert_eq!(tx.next(&mut est), None, "nothing more before its Sack");
        let (sent, resent, _) = transfer(20_000, 300, 0.1, 0.1, 6);
        assert!(resent > 0 && sent > 67, "{sent} frames, {resent} resent");
    }

    #[test]
    fn a_clean_line_sends_every_byte_once() {
        let (sent, resent, probes) = transfer(100_000, 4096, 0.0, 0.0, 1);
        assert_eq!((resent, probes), (0, 0));
        assert!(sent < 100_000 / 1000, "large chunks on a clean line: {sent} frames");
    }

    #[test]
    fn lossy_lines_finish_and_resend_about_what_was_lost() {
        for (i, p) in [0.01, 0.1, 0.3].into_iter().enumerate() {
            let (sent, resent, probes) = transfer(60_000, 4096, p, p, 10 + i as u64);
            let share = resent as f64 / sent as f64;
            // Each resend follows one loss; a lost Sack alone never causes a resend.
            assert!(share < 2.0 * p + 0.02, "p {p}: {resent} of {sent} resent");
            assert!(probes < 5 + (sent as f64 * p) as u64, "p {p}: {probes} probes");
        }
    }

    #[test]
    fn lost_acks_alone_cause_no_resend() {
        let (_, resent, _) = transfer(50_000, 4096, 0.0, 0.5, 3);
        assert_eq!(resent, 0);
    }

    #[test]
    fn a_sack_of_another_transfer_or_from_the_past_changes_nothing() {
        let mut tx = WindowSender::new(1000, 7, 4096, (16, 100), 4096, 11_520.0);
        let mut est = LossEstimator::default();
        let c = tx.next(&mut est).unwrap();
        tx.sent(c, 1, 100);
        let mut rx = ReceiveWindow::new(1000, 4096);
        rx.arrive(0, 100);
        assert_eq!(tx.sack(&rx.sack(1, 8), &mut est), SackEffect::Foreign);
        assert_eq!(tx.sack(&rx.sack(1, 7), &mut est), SackEffect::Applied { advanced: true, lost: 0 });
        let old = ReceiveWindow::new(1000, 4096).sack(0, 7);
        assert_eq!(tx.sack(&old, &mut est), SackEffect::Stale);
        assert_eq!(tx.acked(), 100);
    }
}
