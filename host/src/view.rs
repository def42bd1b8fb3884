//! `gridrt render --view`: a tiny HTTP server on 127.0.0.1 (std only, one thread) whose page
//! shows the frame filling in row by row as rows arrive, the last complete frame of the
//! stream, and the stream's figures (frame, fps, line utilisation, bytes). The page is one
//! file with inline script and style (no CDN, no network beyond this server).
//!
//! | path | what |
//! |---|---|
//! | `/` | the page (`view/page.html`) |
//! | `/state.json` | frame index, size, rows in, frames done, fps, line utilisation, wire bytes |
//! | `/live.rgba` | the frame being received, raw RGBA, row-major (rows not in yet: transparent); headers `X-Frame`, `X-Rows`, `X-Width`, `X-Height` from the same instant |
//! | `/last.rgba` | the last complete frame, raw RGBA; headers `X-Frame`, `X-Width`, `X-Height` (404 before the first) |
//!
//! The library only serves; the binary prints the URL.

use std::io::{self, BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use serde::Serialize;

/// The page.
pub const PAGE: &str = include_str!("view/page.html");

/// Figures of the stream shown beside the picture.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Figures {
    /// Frames complete.
    pub frames_done: u32,
    /// Frames in the stream.
    pub frames: u32,
    /// Frames per second so far.
    pub fps: f64,
    /// Bytes the boards sent ÷ what the lines could carry, so far.
    pub line_utilisation: f64,
    /// Wire bytes device → host so far.
    pub wire_rx: u64,
    /// Line rate.
    pub baud: u32,
    /// Time of the last frame, ms.
    pub last_frame_ms: f64,
    /// The stream ended.
    pub done: bool,
}

#[derive(Debug, Default)]
struct State {
    figures: Figures,
    /// Index of the frame being received.
    frame: u32,
    width: u16,
    height: u16,
    rows_in: u32,
    live: Vec<u8>,
    last: Option<(u32, u16, u16, Vec<u8>)>,
    /// Bumped on every change (the page polls it).
    version: u64,
}

#[derive(Serialize)]
struct StateJson<'a> {
    frame: u32,
    width: u16,
    height: u16,
    rows_in: u32,
    last: Option<u32>,
    version: u64,
    #[serde(flatten)]
    figures: &'a Figures,
}

/// The running server; dropping it stops the thread.
#[derive(Debug)]
pub struct View {
    addr: SocketAddr,
    state: Arc<Mutex<State>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

fn rgba(rgb: &[u8]) -> impl Iterator<Item = u8> + '_ {
    rgb.chunks_exact(3).flat_map(|p| [p[0], p[1], p[2], 255])
}

impl View {
    /// Serves on `127.0.0.1:port` (0: any free port).
    pub fn start(port: u16) -> io::Result<Self> {
        let listener = TcpListener::bind(("127.0.0.1", port))?;
        let addr = listener.local_addr()?;
        let state = Arc::new(Mutex::new(State::default()));
        let stop = Arc::new(AtomicBool::new(false));
        let (st, sp) = (state.clone(), stop.clone());
        let thread = std::thread::Builder::new().name("gridrt-view".into()).spawn(move || {
            for conn in listener.incoming() {
                if sp.load(Ordering::Relaxed) {
                    break;
                }
                if let Ok(c) = conn {
                    let _ = serve(c, &st);
                }
            }
        })?;
        Ok(Self { addr, state, stop, thread: Some(thread) })
    }

    /// The page's address.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Frame `index` of `of`, `width`×`height`, starts (the live picture is cleared).
    pub fn frame_started(&self, index: u32, of: u32, width: u16, height: u16) {
        let mut s = self.lock();
        s.frame = index;
        s.figures.frames = of;
        s.width = width;
        s.height = height;
        s.rows_in = 0;
        s.live = vec![0; 4 * width as usize * height as usize];
        s.version += 1;
    }

    /// Row `y` from column `x0` arrived: `rgb` (RGB8).
    pub fn row(&self, y: u16, x0: u16, rgb: &[u8]) {
        let mut s = self.lock();
        let w = s.width as usize;
        let start = 4 * (y as usize * w + x0 as usize);
        let n = (rgb.len() / 3).min(w.saturating_sub(x0 as usize));
        if let Some(dst) = s.live.get_mut(start..start + 4 * n) {
            for (d, v) in dst.iter_mut().zip(rgba(&rgb[..3 * n])) {
                *d = v;
            }
            s.rows_in += 1;
            s.version += 1;
        }
    }

    /// Frame `index` is complete: `rgb` (RGB8, `width`×`height`), with the stream's figures.
    pub fn frame_done(&self, index: u32, width: u16, height: u16, rgb: &[u8], figures: Figures) {
        let mut s = self.lock();
        s.last = Some((index, width, height, rgba(rgb).collect()));
        s.figures = figures;
        s.version += 1;
    }

    /// The stream ended (the page says so).
    pub fn finish(&self, figures: Figures) {
        let mut s = self.lock();
        s.figures = Figures { done: true, ..figures };
        s.version += 1;
    }
}

impl Drop for View {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        // Wake the accept loop.
        let _ = TcpStream::connect_timeout(&self.addr, Duration::from_millis(200));
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn respond(out: &mut TcpStream, status: &str, kind: &str, extra: &str, body: &[u8]) -> io::Result<()> {
    let head = format!(
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n{extra}Connection: close\r\n\r\n",
        body.len()
    );
    out.write_all(head.as_bytes())?;
    out.write_all(body)?;
    out.flush()
}

/// One request on `c` (GET only; the connection is closed after the answer).
fn serve(mut c: TcpStream, state: &Mutex<State>) -> io::Result<()> {
    c.set_read_timeout(Some(Duration::from_secs(2)))?;
    c.set_write_timeout(Some(Duration::from_secs(5)))?;
    let mut reader = BufReader::new(c.try_clone()?);
    let mut line = String::new();
    reader.read_line(&mut line)?;
    // The headers, up to the blank line.
    let mut h = String::new();
    while reader.read_line(&mut h)? > 2 {
        h.clear();
    }
    let path = line.split_whitespace().nth(1).unwrap_or("/");
    let path = path.split('?').next().unwrap_or("/");
    let s = state.lock().unwrap_or_else(|p| p.into_inner());
    match path {
        "/" | "/index.html" => {
            drop(s);
            respond(&mut c, "200 OK", "text/html; charset=utf-8", "", PAGE.as_bytes())
        }
        "/state.json" => {
            let j = StateJson {
                frame: s.frame,
                width: s.width,
                height: s.height,
                rows_in: s.rows_in,
                last: s.last.as_ref().map(|l| l.0),
                version: s.version,
                figures: &s.figures,
            };
            let body = serde_json::to_vec(&j).unwrap_or_default();
            drop(s);
            respond(&mut c, "200 OK", "application/json", "", &body)
        }
        "/live.rgba" => {
            let extra = format!(
                "X-Frame: {}\r\nX-Rows: {}\r\nX-Width: {}\r\nX-Height: {}\r\n",
                s.frame, s.rows_in, s.width, s.height
            );
            let body = s.live.clone();
            drop(s);
            respond(&mut c, "200 OK", "application/octet-stream", &extra, &body)
        }
        "/last.rgba" => match &s.last {
            Some((i, w, h, px)) => {
                let extra = format!("X-Frame: {i}\r\nX-Width: {w}\r\nX-Height: {h}\r\n");
                let body = px.clone();
                drop(s);
                respond(&mut c, "200 OK", "application/octet-stream", &extra, &body)
            }
            None => {
                drop(s);
                respond(&mut c, "404 Not Found", "text/plain", "", b"no frame yet\n")
            }
        },
        _ => {
            drop(s);
            respond(&mut c, "404 Not Found", "text/plain", "", b"not found\n")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    fn get(url: &str, path: &str) -> (String, Vec<u8>) {
        let addr = url.trim_start_matches("http://").trim_end_matches('/');
        let mut c = TcpStream::connect(addr).unwrap();
        write!(c, "GET {path} HTTP/1.1\r\nHost: x\r\n\r\n").unwrap();
        let mut all = Vec::new();
        c.read_to_end(&mut all).unwrap();
        let split = all.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
        (String::from_utf8_lossy(&all[..split]).into_owned(), all[split + 4..].to_vec())
    }

    #[test]
    fn rows_show_up_live_and_frames_when_done() {
        let v = View::start(0).unwrap();
        let url = v.url();
        let (head, page) = get(&url, "/");
        assert!(head.starts_with("HTTP/1.1 200") && page.starts_with(b"<!doctype html>"), "{head}");
        assert!(!String::from_utf8_lossy(&page).contains("://"), "the page must not load anything from elsewhere");
        assert!(get(&url, "/last.rgba").0.starts_with("HTTP/1.1 404"));
        v.frame_started(2, 5, 2, 2);
        v.row(1, 0, &[1, 2, 3, 4, 5, 6]);
        let (head, live) = get(&url, "/live.rgba");
        assert!(head.contains("X-Frame: 2") && head.contains("X-Rows: 1"), "{head}");
        assert_eq!(live, [0, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 255, 4, 5, 6, 255]);
        v.frame_done(2, 2, 1, &[9, 8, 7, 6, 5, 4], Figures { frames_done: 3, fps: 2.5, ..Default::default() });
        let (head, last) = get(&url, "/last.rgba");
        assert!(head.contains("X-Frame: 2") && head.contains("X-Height: 1"), "{head}");
        assert_eq!(last, [9, 8, 7, 255, 6, 5, 4, 255]);
        let j: serde_json::Value = serde_json::from_slice(&get(&url, "/state.json").1).unwrap();
        assert_eq!((j["frame"].as_u64(), j["last"].as_u64(), j["frames_done"].as_u64()), (Some(2), Some(2), Some(3)));
        assert_eq!(j["rows_in"].as_u64(), Some(1));
    }
}
