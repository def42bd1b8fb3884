//! `gridrt monitor`: what a board says on its own — its text (boot banner, trap and panic
//! reports) and its frames (the banner's `Version`, `Error` frames with their text) —
//! decoded and printed one line each, until Ctrl-C or `--timeout`.

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use gridrt_host::serial;
use gridrt_shared::frame::{FrameAccumulator, Received, MAX_ENCODED};
use gridrt_shared::msg::Msg;

/// Print what the board sends: its text lines and decoded frames (banner, errors).
///
/// Opens the port without sending anything, so it can sit beside a board that boots or
/// crashes and show why.
#[derive(Debug, clap::Parser)]
#[command(after_help = super::config::HELP)]
pub struct Cmd {
    /// Serial port of the board [default: GRIDRT_PORT, else `port` of gridrt.toml].
    #[arg(short = 'p', long, value_name = "PATH", env = "GRIDRT_PORT")]
    port: Option<String>,
    /// Baud rate [default: GRIDRT_BAUD, else `baud` of gridrt.toml, else 115200].
    #[arg(short = 'b', long, value_name = "BAUD", env = "GRIDRT_BAUD")]
    baud: Option<u32>,
    /// Stop after this many seconds (default: run until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    timeout: Option<f64>,
}

/// One thing heard on the line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Heard {
    /// A line of text.
    Text(String),
    /// A decoded frame, described.
    Frame(String),
    /// Bytes that were neither text nor a valid frame.
    Noise(String),
}

/// Splits the byte stream into text lines and frames.
#[derive(Debug)]
pub struct Decoder {
    acc: Box<FrameAccumulator<MAX_ENCODED>>,
    /// Bytes since the last `0x00` (text, or a frame in progress).
    segment: Vec<u8>,
}

impl Default for Decoder {
    fn default() -> Self {
        Self { acc: Box::new(FrameAccumulator::new()), segment: Vec::new() }
    }
}

fn is_text(b: u8) -> bool {
    b == b'\n' || b == b'\r' || b == b'\t' || (0x20..0x7f).contains(&b)
}

/// One line for a frame.
pub fn describe(kind: u8, seq: u16, payload: &[u8]) -> String {
    match Msg::decode(kind, payload) {
        Ok(Msg::Version(i)) => format!(
            "version    firmware {}.{}.{} on board {} ({}), protocol {}, {} PEs × {} words, up to {} voxels (seq {seq})",
            i.firmware[0],
            i.firmware[1],
            i.firmware[2],
            i.board,
            super::render::board_name(i.board),
            i.protocol,
            i.pe_count,
            i.pe_mem_words,
            i.voxel_capacity
        ),
        Ok(Msg::Error { code, detail, text }) => format!("error      {code:?} (detail {detail}): {text} (seq {seq})"),
        Ok(m) => format!("frame      {:?} (seq {seq}, {} B)", m.kind(), payload.len()),
        Err(e) => format!("frame      type {kind:#04x} (seq {seq}, {} B) not decoded: {e}", payload.len()),
    }
}

impl Decoder {
    /// Feeds bytes; returns what they complete.
    pub fn feed(&mut self, bytes: &[u8]) -> Vec<Heard> {
        let mut out = Vec::new();
        for &b in bytes {
            if b == 0 {
                let segment = std::mem::take(&mut self.segment);
                let mut got = None;
                self.acc.feed_all(&[0], |r| {
                    got = Some(match r {
                        Received::Frame(f) => Heard::Frame(describe(f.kind, f.seq, f.payload)),
                        Received::Bad(e) => Heard::Noise(format!("{} bytes that are not a frame ({e})", segment.len())),
                    });
                    std::ops::ControlFlow::<()>::Continue(())
                });
                match got {
                    Some(Heard::Noise(_)) if !segment.is_empty() && segment.iter().all(|&b| is_text(b)) => {
                        out.extend(text_lines(&segment))
                    }
                    Some(h) => out.push(h),
                    None => {}
                }
                continue;
            }
            self.acc.feed_all(&[b], |_| std::ops::ControlFlow::<()>::Continue(()));
            self.segment.push(b);
            // Text ends at a line break; a frame only at 0x00.
            if b == b'\n' && self.segment.iter().all(|&b| is_text(b)) {
                out.extend(text_lines(&std::mem::take(&mut self.segment)));
                self.acc.reset();
            }
        }
        out
    }
}

fn text_lines(bytes: &[u8]) -> Vec<Heard> {
    String::from_utf8_lossy(bytes)
        .lines()
        .map(|l| l.trim_end_matches('\r'))
        .filter(|l| !l.trim().is_empty())
        .map(|l| Heard::Text(l.to_string()))
        .collect()
}

impl Cmd {
    /// Runs the command.
    pub fn run(self) -> anyhow::Result<()> {
        let config = super::config::load()?;
        let Some(port_name) = self.port.clone().or(config.port) else {
            anyhow::bail!("no board given: use --port PATH (or GRIDRT_PORT, or `port` in gridrt.toml)");
        };
        let baud = self.baud.or(config.baud).unwrap_or(super::common::DEFAULT_BAUD);
        super::common::check_port_exists(&port_name)?;
        let mut port = serial::open(&port_name, baud, Duration::from_millis(100))?;
        let deadline = self.timeout.map(|s| Instant::now() + Duration::from_secs_f64(s.max(0.0)));
        eprintln!(
            "monitor    {port_name} at {baud} baud; {}",
            match self.timeout {
                Some(s) => format!("for {s} s"),
                None => "Ctrl-C to stop".into(),
            }
        );
        let mut decoder = Decoder::default();
        let mut buf = [0u8; 4096];
        let mut stdout = std::io::stdout();
        while deadline.is_none_or(|d| Instant::now() < d) {
            let n = match port.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => n,
                Err(e) if e.kind() == ErrorKind::TimedOut || e.kind() == ErrorKind::Interrupted => continue,
                Err(e) if e.kind() == ErrorKind::UnexpectedEof || e.raw_os_error() == Some(5) => break,
                Err(e) => return Err(anyhow::Error::new(e).context(format!("reading {port_name}"))),
            };
            for h in decoder.feed(&buf[..n]) {
                let line = match h {
                    Heard::Text(t) => format!("text       {t}"),
                    Heard::Frame(f) => f,
                    Heard::Noise(n) => format!("noise      {n}"),
                };
                writeln!(stdout, "{line}")?;
            }
            stdout.flush()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gridrt_shared::frame::encode_frame;
    use gridrt_shared::msg::{ErrorCode, MsgType};

    #[test]
    fn text_lines_and_error_frames_are_told_apart() {
        let mut payload = [0u8; 256];
        let msg = Msg::Error { code: ErrorCode::UnexpectedMessage, detail: 7, text: "no scene loaded" };
        let n = msg.encode(&mut payload).unwrap();
        let mut wire = vec![0u8; MAX_ENCODED];
        let m = encode_frame(MsgType::Error as u8, 3, &payload[..n], &mut wire).unwrap();
        let mut bytes = b"gridrt firmware 0.1.0\r\nready\n".to_vec();
        bytes.extend_from_slice(&wire[..m]);
        let mut d = Decoder::default();
        // Byte by byte: a line or a frame may arrive in pieces.
        let heard: Vec<Heard> = bytes.chunks(3).flat_map(|c| d.feed(c)).collect();
        assert_eq!(heard[0], Heard::Text("gridrt firmware 0.1.0".into()));
        assert_eq!(heard[1], Heard::Text("ready".into()));
        match &heard[2] {
            Heard::Frame(f) => assert!(f.contains("UnexpectedMessage") && f.contains("no scene loaded"), "{f}"),
            h => panic!("{h:?}"),
        }
        assert_eq!(heard.len(), 3, "{heard:?}");
    }
}
