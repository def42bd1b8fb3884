//! Windowed transfers (SPEC.md §3.14) over a session: the scene upload to a device and the
//! application image to a bootloader speak the same protocol, and this one loop drives both.
//!
//! 1. **Open**: a lone `0x00`, the begin message, then an empty data frame (a probe). The
//!    `Sack` that answers the probe — naming this transfer by its CRC — gives the receiver's
//!    window. No `Sack`, or one of another transfer, within the derived wait: open again.
//! 2. **Send** whatever [`WindowSender`] allows: chunks proved lost first, then new data
//!    inside the window, sized for the estimated error rate.
//! 3. **Receive** `Sack`s; each settles every transmission up to the frame it answers. A
//!    device NAK (`Error{BadFrame}`) when nothing new can be sent gets a probe at once; so
//!    does a line quiet for longer than the unsettled bytes take to cross it (the last
//!    resort). Each probe in a row without a `Sack` doubles the next wait;
//!    [`SessionConfig::max_probes`](super::SessionConfig::max_probes) of them end the
//!    transfer with a timeout naming what was last heard.
//! 4. **Done** when a `Sack` says `Loaded` / `Verified` at the image's length.
//!
//! A receiver that lost the transfer (it reset, or the begin message was lost: it answers
//! data with `Error{UnexpectedMessage}` / `FlashRejected{NotBegun}`) is opened again and the
//! transfer starts over.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use gridrt_shared::msg::{
    ErrorCode, FlashError, FlashStatus, Msg, MsgType, Sack, SceneStatus, MAX_SACK_RANGES, SACK_HEAD_LEN, SACK_RANGE_LEN,
};

use super::client::{Incoming, Session};
use super::config::MIN_CHUNK;
use super::error::{SessionError, Stage};
use super::estimate::wire_len;
use super::progress::{Activity, ProgressEvent};
use super::sender::{SackEffect, WindowSender, DATA_HEAD};

/// Wire bytes of the largest `Sack`.
const SACK_WIRE: usize = SACK_HEAD_LEN + MAX_SACK_RANGES * SACK_RANGE_LEN + 12;

/// Bytes the host keeps in flight at most, whatever window the receiver offers: a deeper
/// queue only delays the `Sack`s that reveal a loss.
const MAX_FLIGHT: u32 = 8192;

/// Doublings of a wait after unanswered probes, at most (×1024).
const MAX_BACKOFF: u32 = 10;

/// Progress events at least this often.
const TICK: Duration = Duration::from_secs(1);

/// Which transfer: the messages differ, the protocol does not.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Kind {
    /// `SceneBegin`, `SceneData`, `SceneSack` (done at `Loaded`).
    Scene,
    /// `FlashBegin`, `FlashData`, `FlashSack` (done at `Verified`).
    Flash,
}

impl Kind {
    fn stage(self) -> Stage {
        match self {
            Self::Scene => Stage::Upload,
            Self::Flash => Stage::Flash,
        }
    }

    fn data<'a>(self, offset: u32, data: &'a [u8]) -> Msg<'a> {
        match self {
            Self::Scene => Msg::SceneData { offset, data },
            Self::Flash => Msg::FlashData { offset, data },
        }
    }

    /// The `Sack` in `m`, and whether it says the transfer is complete.
    fn sack(self, m: &Incoming) -> Option<(Sack, bool)> {
        match (self, m) {
            (Self::Scene, Incoming::SceneSack { status, sack }) => Some((*sack, *status == SceneStatus::Loaded)),
            (Self::Flash, Incoming::FlashSack { status, sack }) => Some((*sack, *status == FlashStatus::Verified)),
            _ => None,
        }
    }

    /// True when `m` answers a request sent before this transfer, not the transfer: the
    /// device answers only render requests with `NoScene` (SPEC §3.12), which arrive late
    /// during the re-upload after a reset.
    fn late_answer(self, m: &Incoming) -> bool {
        matches!((self, m), (Self::Scene, Incoming::Error { code: ErrorCode::NoScene, .. }))
    }

    /// True when `m` says the receiver holds no transfer (begin lost, or it reset).
    fn lost_transfer(self, m: &Incoming) -> bool {
        match (self, m) {
            (Self::Scene, Incoming::Error { code: ErrorCode::UnexpectedMessage, detail, .. }) => {
                *detail == MsgType::SceneData as u32
            }
            (Self::Flash, Incoming::Error { code: ErrorCode::FlashRejected, detail, .. }) => {
                *detail == FlashError::NotBegun.code()
            }
            _ => false,
        }
    }
}

/// What a transfer did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct TransferReport {
    /// The CRC-32 of the final `Sack` (for a flash: read back from memory).
    pub crc: u32,
    /// Chunks sent again.
    pub resent: u64,
    /// Probes sent.
    pub probes: u64,
    /// Times the transfer was opened (1 = never restarted).
    pub opens: u32,
}

impl<T: Read + Write> Session<T> {
    /// Sends `image` (CRC-32 `crc`) as the windowed transfer `kind` that `begin` opens.
    pub(crate) fn send_windowed(
        &mut self,
        kind: Kind,
        begin: &Msg<'_>,
        image: &[u8],
        crc: u32,
        progress: &mut dyn FnMut(ProgressEvent),
    ) -> Result<TransferReport, SessionError> {
        let stage = kind.stage();
        let total = u32::try_from(image.len()).map_err(|_| SessionError::BadInput {
            port: self.cfg.port_name.clone(),
            stage,
            what: "image larger than 4 GiB".into(),
        })?;
        let device_cap =
            self.device.map_or(super::config::MAX_CHUNK, |d| (d.max_payload as usize).saturating_sub(DATA_HEAD));
        let max_chunk = self.cfg.chunk_size.min(super::config::MAX_CHUNK).min(device_cap).max(1);
        let start = Instant::now();
        let (tx0, rx0) = (self.bytes_tx, self.bytes_rx);
        let errors0 = self.line_errors();
        let mut report = TransferReport::default();
        let rate = self.cfg.baud as f64 / 10.0;
        let mut tx = WindowSender::new(total, crc, 1, (MIN_CHUNK, max_chunk), MAX_FLIGHT, rate);
        if let Some(crc) = self.reopen(kind, begin, &mut tx, &mut report)? {
            report.crc = crc;
            return Ok(report);
        }
        let mut last_event = Instant::now();
        let mut next_tick = Instant::now();
        let mut probes_in_row = 0u32;
        // When the receiver reported a corrupt frame that no later Sack has accounted for.
        let mut nak: Option<Instant> = None;
        loop {
            let nak_grace = self.answer_wait(wire_len(DATA_HEAD), SACK_WIRE);
            let mut sent_any = false;
            while let Some(c) = tx.next(&mut self.est_up) {
                let data = &image[c.offset as usize..(c.offset + c.len) as usize];
                let (seq, wire) = self.send(stage, &kind.data(c.offset, data))?;
                tx.sent(c, seq, wire);
                sent_any = true;
                last_event = Instant::now();
            }
            if sent_any {
                nak = None; // the Sack of what just left will tell
            }
            if nak.is_some_and(|at| at.elapsed() >= nak_grace) && !tx.complete() {
                // A frame was corrupt and no later Sack told which: ask.
                nak = None;
                self.probe(kind, &tx, &mut report)?;
                last_event = Instant::now();
            }
            if Instant::now() >= next_tick {
                next_tick = Instant::now() + TICK;
                let a = self.activity(stage, &tx, start, tx0, rx0, errors0);
                progress(ProgressEvent::Activity(a));
            }
            let probe_at = last_event
                + self.answer_wait(tx.unsettled_wire() + wire_len(DATA_HEAD), SACK_WIRE)
                    * (1 << probes_in_row.min(MAX_BACKOFF));
            let wake = nak.map_or(probe_at, |at| probe_at.min(at + nak_grace));
            let Some(m) = self.poll(stage, wake.min(next_tick))? else {
                if Instant::now() < probe_at {
                    continue; // a progress tick, or the end of a NAK's grace
                }
                probes_in_row += 1;
                self.link.timeouts += 1;
                if probes_in_row > self.cfg.max_probes {
                    return Err(self.timeout(
                        stage,
                        last_event.elapsed(),
                        format!("a Sack for offset {} of {total} ({probes_in_row} probes unanswered)", tx.acked()),
                    ));
                }
                self.probe(kind, &tx, &mut report)?;
                last_event = Instant::now();
                continue;
            };
            if let Some((sack, done)) = kind.sack(&m) {
                let before = tx.acked();
                let effect = tx.sack(&sack, &mut self.est_up);
                if let Some((rtt, queued)) = tx.take_round_trip() {
                    self.learn_round_trip(rtt, queued + SACK_WIRE);
                }
                match effect {
                    SackEffect::Applied { .. } => {
                        probes_in_row = 0;
                        nak = None;
                        last_event = Instant::now();
                        if tx.acked() > before {
                            progress(ProgressEvent::Uploaded { bytes: tx.acked() as u64, total: total as u64 });
                        }
                        if done && sack.next_offset == total {
                            report.resent = tx.frames_resent;
                            self.link.upload_chunks_resent += tx.frames_resent;
                            report.crc = sack.crc;
                            let a = self.activity(stage, &tx, start, tx0, rx0, errors0);
                            progress(ProgressEvent::Activity(a));
                            return Ok(report);
                        }
                    }
                    SackEffect::Foreign => {
                        // The receiver answers for another transfer: our begin was lost.
                        if let Some(crc) = self.reopen(kind, begin, &mut tx, &mut report)? {
                            report.crc = crc;
                            return Ok(report);
                        }
                        last_event = Instant::now();
                    }
                    SackEffect::Stale => {}
                }
                continue;
            }
            match m {
                Incoming::Error { code: ErrorCode::BadFrame, .. } => {
                    self.link.device_bad_frames += 1;
                    nak = Some(Instant::now());
                }
                m if kind.lost_transfer(&m) || matches!(m, Incoming::Version(_)) && self.last_rx_seq == Some(0) => {
                    if matches!(m, Incoming::Version(_)) {
                        // The receiver's reset banner: it forgot the transfer.
                        self.link.device_resets += 1;
                    }
                    if let Some(crc) = self.reopen(kind, begin, &mut tx, &mut report)? {
                        report.crc = crc;
                        return Ok(report);
                    }
                    last_event = Instant::now();
                }
                m if kind.late_answer(&m) => {}
                Incoming::Error { code, detail, text } => return Err(self.device_err(stage, code, detail, text)),
                _ => {} // late answers of earlier requests
            }
        }
    }

    /// Frames seen lost or corrupt so far, both directions.
    pub(crate) fn line_errors(&self) -> u64 {
        self.link.resyncs + self.link.device_bad_frames
    }

    fn activity(&self, stage: Stage, tx: &WindowSender, start: Instant, tx0: u64, rx0: u64, errors0: u64) -> Activity {
        Activity {
            stage,
            done: tx.acked() as u64,
            received: tx.acked() as u64,
            total: tx.total() as u64,
            wire_tx: self.bytes_tx - tx0,
            wire_rx: self.bytes_rx - rx0,
            elapsed: start.elapsed(),
            retransmits: tx.frames_resent,
            line_errors: self.line_errors() - errors0,
            chunk: tx.last_chunk(),
            last_heard: self.last_heard(),
        }
    }

    fn probe(&mut self, kind: Kind, tx: &WindowSender, report: &mut TransferReport) -> Result<(), SessionError> {
        report.probes += 1;
        self.link.probes += 1;
        self.send(kind.stage(), &kind.data(tx.acked(), &[]))?;
        Ok(())
    }

    /// Opens the transfer again from the start; `Some(crc)` when the receiver turns out to
    /// hold the whole image already.
    fn reopen(
        &mut self,
        kind: Kind,
        begin: &Msg<'_>,
        tx: &mut WindowSender,
        report: &mut TransferReport,
    ) -> Result<Option<u32>, SessionError> {
        let (window, done) = self.open_transfer(kind, begin, tx, report)?;
        tx.restart(window);
        Ok(done.map(|s| s.crc))
    }

    /// Opens the transfer (module docs, step 1); returns the receiver's window and, when the
    /// receiver already holds this very image (the begin message was lost on its way to a
    /// receiver that had completed the same transfer), the `Sack` that says so.
    fn open_transfer(
        &mut self,
        kind: Kind,
        begin: &Msg<'_>,
        tx: &WindowSender,
        report: &mut TransferReport,
    ) -> Result<(u16, Option<Sack>), SessionError> {
        let stage = kind.stage();
        let start = Instant::now();
        let begin_wire = wire_len(20); // FlashBegin; SceneBegin is shorter
        let exchange = begin_wire + 1 + wire_len(DATA_HEAD);
        // Every probe of this opening, and when it left: a slow receiver answers one after
        // the next has gone, and each follows a begin message of this same transfer.
        let mut probes: Vec<(u16, Instant)> = Vec::new();
        for attempt in 0..=self.cfg.max_probes {
            report.opens += 1;
            self.write_bytes(stage, &[0])?;
            self.send(stage, begin)?;
            let (probe_seq, _) = self.send(stage, &kind.data(0, &[]))?;
            probes.push((probe_seq, Instant::now()));
            // Each unanswered opening doubles the wait: a receiver slower than anything
            // measured so far (a simulated SoC) answers before the probes run out.
            let until = Instant::now() + self.answer_wait(exchange, 2 * SACK_WIRE) * (1 << attempt.min(MAX_BACKOFF));
            while let Some(m) = self.poll(stage, until)? {
                if let Some((sack, done)) = kind.sack(&m) {
                    // The answer to one of our probes, for our transfer: fresh (nothing held
                    // yet), or already complete (the receiver holds this very image).
                    let probe = probes.iter().find(|(seq, _)| *seq == sack.heard).map(|&(_, at)| at);
                    let ours = sack.crc == tx.crc() && probe.is_some();
                    if let Some(at) = probe {
                        self.learn_round_trip(at.elapsed(), exchange + SACK_WIRE);
                    }
                    if ours && sack.next_offset == 0 {
                        return Ok((sack.window, None));
                    }
                    if ours && done && sack.next_offset == tx.total() {
                        return Ok((sack.window, Some(sack)));
                    }
                    continue;
                }
                match m {
                    Incoming::Error { code: ErrorCode::BadFrame, .. } => self.link.device_bad_frames += 1,
                    m if kind.lost_transfer(&m) => {}
                    Incoming::Error { code: ErrorCode::UnexpectedMessage, .. } => {}
                    m if kind.late_answer(&m) => {}
                    Incoming::Error { code, detail, text } => return Err(self.device_err(stage, code, detail, text)),
                    _ => {}
                }
            }
            self.link.timeouts += 1;
        }
        Err(self.timeout(stage, start.elapsed(), "the receiver's Sack to an opening probe"))
    }
}
