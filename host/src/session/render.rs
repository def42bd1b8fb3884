//! One frame with a single `RenderRequest` (devices without `RenderRegion`), and the frame a
//! render returns.

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::time::{Duration, Instant};

use gridrt_shared::frame::crc32;
use gridrt_shared::msg::{feature, render_flags, Msg, PixelEncoding, RenderRequest};

use super::canvas::decode_colour;
use super::client::{Incoming, Session};
use super::error::{SessionError, Stage};
use super::link::LinkStats;
use super::progress::ProgressEvent;

/// A received frame.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderedFrame {
    /// Frame id.
    pub frame: u16,
    /// Width in pixels.
    pub width: u16,
    /// Height in pixels.
    pub height: u16,
    /// RGB8 row-major.
    pub rgb: Vec<u8>,
    /// Primitive id per pixel (`u32::MAX` = miss), when requested with `PRIM_IDS`.
    pub prim_ids: Option<Vec<u32>>,
    /// Device counters by key ([`gridrt_shared::msg::stat`]).
    pub stats: BTreeMap<u8, u64>,
    /// CRC-32 of the image (verified).
    pub image_crc: u32,
    /// Span count the device reported in `FrameEnd`.
    pub spans_reported: u32,
    /// Spans received (both encodings).
    pub spans_received: u32,
    /// Bytes sent during the render (request included).
    pub bytes_tx: u64,
    /// Bytes received during the render.
    pub bytes_rx: u64,
    /// From sending the request to `FrameEnd`.
    pub elapsed: Duration,
    /// Retransmissions and line errors during the render.
    pub link: LinkStats,
}

impl<T: Read + Write> Session<T> {
    /// Requests one frame and assembles it.
    pub fn render(
        &mut self,
        req: &RenderRequest,
        progress: &mut dyn FnMut(ProgressEvent),
    ) -> Result<RenderedFrame, SessionError> {
        let stage = Stage::Render;
        let (w, h) = (req.width as usize, req.height as usize);
        if w == 0 || h == 0 {
            return Err(SessionError::BadInput {
                port: self.cfg.port_name.clone(),
                stage,
                what: "image size is zero".into(),
            });
        }
        let features = self.device.map_or(0, |d| d.features);
        if req.encoding.feature_bit() & !features != 0 {
            return Err(SessionError::BadInput {
                port: self.cfg.port_name.clone(),
                stage,
                what: format!("the device does not send {:?} spans (features {features:#x})", req.encoding),
            });
        }
        if self.cfg.regions && features & feature::RENDER_REGION != 0 {
            return self.render_regions(req, progress);
        }
        let want_ids = req.flags & render_flags::PRIM_IDS != 0;
        let (tx0, rx0) = (self.bytes_tx, self.bytes_rx);
        let link0 = self.link.clone();
        let start = Instant::now();
        self.send(stage, &Msg::RenderRequest(*req))?;
        progress(ProgressEvent::RenderStarted { width: req.width, height: req.height });

        let mut rgb = vec![0u8; 3 * w * h];
        let mut got_rgb = vec![false; w * h];
        let mut ids = if want_ids { Some(vec![u32::MAX; w * h]) } else { None };
        let mut got_ids = vec![false; if want_ids { w * h } else { 0 }];
        let mut row_left = vec![if want_ids { 2 * w } else { w }; h];
        let mut rows_done = 0u32;
        let mut stats = BTreeMap::new();
        let mut spans_received = 0u32;
        let mut last_msg = Instant::now();
        loop {
            let Some(m) = self.poll(stage, last_msg + self.cfg.render_timeout)? else {
                return Err(self.timeout(stage, last_msg.elapsed(), format!("the next span of frame {}", req.frame)));
            };
            last_msg = Instant::now();
            match m {
                Incoming::PixelSpan { frame, y, x0, count, encoding, data } => {
                    if frame != req.frame {
                        continue; // stale span of an earlier frame
                    }
                    let (y, x0, count) = (y as usize, x0 as usize, count as usize);
                    if y >= h || x0 + count > w {
                        return Err(
                            self.protocol(stage, format!("span y {y} x {x0}+{count} outside the {w}×{h} image"))
                        );
                    }
                    spans_received += 1;
                    let base = y * w + x0;
                    let newly = match encoding {
                        PixelEncoding::Rgb888 | PixelEncoding::Rgb565 | PixelEncoding::Rle => {
                            decode_colour(encoding, count, &data, &mut rgb[3 * base..3 * (base + count)])
                                .map_err(|w| self.protocol(stage, w))?;
                            got_rgb[base..base + count]
                                .iter_mut()
                                .map(|g| !std::mem::replace(g, true))
                                .filter(|&n| n)
                                .count()
                        }
                        PixelEncoding::PrimId32 => match ids.as_mut() {
                            Some(ids) => {
                                for (k, c) in data.chunks_exact(4).enumerate() {
                                    ids[base + k] = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                                }
                                got_ids[base..base + count]
                                    .iter_mut()
                                    .map(|g| !std::mem::replace(g, true))
                                    .filter(|&n| n)
                                    .count()
                            }
                            None => 0,
                        },
                        #[allow(unreachable_patterns)]
                        _ => return Err(self.protocol(stage, format!("unsupported pixel encoding {encoding:?}"))),
                    };
                    if newly > 0 {
                        row_left[y] -= newly;
                        if row_left[y] == 0 {
                            rows_done += 1;
                            let row = rgb[3 * y * w..3 * (y + 1) * w].to_vec();
                            progress(ProgressEvent::RowArrived { y: y as u16, x0: 0, rgb: row });
                            progress(ProgressEvent::RowReceived { y: y as u16, rows_done });
                        }
                    }
                }
                Incoming::Stats { frame, entries } if frame == req.frame => {
                    stats.extend(entries);
                }
                Incoming::FrameEnd { frame, spans, image_crc } if frame == req.frame => {
                    if let Some(i) = got_rgb.iter().position(|g| !g) {
                        return Err(SessionError::MissingPixels {
                            port: self.cfg.port_name.clone(),
                            frame,
                            what: "pixels",
                            missing: got_rgb.iter().filter(|g| !**g).count() as u64,
                            first_x: (i % w) as u16,
                            first_y: (i / w) as u16,
                        });
                    }
                    if let Some(i) = got_ids.iter().position(|g| !g) {
                        return Err(SessionError::MissingPixels {
                            port: self.cfg.port_name.clone(),
                            frame,
                            what: "primitive ids",
                            missing: got_ids.iter().filter(|g| !**g).count() as u64,
                            first_x: (i % w) as u16,
                            first_y: (i / w) as u16,
                        });
                    }
                    let received = crc32(&rgb);
                    if received != image_crc {
                        return Err(SessionError::ImageCrc {
                            port: self.cfg.port_name.clone(),
                            frame,
                            device: image_crc,
                            received,
                        });
                    }
                    progress(ProgressEvent::Finished);
                    return Ok(RenderedFrame {
                        frame,
                        width: req.width,
                        height: req.height,
                        rgb,
                        prim_ids: ids,
                        stats,
                        image_crc,
                        spans_reported: spans,
                        spans_received,
                        bytes_tx: self.bytes_tx - tx0,
                        bytes_rx: self.bytes_rx - rx0,
                        elapsed: start.elapsed(),
                        link: self.link.since(&link0),
                    });
                }
                Incoming::Error { code, detail, text } => return Err(self.device_err(stage, code, detail, text)),
                _ => {}
            }
        }
    }
}
