//! `gridrt bench splat`: the native splat path (the firmware's code generator and splat stage
//! compiled for the host) over clouds of 10³…10⁶ points and several shape-table sizes:
//! splats per second, and image error against the same points as disks in the f64 reference,
//! with the table keyed as the device does (local affine) and as the point-splatting design does (camera-frame
//! normal, orthographic at every splat).

use std::time::Instant;

use gridrt_firmware::camera::Camera;
use gridrt_firmware::splat::codegen::{Pass, SplatLight, View};
use gridrt_firmware::splat::table::TableConfig;
use gridrt_firmware::splat::SplatEngine;
use gridrt_shared::math::Vec3;
use gridrt_shared::splat::MaterialTerm;
use serde::Serialize;

use crate::compare::compare;
use crate::points::{cloud_scene, synthetic, PointCloud};
use crate::reference::{self, Reference, Stages};

/// Largest cloud the bench holds.
pub const MAX_POINTS: usize = 1 << 20;
/// Largest table the bench builds (64 normal bins, 8 steps per pixel, 8 px).
pub const MAX_TABLE: usize = 655_360;

/// The bench's engine (≈ 70 MB: build it on a thread with a large stack, boxed).
pub type BenchEngine = SplatEngine<MAX_POINTS, MAX_TABLE>;

/// One row of `splat.csv`.
#[derive(Debug, Clone, Serialize)]
pub struct SplatRow {
    /// Points in the cloud.
    pub points: usize,
    /// Normal bins per axis.
    pub normal_bins: u16,
    /// Radius bins per pixel.
    pub steps_per_px: u16,
    /// Table words.
    pub table_words: usize,
    /// Best wall time of one frame (code generator + stage), ms.
    pub frame_ms: f64,
    /// Points per second through the native code generator and stage.
    pub splats_per_s: f64,
    /// Nanoseconds per point (the point-splatting design estimates 60 ns on its FPGA).
    pub ns_per_splat: f64,
    /// Codewords (8×8 tiles) sent.
    pub codewords: u64,
    /// PSNR against the f64 disks, device keying (local affine); `null` = identical.
    pub psnr_db: Option<f64>,
    /// PSNR against the f64 disks with the point-splatting design's keying.
    pub psnr_seed_affine_db: Option<f64>,
    /// PSNR with per-pixel depth (device keying).
    pub psnr_pixel_depth_db: Option<f64>,
}

/// Renders `cloud` natively into an RGB image of `w`×`h` with the scene's default camera.
pub fn render_native(
    engine: &mut BenchEngine,
    cloud: &PointCloud,
    w: u16,
    h: u16,
    seed_affine: bool,
    pixel_depth: bool,
) -> Option<(Vec<u8>, f64, u64)> {
    let scene = cloud_scene(cloud);
    let s = scene.settings.with_size(w, h);
    let req = s.to_request(1);
    let v = Vec3::from_array;
    let cam = Camera::new(v(req.eye), v(req.target), v(req.up), req.fov_y_deg, w as u32, h as u32).ok()?;
    let half_h = gridrt_firmware::fmath::tan_turns(req.fov_y_deg / 720.0);
    let b = cloud.bounds();
    let mut view = View::new(
        v(req.eye),
        [cam.forward(), cam.right(), cam.up()],
        h as f32 / (2.0 * half_h),
        (w, h),
        [v(b.min), v(b.max)],
    )?;
    view.seed_affine = seed_affine;
    view.pixel_depth = pixel_depth;
    let l = &scene.lighting;
    let light = SplatLight { pos: v(req.light_pos), on: l.light_count > 0, inverse_square: false, spot: None };
    // Matte: k_a = k_d = 1, white light and ambient colour.
    let materials: Vec<[MaterialTerm; 3]> = cloud
        .materials
        .iter()
        .map(|m| {
            let a = m.diffuse.map(|c| c * l.ambient_colour[0]);
            let d = m.diffuse.map(|c| c * l.light_colour[0] * req.light_intensity);
            [MaterialTerm::from_coefficient(a), MaterialTerm::from_coefficient(d), MaterialTerm::default()]
        })
        .collect();
    let amb = (req.ambient.clamp(0.0, 1.0) * 127.0 + 0.5) as u8;
    // The ambient register stands for the request's ambient (k_a scaled as the device does).
    let scale = if amb > 0 { req.ambient * 127.0 / amb as f32 } else { 0.0 };
    let materials: Vec<_> = materials
        .iter()
        .map(|[a, d, s]| [MaterialTerm(a.0.map(|k| (k as f32 * scale).round() as u16)), *d, *s])
        .collect();
    let bg = gridrt_firmware::shade::to_rgb8(l.background);
    let background = (bg[0] as u32) << 16 | (bg[1] as u32) << 8 | bg[2] as u32;
    let pass = Pass { x0: 0, y0: 0, columns: w, rows: h };
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    let start = Instant::now();
    let st = engine
        .render_pass(&view, &light, &pass, &materials, amb, background, &|| [0, 0], &mut |y, c: &[u32], _d: &[u16]| {
            for (x, &p) in c.iter().enumerate() {
                let i = 3 * (y as usize * w as usize + x);
                rgb[i..i + 3].copy_from_slice(&[(p >> 16) as u8, (p >> 8) as u8, p as u8]);
            }
            Ok::<(), ()>(())
        })
        .ok()?;
    Some((rgb, start.elapsed().as_secs_f64(), st.codegen.codewords))
}

/// Loads a cloud into the engine (through the same point records the device parses).
pub fn load(engine: &mut BenchEngine, cloud: &PointCloud) -> bool {
    let b = cloud.bounds();
    let head =
        gridrt_shared::scene::PointsHead { count: cloud.points.len() as u32, bounds_min: b.min, bounds_max: b.max };
    if engine.begin(&head).is_err() {
        return false;
    }
    cloud.points.iter().all(|p| {
        let r =
            gridrt_shared::scene::PointRecord { pos: p.pos, normal: p.normal, radius: p.radius, material: p.material };
        engine.push(&r).is_ok()
    })
}

/// Runs the bench for `counts` × `tables` at `w`×`h`, best of `runs`; `progress` hears each
/// row.
pub fn run(
    counts: &[usize],
    tables: &[TableConfig],
    (w, h): (u16, u16),
    runs: u32,
    progress: &mut dyn FnMut(&SplatRow),
) -> Result<Vec<SplatRow>, String> {
    let mut engine: Box<BenchEngine> = Box::new(SplatEngine::new());
    let mut rows = Vec::new();
    for &n in counts {
        if n > MAX_POINTS {
            return Err(format!("{n} points exceed the bench's {MAX_POINTS}"));
        }
        let v = synthetic::torus_and_sphere(n, 0xBE_0001 ^ n as u64);
        let cloud = PointCloud::from_ply(std::path::Path::new("synthetic"), v).map_err(|e| e.to_string())?;
        if !load(&mut engine, &cloud) {
            return Err("the bench engine refused the cloud".into());
        }
        let scene = cloud_scene(&cloud);
        let settings = scene.settings.with_size(w, h);
        let bounds = crate::scene::Bounds::of_geometry(&scene.mesh, &scene.prims).ok_or("empty cloud")?;
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(2);
        let stages = Stages { shadows: false, reflections: false, textures: false, specular: false };
        let reference = reference::render(&Reference::new(&scene, &bounds), &settings, stages, threads);
        for t in tables {
            engine.build_table(*t).map_err(|e| format!("table {t:?}: {e:?}"))?;
            let mut best = f64::INFINITY;
            let mut out = None;
            for _ in 0..runs.max(1) {
                let (rgb, secs, cw) = render_native(&mut engine, &cloud, w, h, false, false).ok_or("render failed")?;
                best = best.min(secs);
                out = Some((rgb, cw));
            }
            let (rgb, codewords) = out.ok_or("no run")?;
            let psnr =
                |img: &[u8]| compare(img, &reference.rgb, None, None).map(|c| c.psnr_db).map_err(|e| e.to_string());
            let seed = render_native(&mut engine, &cloud, w, h, true, false).ok_or("render failed")?.0;
            let depth = render_native(&mut engine, &cloud, w, h, false, true).ok_or("render failed")?.0;
            let row = SplatRow {
                points: n,
                normal_bins: t.normal_bins,
                steps_per_px: t.steps_per_px,
                table_words: t.words(),
                frame_ms: best * 1e3,
                splats_per_s: n as f64 / best,
                ns_per_splat: best * 1e9 / n as f64,
                codewords,
                psnr_db: psnr(&rgb)?,
                psnr_seed_affine_db: psnr(&seed)?,
                psnr_pixel_depth_db: psnr(&depth)?,
            };
            progress(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}
