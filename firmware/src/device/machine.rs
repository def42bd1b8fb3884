//! The device state machine: received frames are decoded and dispatched (`Hello`, scene
//! upload, render requests), every answer leaves as a frame, and every refusal or failure
//! as one `Msg::Error`. Scene storage, request checks, the ray path and the pixel pipeline
//! are the sibling modules this one drives.

use super::fail::{Fail, Text, Trunc, DETAIL_MSG_ERROR};
use super::farm::NoFarm;
use super::farm::RowFarm;
use super::pipeline;
use super::render::Renderer;
use super::request::{self, Target};
use super::scene::{Reorder, SceneStore, Upload, UPLOAD_WINDOW};
#[cfg(feature = "splats")]
use super::splat;
use super::stats::{cycles_between, FrameStats, NoClock, StageClock, StageStamp, UploadWork};
use crate::fsl::FslLink;
use crate::pixels::FrameTx;
#[cfg(feature = "splats")]
use crate::pixels::SpanEncoder;
#[cfg(feature = "splats")]
use crate::splat::SplatEngine;
use crate::text::TextOut;
use core::ops::ControlFlow;
use embedded_io::Write;
use gridrt_shared::frame::{FrameAccumulator, FrameError, Received, MAX_PAYLOAD};
use gridrt_shared::msg::{
    feature, render_flags, DeviceInfo, ErrorCode, Msg, MsgError, MsgType, RenderRequest, Sack, SackRanges, SceneStatus,
};

/// Feature bits of this build.
pub const fn compiled_features() -> u32 {
    let shadows = if cfg!(feature = "shadows") { feature::SHADOWS } else { 0 };
    shadows
        | feature::PRIM_IDS
        | feature::RENDER_REGION
        | feature::RGB565
        | feature::RLE
        | feature::WINDOWED
        | if cfg!(feature = "compact-scene") { feature::COMPACT_SCENE } else { 0 }
        | pipeline::pipeline_features()
}

/// Everything but the receive buffer (split so a received frame can borrow that buffer
/// while the handler mutates the rest).
struct Core<L, C, const N: usize, const P: usize, const T: usize, F> {
    render: Renderer<L, C, F>,
    info: DeviceInfo,
    tx: FrameTx,
    scene: SceneStore<N>,
    upload: Option<Upload>,
    /// `SceneData` bytes that arrived ahead of a gap.
    ahead: Reorder,
    /// (length, CRC) of the upload that loaded the current scene: a `SceneData` after the
    /// end is answered with its final `SceneSack` again (the host may have lost it).
    loaded_image: Option<(u32, u32)>,
    /// Answers held back until the input at hand is used up (SPEC.md §3.14): the `SceneSack`
    /// of the last `SceneData`, and a corrupt frame after it.
    held: Held,
    /// The cycles of the upload in progress (or the last one) so far.
    upload_work: UploadWork,
    /// When the last input batch of the upload in progress ended.
    upload_lap: Option<StageStamp>,
    /// An upload began in the batch at hand.
    upload_began: bool,
    /// The window the device offers in its `SceneSack`s ([`Device::set_upload_window`]).
    upload_window: u16,
    /// The point cloud, shape table and stage of `SPLATS` frames, and their span encoder.
    #[cfg(feature = "splats")]
    splat: SplatEngine<P, T>,
    #[cfg(feature = "splats")]
    splat_spans: SpanEncoder,
}

/// Answers one batch of input may share: one `SceneSack` for its data frames (naming the
/// last), one `Error{BadFrame}` for the corrupt frames after that one.
#[derive(Default)]
struct Held {
    sack: Option<(SceneStatus, Sack)>,
    bad: Option<FrameError>,
}

/// The device: feed it UART bytes, it answers through an [`embedded_io::Write`].
///
/// Output errors: a failed write is counted ([`write_errors`](Self::write_errors)) and
/// stops the frame it belonged to: nothing more is sent for that frame (no spans, `Stats`,
/// end message or `Error`, which would need the output that just failed). An answer outside
/// a frame whose write failed is lost. Either way the host, which waits for every answer,
/// times out and asks again.
///
/// `MAX_POINTS` and `TABLE_WORDS` size the splat path (SPEC.md §6): a device with either at
/// 0 (the default) has none and does not advertise `feature::SPLATS`.
///
/// A simulator may hand the rows of a frame to a [`RowFarm`] ([`Device::with_farm`]); the
/// firmware has none ([`NoFarm`]).
pub struct Device<
    L: FslLink,
    C: StageClock,
    const MAX_VOXELS: usize,
    const MAX_POINTS: usize = 0,
    const TABLE_WORDS: usize = 0,
    F: RowFarm<L> = NoFarm,
> {
    rx: FrameAccumulator,
    core: Core<L, C, MAX_VOXELS, MAX_POINTS, TABLE_WORDS, F>,
}

impl<L: FslLink, C: StageClock, const MAX_VOXELS: usize, const MAX_POINTS: usize, const TABLE_WORDS: usize>
    Device<L, C, MAX_VOXELS, MAX_POINTS, TABLE_WORDS>
{
    /// A device with no scene. `info` supplies firmware version, board, PE count and PE memory
    /// size (0 = unknown, not checked); protocol, max payload, voxel capacity (= MAX_VOXELS)
    /// and feature bits are filled in here.
    pub fn new(link: L, clock: C, info: DeviceInfo) -> Self {
        Device::build(link, clock, info, NoFarm)
    }
}

impl<L: FslLink, const MAX_VOXELS: usize, const MAX_POINTS: usize, const TABLE_WORDS: usize, F: RowFarm<L>>
    Device<L, NoClock, MAX_VOXELS, MAX_POINTS, TABLE_WORDS, F>
{
    /// A device whose frames without row interpolation are traced by `farm` (when it takes
    /// them), sending the same bytes as [`Device::new`]'s. Only without stage clocks: a
    /// farm's rows are not timed.
    pub fn with_farm(link: L, info: DeviceInfo, farm: F) -> Self {
        Device::build(link, NoClock, info, farm)
    }
}

impl<
        L: FslLink,
        C: StageClock,
        const MAX_VOXELS: usize,
        const MAX_POINTS: usize,
        const TABLE_WORDS: usize,
        F: RowFarm<L>,
    > Device<L, C, MAX_VOXELS, MAX_POINTS, TABLE_WORDS, F>
{
    /// A device with a farm and a clock: the frames the farm takes report only their whole
    /// (`frame_cycles`, `link_cycles`; the stages read 0, as the farm's rows are not timed),
    /// the others every stage. A board whose worker harts trace rows beside the device loop.
    #[inline(always)]
    pub fn with_clock_and_farm(link: L, clock: C, info: DeviceInfo, farm: F) -> Self {
        Device::build(link, clock, info, farm)
    }

    #[inline(always)]
    fn build(link: L, clock: C, info: DeviceInfo, farm: F) -> Self {
        let info = DeviceInfo {
            protocol: gridrt_shared::PROTOCOL_VERSION as u16,
            max_payload: MAX_PAYLOAD as u16,
            voxel_capacity: u32::try_from(MAX_VOXELS).unwrap_or(u32::MAX),
            // The board declares what its UART path can do (`REQUEST_QUEUE`); the stages are
            // the build's.
            features: compiled_features()
                | (info.features & feature::REQUEST_QUEUE)
                | if cfg!(feature = "splats") && MAX_POINTS > 0 && TABLE_WORDS > 0 { feature::SPLATS } else { 0 },
            ..info
        };
        Self {
            rx: FrameAccumulator::new(),
            core: Core {
                render: Renderer::new(link, clock, farm),
                info,
                tx: FrameTx::new(),
                scene: SceneStore::new(),
                upload: None,
                ahead: [0; UPLOAD_WINDOW],
                loaded_image: None,
                held: Held::default(),
                upload_work: UploadWork::default(),
                upload_lap: None,
                upload_began: false,
                upload_window: UPLOAD_WINDOW as u16,
                #[cfg(feature = "splats")]
                splat: SplatEngine::new(),
                #[cfg(feature = "splats")]
                splat_spans: SpanEncoder::new(),
            },
        }
    }

    /// Processes received bytes; every complete frame is handled before this returns (a
    /// render request renders the whole frame). Partial frames wait for the next call.
    /// Blocks as long as `out`'s `write_all` does for each answer. The `SceneData` frames of
    /// one call share one `SceneSack`, sent before this returns (SPEC.md §3.14).
    pub fn feed(&mut self, input: &[u8], out: &mut impl Write) {
        let core = &mut self.core;
        let start = core.render.clock().now();
        let uploading = core.upload.is_some();
        self.rx.feed_all(input, |received| {
            match received {
                Received::Frame(frame) => core.handle(frame.kind, frame.seq, frame.payload, out),
                Received::Bad(error) => core.bad_frame(error),
            }
            ControlFlow::<()>::Continue(())
        });
        core.flush(out);
        core.time_upload(start, uploading);
    }

    /// The boot banner (SPEC.md §3.12): a lone `0x00` (flushes whatever the host's receiver
    /// holds) and an unsolicited `Version`. Call once after every reset, before the first
    /// [`feed`](Self::feed); a host that sees it mid-session knows the device lost its scene.
    pub fn announce(&mut self, out: &mut impl Write) {
        // A failed write is counted (`write_errors`); the host, which waits for the banner,
        // asks again with `Hello`.
        let _ = self.core.tx.delimiter(out);
        let info = self.core.info;
        self.core.send(&Msg::Version(info), out);
    }

    /// The co-processor link.
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.core.render.path.link
    }

    /// The co-processor link.
    pub fn link(&self) -> &L {
        &self.core.render.path.link
    }

    /// What the device reports in `Msg::Version`.
    pub fn info(&self) -> &DeviceInfo {
        &self.core.info
    }

    /// True when a scene is loaded and renders are accepted.
    pub fn scene_loaded(&self) -> bool {
        self.core.scene.loaded
    }

    /// Counters of the last (or current, if it was aborted) frame.
    pub fn stats(&self) -> &FrameStats {
        &self.core.render.path.stats
    }

    /// Writes to the output that failed so far (saturating; see [`Device`] for what a
    /// failed write does).
    pub fn write_errors(&self) -> u32 {
        self.core.tx.write_errors()
    }

    /// Sets the window of the scene upload, the bytes past the last contiguous one a host may
    /// send before the next `SceneSack` (SPEC.md §3.14), from 1 to [`UPLOAD_WINDOW`] (the
    /// default). A board whose UART buffers fewer bytes than arrive while a data frame is
    /// parsed offers one frame's worth: the host then sends the next frame only after the
    /// `SceneSack` of the last, and no byte arrives while the device is busy. Applies from
    /// the next `SceneBegin`.
    pub fn set_upload_window(&mut self, bytes: u16) {
        self.core.upload_window = bytes.clamp(1, UPLOAD_WINDOW as u16);
    }

    /// Sets the poll budget of every blocking FSL put/get (default
    /// [`DEFAULT_POLLS`](super::raypath::DEFAULT_POLLS)).
    pub fn set_poll_budget(&mut self, polls: u32) {
        self.core.render.path.polls = polls;
    }
}

impl<L: FslLink, C: StageClock, const N: usize, const P: usize, const T: usize, F: RowFarm<L>> Core<L, C, N, P, T, F> {
    /// Sends the answers held back, in the order they belong: the `SceneSack`, then the
    /// report of a corrupt frame that came after its data frame.
    fn flush(&mut self, out: &mut impl Write) {
        if let Some((status, sack)) = self.held.sack.take() {
            let _ = self.tx.send(&Msg::SceneSack { status, sack }, out);
        }
        if let Some(e) = self.held.bad.take() {
            let mut t = Text::new();
            Trunc(&mut t).put("bad frame: ");
            Trunc(&mut t).put(e.as_str());
            let _ = self.tx.send(&Msg::Error { code: ErrorCode::BadFrame, detail: e.code(), text: t.as_str() }, out);
        }
    }

    fn send(&mut self, msg: &Msg<'_>, out: &mut impl Write) {
        self.flush(out);
        // Fails on a write error (counted by `tx`, see `Device::write_errors`) or a firmware
        // bug (message larger than a frame): nothing to report either with.
        let _ = self.tx.send(msg, out);
    }

    fn error(&mut self, code: ErrorCode, detail: u32, text: &str, out: &mut impl Write) {
        self.send(&Msg::Error { code, detail, text }, out);
    }

    /// Reports `f` with one `Msg::Error`, except an output failure (module docs of `fail`).
    fn abort(&mut self, f: Fail, out: &mut impl Write) {
        if let Fail::Output = f {
            return;
        }
        let (code, detail) = f.code_detail();
        let mut t = Text::new();
        f.describe(&mut t);
        self.error(code, detail, t.as_str(), out);
    }

    /// A corrupt frame: reported once this batch of input is used up (the last report wins).
    fn bad_frame(&mut self, e: FrameError) {
        self.held.bad = Some(e);
    }

    fn handle(&mut self, kind: u8, seq: u16, payload: &[u8], out: &mut impl Write) {
        if kind != MsgType::SceneData as u8 {
            // Everything else is answered in order, after what was held back.
            self.flush(out);
        }
        let msg = match Msg::decode(kind, payload) {
            Ok(m) => m,
            Err(MsgError::DecodeUnknownType) => {
                return self.error(ErrorCode::UnexpectedMessage, kind as u32, "unknown message type", out);
            }
            Err(e) => {
                let mut t = Text::new();
                let mut w = Trunc(&mut t);
                w.put("malformed payload of message ");
                w.put_hex(kind as u32, 2);
                w.put(": ");
                w.put(e.as_str());
                // SPEC.md §3.9: the detail of a payload that failed to decode names the
                // decoder's error, not the type (the text names the type).
                return self.error(ErrorCode::BadRequest, DETAIL_MSG_ERROR | e.code(), t.as_str(), out);
            }
        };
        match msg {
            Msg::Hello { .. } => {
                let info = self.info;
                self.send(&Msg::Version(info), out);
            }
            Msg::SceneBegin { total_len, crc } => {
                // A new upload invalidates the old scene (it will CLEAR the co-processor).
                self.scene.loaded = false;
                self.loaded_image = None;
                self.end_upload();
                self.upload = Some(Upload::new(total_len, crc, self.upload_window));
                self.upload_work = UploadWork::default();
                self.upload_lap = None;
                self.upload_began = true;
                self.render.upload = UploadWork::default();
            }
            Msg::SceneChunk { offset, data } => self.scene_data(MsgType::SceneChunk, seq, offset, data, out),
            Msg::SceneData { offset, data } => self.scene_data(MsgType::SceneData, seq, offset, data, out),
            Msg::RenderRequest(req) => self.render(&req, Target::Frame, out),
            Msg::RenderRegion { region, max_span, options, request } => {
                self.render(&request, Target::Region { region, max_span, options }, out)
            }
            // Never answer an Error with an Error (SPEC.md §1): a peer's report is dropped.
            Msg::Error { .. } => {}
            other => {
                let k = other.kind() as u8;
                self.error(ErrorCode::UnexpectedMessage, k as u32, "message not accepted by the device", out);
            }
        }
    }

    /// Adds the input batch that began at `start` (and, when an upload was in progress
    /// before it, the wait since the previous batch) to the upload's cycles.
    fn time_upload(&mut self, start: StageStamp, uploading: bool) {
        let began = core::mem::take(&mut self.upload_began);
        if !uploading && !began {
            return;
        }
        let now = self.render.clock().now();
        let w = &mut self.upload_work;
        if let Some(last) = self.upload_lap.take().filter(|_| uploading) {
            w.cycles = w.cycles.wrapping_add(cycles_between(last, start));
        }
        let batch = cycles_between(start, now);
        w.cycles = w.cycles.wrapping_add(batch);
        w.feed_cycles = w.feed_cycles.wrapping_add(batch);
        self.upload_lap = self.upload.is_some().then_some(now);
        self.render.upload = *w;
    }

    /// Drops the upload in progress, if any, first ending a LOAD_PE packet it left open.
    fn end_upload(&mut self) {
        if let Some(mut up) = self.upload.take() {
            up.close(&mut self.render.path.link, self.render.path.polls);
        }
    }

    /// `SceneChunk` (in order, answered with `SceneAck`) or `SceneData` (any order inside the
    /// window, answered with `SceneSack`, SPEC.md §3.14): the frame with sequence number `seq`.
    fn scene_data(&mut self, kind: MsgType, seq: u16, offset: u32, data: &[u8], out: &mut impl Write) {
        let windowed = kind == MsgType::SceneData;
        let Some(up) = self.upload.as_mut() else {
            if let (true, Some((total, crc)), true) = (windowed, self.loaded_image, self.scene.loaded) {
                // The upload is over: its last SceneSack again.
                let sack =
                    Sack { next_offset: total, heard: seq, window: self.upload_window, crc, ranges: SackRanges::new() };
                return self.send(&Msg::SceneSack { status: SceneStatus::Loaded, sack }, out);
            }
            let text = if windowed { "scene data without SceneBegin" } else { "scene chunk without SceneBegin" };
            return self.error(ErrorCode::UnexpectedMessage, kind as u32, text, out);
        };
        if !windowed && offset != up.next {
            let expected = up.next;
            return self.error(ErrorCode::BadOffset, expected, "scene chunk out of order", out);
        }
        let parse_start = self.render.clock().now();
        let path = &mut self.render.path;
        #[cfg(feature = "splats")]
        let points: &mut dyn crate::splat::PointSink = &mut self.splat;
        #[cfg(not(feature = "splats"))]
        let points: &mut dyn crate::splat::PointSink = &mut crate::splat::NoPoints;
        let received =
            up.receive(offset, data, &mut self.ahead, &mut path.link, path.polls, &mut self.scene, points, &self.info);
        let parsed = cycles_between(parse_start, self.render.clock().now());
        self.upload_work.parse_cycles = self.upload_work.parse_cycles.wrapping_add(parsed);
        if let Err((e, failure)) = received {
            self.end_upload();
            self.scene.loaded = false;
            let mut t = Text::new();
            Trunc(&mut t).put("scene rejected: ");
            Trunc(&mut t).put(e.as_str());
            if let Some(f) = failure {
                Trunc(&mut t).put("; ");
                f.describe(&mut t);
            }
            return self.error(ErrorCode::SceneRejected, e.code(), t.as_str(), out);
        }
        let (next, crc, total) = (up.next, up.crc, up.total_len());
        let sack = up.window.sack(seq, crc);
        let status = if up.complete() {
            let result = up.finish();
            self.end_upload();
            if let Err((e, text)) = result {
                return self.error(ErrorCode::SceneRejected, e.code(), text, out);
            }
            self.scene.fill_ahead();
            self.scene.loaded = true;
            self.loaded_image = Some((total, crc));
            SceneStatus::Loaded
        } else {
            SceneStatus::Receiving
        };
        if windowed {
            // Held back: the next data frame of this batch answers for both; a corrupt frame
            // before it is then reported by the Sack itself (it does not cover it).
            self.held = Held { sack: Some((status, sack)), bad: None };
        } else {
            self.send(&Msg::SceneAck { next_offset: next, status }, out);
        }
    }

    /// `RenderRequest` or `RenderRegion`: checks the request, renders, sends the spans, `Stats`
    /// and the end message (`FrameEnd` / `RegionEnd`), or one `Error` when it is refused or
    /// the frame fails.
    fn render(&mut self, req: &RenderRequest, target: Target, out: &mut impl Write) {
        let splats = req.flags & render_flags::SPLATS != 0;
        let result = request::job(self.scene.loaded, req, target).and_then(|job| {
            if splats {
                #[cfg(feature = "splats")]
                return splat::render(
                    &mut self.splat,
                    &self.scene,
                    self.render.clock(),
                    &mut self.splat_spans,
                    &mut self.tx,
                    &job,
                    out,
                );
                #[cfg(not(feature = "splats"))]
                return Err(super::fail::Fail::Plain(
                    ErrorCode::BadRequest,
                    6,
                    "this firmware was built without the splat path (feature `splats`)",
                ));
            } else {
                self.render.frame(&mut self.scene, &mut self.tx, &job, out)
            }
        });
        let (spans, crc) = match result {
            Ok(v) => v,
            Err(f) => return self.abort(f, out),
        };
        let end = match target {
            Target::Frame => Msg::FrameEnd { frame: req.frame, spans, image_crc: crc },
            Target::Region { region, .. } => Msg::RegionEnd { frame: req.frame, region, spans, crc },
        };
        self.send(&end, out);
    }
}
