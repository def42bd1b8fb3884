//! `gridrt render`: load a scene, build its grid, upload it, render one frame, write a PNG
//! and statistics, optionally compare with the f64 reference renderer.

use std::io::{Read, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use gridrt_host::compare::compare;
use gridrt_host::grid::GridParams;
use gridrt_host::multi::DeviceShare;
use gridrt_host::plan::{Interp, Plan};
use gridrt_host::reference::{self, Reference, Stages};
use gridrt_host::scene::Scene;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::{RenderedFrame, Session, SessionConfig};
use gridrt_host::stats::{
    CoprocFacts, LinkReport, PeCacheReport, PipelineStats, ReferenceStats, RenderStats, SceneFacts,
};
use gridrt_shared::msg::PixelEncoding;

use super::common::{ModelOptions, PortOptions, SceneOptions};
use super::progress::CliProgress;

/// Transport read timeout: short, so the session's own stage timeouts stay responsive.
const PORT_READ_TIMEOUT: Duration = Duration::from_millis(50);

/// Render one frame and write it as a PNG.
///
/// With --sim the scene image is built here, a loopback simulator is started in-process, and
/// everything (hello, upload, render) goes through its UART byte stream, exactly as with a
/// board. With --reference the same frame is also rendered by the independent f64 reference
/// renderer and compared (PSNR, differing pixels, primary-hit mismatches).
#[derive(Debug, clap::Parser)]
pub struct Cmd {
    #[clap(flatten)]
    pub(crate) port: PortOptions,
    #[clap(flatten)]
    pub(super) scene: SceneOptions,
    #[clap(flatten)]
    pub(super) model: ModelOptions,
    /// Image width in pixels, 1..=4096 [default: the scene file's camera, else 320].
    #[arg(short = 'W', long, value_name = "PX", help_heading = "Frame", value_parser = image_dim)]
    pub(super) width: Option<u16>,
    /// Image height in pixels, 1..=4096 [default: the scene file's camera, else 240].
    #[arg(short = 'H', long, value_name = "PX", help_heading = "Frame", value_parser = image_dim)]
    pub(super) height: Option<u16>,
    /// Do not trace shadow rays.
    #[arg(long, help_heading = "Frame")]
    no_shadows: bool,
    /// Row interpolation: trace every (l+1)-th pixel of a row, fill between two
    /// traced pixels when their colours differ by less than EPS (8-bit levels) and they hit the
    /// same primitive at a close depth, else refine through the centre pixel. `l,EPS` (fixed
    /// step) or `l,EPS,adaptive`; l in 1..=15, EPS in 0..=31. BENCHMARKS.md recommends 3,8.
    #[arg(long, value_name = "l,EPS", value_parser = Interp::parse, help_heading = "Frame")]
    interp: Option<Interp>,
    /// Run every pipeline stage even when the scene does not need it (no skipping; for
    /// comparisons).
    #[arg(long, help_heading = "Frame")]
    no_skip: bool,
    /// Pixel encoding on the serial line: `rle` is lossless and several times smaller on
    /// typical frames than `rgb888`; `rgb565` is lossy.
    #[arg(long, value_enum, default_value_t = Encoding::Rle, help_heading = "Link")]
    pub(super) encoding: Encoding,
    /// Rows per request (0 = the whole frame on one board; about eight bands per board
    /// with several boards). Smaller bands cost less when a device resets.
    #[arg(long, default_value_t = 0, value_name = "ROWS", help_heading = "Link")]
    pub(super) band_rows: u16,
    /// Output image (PNG). Not with --out-dir.
    #[arg(
        short = 'o',
        long,
        value_name = "PNG",
        help_heading = "Output",
        required_unless_present = "out_dir",
        conflicts_with = "out_dir"
    )]
    pub(super) out: Option<PathBuf>,
    /// Render a stream of frames into DIR: `frame-0000.png`, `frame-0001.png`, … (created;
    /// must take new files). --stats then holds one object per frame (`frames`: frame time,
    /// wire bytes, fps) and the stream's `fps` and `line_utilisation`.
    #[arg(long, value_name = "DIR", help_heading = "Stream")]
    pub(super) out_dir: Option<PathBuf>,
    /// Frames of the stream, 1..=100000 [default: 1]. The camera follows --orbit, else the
    /// scene file's `[[camera_path]]` keyframes (docs/SCENE-FILE.md), else stays.
    #[arg(long, value_name = "N", help_heading = "Stream", requires = "out_dir", value_parser = frame_count)]
    pub(super) frames: Option<u32>,
    /// Turn the camera DEGREES about the vertical axis through the scene's centre over the
    /// stream: frame i at i × DEGREES / N (360: a full turn, no frame twice). -3600..=3600.
    #[arg(long, value_name = "DEGREES", help_heading = "Stream", requires = "out_dir", allow_negative_numbers = true, value_parser = orbit_degrees)]
    pub(super) orbit: Option<f64>,
    /// Serve a live view on http://127.0.0.1:PORT/ (PORT 0 or none: any free port; the URL
    /// is printed): the frame filling in row by row, the last complete frame, fps and link
    /// figures. No internet needed.
    #[arg(long, value_name = "PORT", help_heading = "Stream", requires = "out_dir", num_args = 0..=1, default_missing_value = "0")]
    pub(super) view: Option<u16>,
    /// Keep serving --view this many seconds after the stream ends (0..=3600).
    #[arg(long, value_name = "SECS", default_value_t = 0.0, help_heading = "Stream", requires = "view", value_parser = linger_secs)]
    pub(super) view_linger: f64,
    /// Also write the stream as one animated PNG (APNG) to FILE, looping, every frame shown
    /// 1 / --apng-fps s. Checked before anything is rendered, like --out.
    #[arg(long, value_name = "FILE", help_heading = "Stream", requires = "out_dir")]
    pub(super) apng: Option<PathBuf>,
    /// Frames a second of --apng, 0.01..=1000 [default: the stream's measured fps].
    #[arg(long, value_name = "FPS", help_heading = "Stream", requires = "apng", value_parser = apng_fps)]
    pub(super) apng_fps: Option<f64>,
    /// Write statistics as JSON here.
    #[arg(long, value_name = "JSON", help_heading = "Output")]
    pub(super) stats: Option<PathBuf>,
    /// Also render with the f64 reference renderer and compare (asks the device for
    /// primitive ids too).
    #[arg(long, help_heading = "Output")]
    pub(super) reference: bool,
    /// Also write the reference image here (implies --reference).
    #[arg(long, value_name = "PNG", help_heading = "Output")]
    pub(super) reference_out: Option<PathBuf>,
    /// Render a mesh as a point cloud (splats): its vertices with averaged normals
    /// and radii from density. A PLY with vertices and no faces is a point cloud anyway.
    #[arg(long, help_heading = "Point clouds")]
    pub(super) points: bool,
    /// How several boards share a point cloud: `rows` (bands of rows from a shared queue) or
    /// `points` (sort-last: each board a random subset, composited by depth).
    #[arg(long, value_enum, default_value_t = Split::Rows, help_heading = "Point clouds")]
    pub(super) split: Split,
    /// Depth-test splats per pixel (each splat's plane) instead of one depth per splat.
    #[arg(long, help_heading = "Point clouds")]
    pub(super) pixel_depth: bool,
}

/// What [`Cmd::setup`] hands to the frame or the stream.
pub(super) struct Setup<T> {
    pub(super) sessions: Vec<Session<T>>,
    pub(super) prepared: PreparedScene,
    pub(super) plan: Plan,
    pub(super) settings: gridrt_host::render_settings::RenderSettings,
    pub(super) request: gridrt_shared::msg::RenderRequest,
    pub(super) upload_ms: f64,
    /// The scene's bytes on the wire, framing included (all boards).
    pub(super) upload_wire_bytes: u64,
}

/// `--frames`: 1..=[`gridrt_host::stream::MAX_FRAMES`].
fn frame_count(s: &str) -> Result<u32, String> {
    let max = gridrt_host::stream::MAX_FRAMES;
    match s.parse::<u64>() {
        Ok(v) if (1..=u64::from(max)).contains(&v) => Ok(v as u32),
        Ok(v) => Err(format!("{v} frames is not in 1..={max}")),
        Err(_) => Err(format!("`{s}` is not a number of frames")),
    }
}

/// `--orbit`: finite, -3600..=3600 degrees.
fn orbit_degrees(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v.abs() <= 3600.0 => Ok(v),
        Ok(v) => Err(format!("{v} degrees is not in -3600..=3600")),
        Err(_) => Err(format!("`{s}` is not a number of degrees")),
    }
}

/// `--view-linger`: 0..=3600 seconds.
fn linger_secs(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=3600.0).contains(&v) => Ok(v),
        Ok(v) => Err(format!("{v} s is not in 0..=3600")),
        Err(_) => Err(format!("`{s}` is not a number of seconds")),
    }
}

/// `--apng-fps`: 0.01..=1000 frames a second.
fn apng_fps(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.01..=1000.0).contains(&v) => Ok(v),
        Ok(v) => Err(format!("{v} fps is not in 0.01..=1000")),
        Err(_) => Err(format!("`{s}` is not a number of frames a second")),
    }
}

/// `--split` choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Split {
    /// Bands of rows.
    Rows,
    /// Random point subsets, composited by depth (sort-last).
    Points,
}

/// `--encoding` choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Encoding {
    /// 3 bytes per pixel.
    Rgb888,
    /// 2 bytes per pixel, lossy.
    Rgb565,
    /// Lossless run-length + delta code.
    Rle,
}

impl From<Encoding> for PixelEncoding {
    fn from(e: Encoding) -> Self {
        match e {
            Encoding::Rgb888 => PixelEncoding::Rgb888,
            Encoding::Rgb565 => PixelEncoding::Rgb565,
            Encoding::Rle => PixelEncoding::Rle,
        }
    }
}

impl Cmd {
    /// Runs the command.
    pub fn run(mut self) -> anyhow::Result<()> {
        // Everything that can be checked before a byte is sent: the connection, the
        // simulator's configuration, the outputs (their folders are made now, so a finished
        // frame is never lost to a missing folder), the ports, the scene and the frame size.
        if self.out_dir.is_none() {
            let stream_flag = [
                ("--frames", self.frames.is_some()),
                ("--orbit", self.orbit.is_some()),
                ("--view", self.view.is_some()),
                ("--apng", self.apng.is_some()),
            ];
            if let Some((flag, _)) = stream_flag.iter().find(|f| f.1) {
                bail!("{flag} is for a stream: give --out-dir DIR for its numbered PNGs (--out writes one frame)");
            }
        }
        self.port.resolve()?;
        if self.port.port.is_empty() {
            self.model.sim_config(self.scene.pes, self.scene.pe_mem_words)?;
        }
        if let Some(out) = &self.out {
            super::output::check_image(out, "--out")?;
        }
        if let Some(dir) = &self.out_dir {
            super::output::check_dir(dir, "--out-dir")?;
            if let Some(p) = &self.apng {
                super::output::check_file(p, "--apng")?;
            }
            if self.reference || self.reference_out.is_some() {
                bail!("--reference is for one frame (--out), not a stream (--out-dir)");
            }
            if self.points {
                bail!("--points renders one frame (--out), not a stream (--out-dir)");
            }
        }
        if let Some(path) = &self.stats {
            super::output::check_file(path, "--stats")?;
        }
        if let Some(path) = &self.reference_out {
            super::output::check_image(path, "--reference-out")?;
        }
        self.port.check_ports_exist()?;
        let input = gridrt_host::points::load(&self.scene.scene, self.points)
            .with_context(|| format!("loading scene {}", self.scene.scene.display()))?;
        let mesh = match input {
            gridrt_host::points::Input::Scene(s) => *s,
            gridrt_host::points::Input::Cloud(cloud) => return self.run_cloud(cloud),
        };
        self.check_stream(&mesh)?;
        let base = mesh.settings;
        check_size(self.width.unwrap_or(base.width), self.height.unwrap_or(base.height))?;
        if !self.port.port.is_empty() {
            self.run_on(self.open_ports()?, mesh, None)
        } else {
            let config = self.model.sim_config(self.scene.pes, self.scene.pe_mem_words)?;
            if config.backend == gridrt_loopback::Backend::Rtl {
                eprintln!("rtl        building or reusing the Verilator co-processor (cargo xtask rtl sim) …");
            }
            gridrt_loopback::prepare(&config).map_err(anyhow::Error::msg).context("the RTL co-processor")?;
            let ports = self.sim_ports(config);
            let caches = (config.pe_cache_lines != 0).then(|| CacheWatch {
                lines: config.pe_cache_lines,
                mem_latency: config.pe_mem_latency,
                probes: ports.iter().map(|(p, _)| p.pe_cache_probe()).collect(),
            });
            self.run_on_watched(ports, mesh, Some(ModelOptions::facts(&config)), caches)
        }
    }

    /// A point cloud: the same ports, the splat path (`render_points`).
    fn run_cloud(&self, cloud: gridrt_host::points::PointCloud) -> anyhow::Result<()> {
        if !self.port.port.is_empty() {
            return self.run_points(self.open_ports()?, cloud);
        }
        let config = self.model.sim_config(self.scene.pes, self.scene.pe_mem_words)?;
        gridrt_loopback::prepare(&config).map_err(anyhow::Error::msg).context("the RTL co-processor")?;
        self.run_points(self.sim_ports(config), cloud)
    }

    /// `--out` (present whenever --out-dir is not: clap enforces it).
    pub(super) fn out_path(&self) -> &std::path::Path {
        self.out.as_deref().unwrap_or(std::path::Path::new("frame.png"))
    }

    /// The serial ports of `--port`, opened at `--baud`.
    fn open_ports(&self) -> anyhow::Result<Vec<(Box<dyn serialport::SerialPort>, String)>> {
        let mut ports = Vec::new();
        for path in &self.port.port {
            let port = serialport::new(path, self.port.baud())
                .timeout(PORT_READ_TIMEOUT)
                .open()
                .with_context(|| format!("opening serial port {path}"))?;
            ports.push((port, path.clone()));
        }
        Ok(ports)
    }

    /// `--sim-devices` simulated boards (one by default), paced at `--baud` with `--sim-paced`.
    fn sim_ports(&self, config: gridrt_loopback::SimConfig) -> Vec<(gridrt_loopback::SimPort, String)> {
        let n = self.port.sim_devices.unwrap_or(1);
        (0..n)
            .map(|i| {
                let mut port = gridrt_loopback::spawn(config);
                port.set_timeout(PORT_READ_TIMEOUT);
                if self.port.sim_paced {
                    port.set_line_rate(Some(self.port.baud()));
                }
                (port, if n == 1 { "sim".to_string() } else { format!("sim{i}") })
            })
            .collect()
    }

    /// One session per port, with the line rate, turnaround, render timeout and band height
    /// of the command line.
    pub(super) fn sessions<T: Read + Write>(&self, ports: Vec<(T, String)>) -> Vec<Session<T>> {
        ports
            .into_iter()
            .map(|(port, name)| {
                let cfg = SessionConfig::new(name)
                    .baud(self.port.baud())
                    .turnaround(Duration::from_millis(self.port.turnaround))
                    .render_timeout(Duration::from_secs_f64(self.port.timeout.max(0.1)))
                    .band_rows(self.band_rows);
                Session::new(port, cfg)
            })
            .collect()
    }

    /// Everything before the first frame: hello (the boards must agree), the grid and scene
    /// image for the device's PEs, the upload (to every board at once), the request.
    fn setup<T: Read + Write + Send>(
        &self,
        ports: Vec<(T, String)>,
        loaded: Scene,
        progress: &mut CliProgress,
    ) -> anyhow::Result<Setup<T>> {
        let mut sessions = self.sessions(ports);
        let mut on_event = |e| progress.handle(e);

        // Hello: the devices tell us their PEs and memories (they must agree).
        let mut info = None;
        for s in &mut sessions {
            let name = s.config().port_name.clone();
            let i = s.hello(&mut on_event).with_context(|| format!("connecting to {name}"))?;
            match info {
                None => info = Some(i),
                Some(first) if (first.pe_count, first.pe_mem_words) != (i.pe_count, i.pe_mem_words) => bail!(
                    "{name} has {} PEs of {} words, {} has {} of {}: all boards must match",
                    i.pe_count,
                    i.pe_mem_words,
                    sessions.first().map_or("", |f| f.config().port_name.as_str()),
                    first.pe_count,
                    first.pe_mem_words
                ),
                Some(_) => {}
            }
        }
        let Some(info) = info else { bail!("no device") };
        if let Some(board) = self.port.board.filter(|&b| b != info.board) {
            bail!(
                "the device is board {} ({}), not board {board} (--board or `board` in gridrt.toml)",
                info.board,
                board_name(info.board)
            );
        }
        if !self.port.port.is_empty() && info.pe_count != self.scene.pes {
            eprintln!("note: the device has {} PEs; using that instead of --pes {}", info.pe_count, self.scene.pes);
        }
        let pe_mem_words = match self.scene.pe_mem_words {
            Some(w) if w > info.pe_mem_words => {
                bail!("--pe-mem-words {w} exceeds the device's PE memory of {} words", info.pe_mem_words)
            }
            Some(w) => w,
            None => info.pe_mem_words,
        };

        // Grid and scene image.
        let params = GridParams {
            m: self.scene.grid.grid_m,
            pe_count: info.pe_count,
            pe_mem_words,
            mapping: self.scene.mapping.into(),
            dims_override: None,
            max_voxels: self.scene.grid.grid_max_voxels,
        };
        for w in &loaded.mesh.stats.warnings {
            eprintln!("warning: {w}");
        }
        let prepared = PreparedScene::new(loaded, &params).context("building the grid")?;
        let voxels = prepared.grid.voxel_count();
        if voxels > info.voxel_capacity {
            let d = prepared.grid.dims;
            bail!(
                "grid {}×{}×{} = {voxels} voxels exceeds the device's capacity of {} voxels; use a smaller --grid-m (now {}) or --grid-max-voxels",
                d[0],
                d[1],
                d[2],
                info.voxel_capacity,
                self.scene.grid.grid_m
            );
        }

        // Upload (to every board at once).
        let upload_start = Instant::now();
        let tx_before: u64 = sessions.iter().map(|s| s.bytes_tx()).sum();
        if let [session] = &mut sessions[..] {
            session.upload_scene(&prepared.image, &mut on_event).context("uploading the scene")?;
        } else {
            let image = &prepared.image;
            // Progress of the first board stands for all (they upload at once).
            let first = std::sync::Mutex::new(&mut on_event);
            let first = &first;
            std::thread::scope(|sc| {
                let jobs: Vec<_> = sessions
                    .iter_mut()
                    .enumerate()
                    .map(|(i, s)| {
                        sc.spawn(move || {
                            let mut on = |e| {
                                if i == 0 {
                                    (first.lock().unwrap_or_else(|p| p.into_inner()))(e)
                                }
                            };
                            s.upload_scene(image, &mut on).map_err(anyhow::Error::from)
                        })
                    })
                    .collect();
                jobs.into_iter()
                    .try_for_each(|j| j.join().unwrap_or_else(|_| Err(anyhow::anyhow!("upload thread panicked"))))
            })
            .context("uploading the scene")?;
        }
        let upload_ms = upload_start.elapsed().as_secs_f64() * 1e3;
        let upload_wire_bytes = sessions.iter().map(|s| s.bytes_tx()).sum::<u64>() - tx_before;

        // The frame's settings.
        let want_reference = self.reference || self.reference_out.is_some();
        let base = prepared.scene.settings;
        let plan = if self.no_skip { Plan::ALL } else { Plan::derive(&prepared.scene) };
        let plan = Plan { shadows: plan.shadows && !self.no_shadows, ..plan };
        let settings = base
            .with_size(self.width.unwrap_or(base.width), self.height.unwrap_or(base.height))
            .with_shadows(plan.shadows)
            .with_prim_ids(want_reference);
        let mut request = settings.to_request(1);
        request.flags |= plan.flags() | self.interp.map_or(0, |i| i.flags());
        request.encoding = self.encoding.into();
        Ok(Setup { sessions, prepared, plan, settings, request, upload_ms, upload_wire_bytes })
    }

    fn run_on<T: Read + Write + Send>(
        &self,
        ports: Vec<(T, String)>,
        loaded: Scene,
        coproc: Option<CoprocFacts>,
    ) -> anyhow::Result<()> {
        self.run_on_watched(ports, loaded, coproc, None)
    }

    /// [`Self::run_on`], reporting the simulated boards' PE caches if `caches` watches them.
    fn run_on_watched<T: Read + Write + Send>(
        &self,
        ports: Vec<(T, String)>,
        loaded: Scene,
        coproc: Option<CoprocFacts>,
        caches: Option<CacheWatch>,
    ) -> anyhow::Result<()> {
        let total_start = Instant::now();
        let mut progress = CliProgress::default();
        let setup = self.setup(ports, loaded, &mut progress)?;
        let after_upload = caches.as_ref().and_then(CacheWatch::read);
        if let Some(dir) = &self.out_dir {
            return self.run_stream(setup, dir, progress, total_start);
        }
        let Setup { mut sessions, prepared, plan, settings, request, upload_ms, upload_wire_bytes } = setup;
        let dropped = prepared.scene.mesh.stats.dropped_degenerate;
        let mut on_event = |e| progress.handle(e);
        let (frame, devices) =
            gridrt_host::stream::render_frame(&mut sessions, &request, self.band_rows, &mut on_event)
                .context(if sessions.len() > 1 { "rendering on several boards" } else { "rendering" })?;
        drop(progress);
        let after_frame = caches.as_ref().and_then(CacheWatch::read);
        let out = self.out_path();
        write_png(out, frame.width, frame.height, frame.rgb.clone())?;
        let facts = SceneFacts {
            scene: self.scene.scene.display().to_string(),
            dropped_triangles: dropped,
            scene_image_bytes: prepared.image.len() as u64,
            upload_wire_bytes,
            upload_ms,
        };
        let mut stats = RenderStats::new(&facts, &prepared.grid, &frame);
        stats.coproc = coproc;
        if let (Some(w), Some(up), Some(fr)) = (&caches, after_upload, after_frame) {
            stats.pe_cache = Some(PeCacheReport {
                lines: w.lines,
                mem_latency: w.mem_latency,
                modelled: fr.modelled,
                upload_stall_cycles: up.stall_cycles,
                frame_stall_cycles: fr.stall_cycles - up.stall_cycles,
                frame_reads: fr.reads - up.reads,
                upload_writes: up.writes,
            });
        }
        stats.pipeline = Some(PipelineStats::new(&plan.names(), self.interp, &frame));
        let baud = self.port.baud();
        let modelled_link_s = if devices.is_empty() {
            (frame.bytes_tx + frame.bytes_rx) as f64 * 10.0 / baud as f64
        } else {
            devices.iter().map(|d: &DeviceShare| d.link_seconds(baud)).fold(0.0, f64::max)
        };
        let encoding = format!("{:?}", self.encoding).to_lowercase();
        stats.link = LinkReport { encoding, baud, modelled_link_s, counters: frame.link.clone() };
        stats.devices = devices;

        // Reference.
        if self.reference || self.reference_out.is_some() {
            let start = Instant::now();
            let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(2);
            let stages = Stages {
                shadows: plan.shadows,
                reflections: plan.reflections,
                textures: plan.textures,
                specular: plan.specular,
            };
            let reference =
                reference::render(&Reference::new(&prepared.scene, &prepared.grid.bounds), &settings, stages, threads);
            let reference_ms = start.elapsed().as_secs_f64() * 1e3;
            let cmp = compare(&frame.rgb, &reference.rgb, frame.prim_ids.as_deref(), Some(&reference.prim_ids))?;
            stats.reference = Some(ReferenceStats::new(&cmp, reference_ms));
            if let Some(path) = &self.reference_out {
                write_png(path, reference.width, reference.height, reference.rgb)?;
            }
        }

        if let Some(path) = &self.stats {
            let json = serde_json::to_string_pretty(&stats)?;
            super::output::write_bytes(path, (json + "\n").as_bytes())?;
        }
        print_summary(&stats, &frame, out, total_start.elapsed());
        Ok(())
    }
}

pub(super) fn write_png(path: &std::path::Path, w: u16, h: u16, rgb: Vec<u8>) -> anyhow::Result<()> {
    super::output::write_rgb(path, w, h, rgb)
}

/// `--width` / `--height`: 1..=the device's largest image side.
fn image_dim(s: &str) -> Result<u16, String> {
    let max = gridrt_firmware::device::MAX_IMAGE_DIM;
    match s.parse::<u64>() {
        Ok(v) if (1..=max as u64).contains(&v) => Ok(v as u16),
        Ok(v) => Err(format!("{v} is not in 1..={max} pixels (the device's limit)")),
        Err(_) => Err(format!("`{s}` is not a number of pixels")),
    }
}

/// Checks a frame size against the device's limit (a scene file's camera may ask for more).
pub(super) fn check_size(width: u16, height: u16) -> anyhow::Result<()> {
    let max = gridrt_firmware::device::MAX_IMAGE_DIM;
    if !(1..=max).contains(&width) || !(1..=max).contains(&height) {
        bail!("frame {width}×{height} is outside the device's 1..={max} pixels per side (--width, --height)");
    }
    Ok(())
}

/// A board id's name (Hello's `board`).
pub(super) fn board_name(id: u8) -> &'static str {
    match id {
        0 => "loopback simulator",
        1 => "qemu-virt",
        2 => "FPGA SoC",
        3 => "LiteX SoC",
        _ => "unknown board",
    }
}

fn si(v: u64) -> String {
    match v {
        v if v >= 10_000_000_000 => format!("{:.1} G", v as f64 / 1e9),
        v if v >= 10_000_000 => format!("{:.1} M", v as f64 / 1e6),
        v if v >= 10_000 => format!("{:.1} k", v as f64 / 1e3),
        v => v.to_string(),
    }
}

/// The simulated boards' PE caches, watched through their ports' probes.
struct CacheWatch {
    lines: u32,
    mem_latency: u32,
    probes: Vec<gridrt_loopback::PeCacheProbe>,
}

impl CacheWatch {
    /// The boards' counters summed (None if a board does not answer).
    fn read(&self) -> Option<gridrt_loopback::PeCacheCounts> {
        let mut sum = gridrt_loopback::PeCacheCounts::default();
        for p in &self.probes {
            let c = p.counts()?;
            sum.stall_cycles += c.stall_cycles;
            sum.reads += c.reads;
            sum.writes += c.writes;
            sum.modelled = c.modelled;
        }
        Some(sum)
    }
}

fn print_summary(s: &RenderStats, frame: &RenderedFrame, out: &std::path::Path, total: Duration) {
    let g = s.grid;
    println!(
        "scene      {}: {} triangles ({} zero-area dropped), grid {}×{}×{} ({} non-empty voxels), {} PEs, image {} B",
        s.scene, s.triangles, s.dropped_triangles, g[0], g[1], g[2], s.nonempty_voxels, s.pe_count, s.scene_image_bytes
    );
    println!("upload     {:.0} ms", s.upload_ms);
    println!(
        "render     {}×{} in {:.0} ms: {} primary + {} shadow rays ({} culled), {} list entries, {} tests, {} co-processor cycles",
        s.width,
        s.height,
        s.wall_ms,
        si(s.primary_rays),
        si(s.shadow_rays),
        si(s.culled_rays),
        si(s.list_entries),
        si(s.intersection_tests),
        si(s.coproc_cycles)
    );
    println!(
        "link       {} FSL words, {} UART bytes ({} spans, {}), {:.2} s modelled at {} baud",
        si(s.fsl_words),
        si(s.uart_bytes),
        frame.spans_received,
        s.link.encoding,
        s.link.modelled_link_s,
        s.link.baud
    );
    let l = &s.link.counters;
    if l.regions_resent + l.resyncs + l.device_resets + l.device_bad_frames > 0 {
        println!(
            "retransmit {} regions re-requested ({} pixels, {} B), {} CRC errors, {} resyncs, {} frames lost, {} device resets",
            l.regions_resent, l.pixels_resent, l.bytes_resent, l.crc_errors, l.resyncs, l.seq_gaps, l.device_resets
        );
    }
    for d in &s.devices {
        println!(
            "board      {}: {} bands ({} rows), {} B, {:.2} s link, {} co-processor cycles{}",
            d.port,
            d.bands,
            d.rows,
            si(d.bytes_tx + d.bytes_rx),
            d.link_seconds(s.link.baud),
            si(d.coproc_cycles),
            d.error.as_deref().map_or_else(String::new, |e| format!(" (dropped out: {e})"))
        );
    }
    if let Some(p) = &s.pipeline {
        println!(
            "pipeline   plan [{}], {} reflection rays, {} of {} pixels traced ({} interpolated), FSL words primary/shadow/reflection {}/{}/{}",
            p.plan.join(", "),
            si(p.reflection_rays),
            si(p.traced_pixels),
            si(p.traced_pixels + p.interpolated_pixels),
            si(p.interpolated_pixels),
            si(p.fsl_words_primary),
            si(p.fsl_words_shadow),
            si(p.fsl_words_reflection)
        );
    }
    if let Some(c) = &s.pe_cache {
        println!(
            "pe caches  {} lines × 8 words per PE, memory latency {} cycles: {} cycles stopped in the frame ({}; not in the co-processor cycles), {} in the upload; {} words read in the frame, {} written in the upload",
            c.lines,
            c.mem_latency,
            si(c.frame_stall_cycles),
            if c.modelled { "modelled" } else { "the RTL's count" },
            si(c.upload_stall_cycles),
            si(c.frame_reads),
            si(c.upload_writes)
        );
    }
    if let Some(r) = &s.reference {
        let psnr = r.psnr_db.map_or_else(|| "∞ (identical)".to_string(), |p| format!("{p:.2} dB"));
        println!(
            "reference  PSNR {psnr}, max diff {}, {} differing pixels, {} hit mismatches ({:.0} ms)",
            r.max_abs_diff,
            r.differing_pixels,
            r.hit_mismatches.map_or_else(|| "n/a".to_string(), |m| m.to_string()),
            r.reference_ms
        );
    }
    println!("wrote      {} ({:.1} s total)", out.display(), total.as_secs_f64());
}
