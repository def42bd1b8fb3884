//! JSON statistics of a render (`gridrt render --stats`) and of the ray bench.
//!
//! Field meanings (all counters are of the one rendered frame):
//! - `primary_rays`, `shadow_rays`: rays the device generated; `rays` = their sum.
//! - `coproc_rays`: ray requests sent to the co-processor (a list sent in two parts, SPEC.md §4.3, is two); `culled_rays`: rays that missed the grid box
//!   and cost no FSL traffic.
//! - `fsl_words` = `fsl_words_out` + `fsl_words_in`; `list_entries`: traversal-list entries sent.
//! - `intersection_tests`, `coproc_cycles`: as reported by the co-processor.
//! - `uart_bytes`: bytes on the wire in both directions from the render request to `FrameEnd`.
//! - `upload_wire_bytes`: bytes host → device on the wire for the scene upload, framing
//!   included (with several boards, their sum).
//! - `wall_ms`: host wall time of the render (request to verified `FrameEnd`); `upload_ms`: of
//!   the scene upload.
//! - With `--reference`: `psnr_db` (`null` when the images are identical, see
//!   [`crate::compare`]), `identical`, `max_abs_diff`, `differing_pixels`, `hit_mismatches`,
//!   `reference_ms`.
//! - `link`: the pixel encoding, the modelled link time at `--baud` (wire bytes × 10 / baud;
//!   with several boards the busiest one) and the retransmission counters
//!   ([`crate::session::LinkStats`]: regions re-requested, pixels and bytes resent, CRC errors,
//!   resyncs, frames lost by sequence number, timeouts, device resets, scene re-uploads).
//! - `devices` (several boards only): per board, bands and rows rendered, bytes, link time,
//!   co-processor cycles, and why it dropped out if it did.
//! - `device_counters`: every counter the device sent, by name (per-stage counters as
//!   `stage_<stage>_instret` / `stage_<stage>_cycles`, unknown keys as `key_<n>`).
//! - `device_instructions` (object by stage), `instructions_per_primary_ray` (all stages) and
//!   `instructions_per_primary_ray_by_stage`: only when the device counts its instructions
//!   (the firmware image on QEMU/a soft-core; under QEMU `-icount shift=0` they are exact and
//!   exclude the co-processor model's own work).

use std::collections::BTreeMap;

use gridrt_firmware::device::Stage;
use gridrt_shared::msg::{stat, STAT_HARTS};
use serde::Serialize;

use crate::compare::Comparison;
use crate::grid::Grid;
use crate::multi::DeviceShare;
use crate::session::{LinkStats, RenderedFrame};

/// One past the last per-hart key.
const HART_KEYS_END: u8 = stat::HART_WAIT_BASE + STAT_HARTS;

/// Name of a device statistics key.
pub fn stat_name(key: u8) -> String {
    match key {
        stat::PRIMARY_RAYS => "primary_rays".into(),
        stat::SHADOW_RAYS => "shadow_rays".into(),
        stat::COPROC_RAYS => "coproc_rays".into(),
        stat::CULLED_RAYS => "culled_rays".into(),
        stat::FSL_WORDS_OUT => "fsl_words_out".into(),
        stat::FSL_WORDS_IN => "fsl_words_in".into(),
        stat::INTERSECTION_TESTS => "intersection_tests".into(),
        stat::COPROC_CYCLES => "coproc_cycles".into(),
        stat::PIXELS => "pixels".into(),
        stat::LIST_ENTRIES => "list_entries".into(),
        stat::REFLECTION_RAYS => "reflection_rays".into(),
        stat::INTERPOLATED_PIXELS => "interpolated_pixels".into(),
        stat::INTERP_RETRACES => "interp_retraces".into(),
        stat::PLAN => "plan".into(),
        stat::FSL_WORDS_PRIMARY => "fsl_words_primary".into(),
        stat::FSL_WORDS_SHADOW => "fsl_words_shadow".into(),
        stat::FSL_WORDS_REFLECTION => "fsl_words_reflection".into(),
        stat::RAYS_IN_FLIGHT => "rays_in_flight".into(),
        stat::MODEL_INSTRUCTIONS => "model_instructions".into(),
        stat::LINK_WRAPPER_INSTRUCTIONS => "link_wrapper_instructions".into(),
        stat::FRAME_CYCLES => "frame_cycles".into(),
        stat::LINK_CYCLES => "link_cycles".into(),
        stat::FRAME_TX_BYTES => "frame_tx_bytes".into(),
        stat::UPLOAD_CYCLES => "upload_cycles".into(),
        stat::UPLOAD_FEED_CYCLES => "upload_feed_cycles".into(),
        stat::UPLOAD_PARSE_CYCLES => "upload_parse_cycles".into(),
        k @ stat::HART_ROWS_BASE..stat::HART_BUSY_BASE => format!("hart{}_rows", k - stat::HART_ROWS_BASE),
        k @ stat::HART_BUSY_BASE..stat::HART_WAIT_BASE => format!("hart{}_busy_cycles", k - stat::HART_BUSY_BASE),
        k @ stat::HART_WAIT_BASE..HART_KEYS_END => format!("hart{}_wait_cycles", k - stat::HART_WAIT_BASE),
        k => {
            // Per-stage counters, keyed as the firmware sends them (`device::Stage`).
            for s in Stage::ALL {
                let name = match s {
                    Stage::RayGen => "raygen",
                    Stage::Traverse => "traverse",
                    Stage::FslIo => "fsl_io",
                    Stage::Shade => "shade",
                    Stage::Encode => "encode",
                };
                if k == s.instret_key() {
                    return format!("stage_{name}_instret");
                }
                if k == s.cycles_key() {
                    return format!("stage_{name}_cycles");
                }
            }
            format!("key_{k}")
        }
    }
}

/// Comparison with the reference renderer.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ReferenceStats {
    /// PSNR in dB, `null` for identical images.
    pub psnr_db: Option<f64>,
    /// Every byte matches.
    pub identical: bool,
    /// Largest channel difference.
    pub max_abs_diff: u8,
    /// Pixels with any difference.
    pub differing_pixels: u64,
    /// Pixels whose primary primitive id differs.
    pub hit_mismatches: Option<u64>,
    /// Reference render time.
    pub reference_ms: f64,
}

impl ReferenceStats {
    /// From a comparison and the reference time.
    pub fn new(c: &Comparison, reference_ms: f64) -> Self {
        Self {
            psnr_db: c.psnr_db,
            identical: c.identical,
            max_abs_diff: c.max_abs_diff,
            differing_pixels: c.differing_pixels,
            hit_mismatches: c.hit_mismatches,
            reference_ms,
        }
    }
}

/// The simulated co-processor of a render (`render --sim`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CoprocFacts {
    /// `model` (gridrt-coproc) or `rtl` (the RTL in Verilator).
    pub coproc: String,
    /// Intersection kernel (`KernelKind::name`).
    pub kernel: String,
    /// Number format (`NumberFormat::name`).
    pub format: String,
    /// Timing profile of the cycle counts (`rtl` for the RTL: its own cycles).
    pub timing: String,
}

/// Statistics of one `gridrt render`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RenderStats {
    /// Scene file.
    pub scene: String,
    /// Image width.
    pub width: u16,
    /// Image height.
    pub height: u16,
    /// Triangles in the scene.
    pub triangles: u32,
    /// Zero-area triangles dropped while loading.
    pub dropped_triangles: u64,
    /// Grid resolution.
    pub grid: [u16; 3],
    /// Non-empty voxels.
    pub nonempty_voxels: u64,
    /// Triangle references over all voxels.
    pub grid_refs: u64,
    /// PEs.
    pub pe_count: u16,
    /// Words per PE memory.
    pub pe_mem_words: u32,
    /// Largest PE image in words.
    pub max_pe_words: u64,
    /// Scene image size in bytes.
    pub scene_image_bytes: u64,
    /// Bytes host → device on the wire for the scene upload (`SceneBegin` and every data
    /// frame, framing included; compact when the device decodes it, SPEC.md §5.12).
    pub upload_wire_bytes: u64,
    /// Camera rays.
    pub primary_rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// All rays generated (primary + shadow).
    pub rays: u64,
    /// Rays sent to the co-processor.
    pub coproc_rays: u64,
    /// Rays that missed the grid box.
    pub culled_rays: u64,
    /// Traversal-list entries sent.
    pub list_entries: u64,
    /// FSL words in both directions.
    pub fsl_words: u64,
    /// FSL words to the co-processor.
    pub fsl_words_out: u64,
    /// FSL words from the co-processor.
    pub fsl_words_in: u64,
    /// Ray–triangle tests.
    pub intersection_tests: u64,
    /// Co-processor cycles.
    pub coproc_cycles: u64,
    /// UART bytes in both directions during the render.
    pub uart_bytes: u64,
    /// UART bytes host → device during the render.
    pub uart_bytes_tx: u64,
    /// UART bytes device → host during the render.
    pub uart_bytes_rx: u64,
    /// Scene upload time.
    pub upload_ms: f64,
    /// Render wall time.
    pub wall_ms: f64,
    /// What computed in the simulator: co-processor, kernel, format, timing (absent for a
    /// real board, which does not report them).
    #[serde(flatten)]
    pub coproc: Option<CoprocFacts>,
    /// Comparison with the reference (only with `--reference`).
    #[serde(flatten)]
    pub reference: Option<ReferenceStats>,
    /// Pipeline plan, rays of each kind, interpolation and FSL words per ray kind.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pipeline: Option<PipelineStats>,
    /// UART link: encoding, retransmissions and line errors of the render.
    pub link: LinkReport,
    /// Per board, when the frame was split across several (`--port A --port B`,
    /// `--sim-devices N`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub devices: Vec<DeviceShare>,
    /// Every device counter by name.
    pub device_counters: BTreeMap<String, u64>,
    /// Instructions the device retired in each pipeline stage (`raygen`, `traverse`,
    /// `fsl_io`, `shade`, `encode`), from its per-stage counters; only when the device
    /// counts them (the firmware on a soft-core or QEMU; the loopback simulator does not).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub device_instructions: Option<BTreeMap<String, u64>>,
    /// All device instructions of the frame divided by the primary rays.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub instructions_per_primary_ray: Option<f64>,
    /// `device_instructions` of each stage divided by the primary rays.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub instructions_per_primary_ray_by_stage: Option<BTreeMap<String, f64>>,
    /// The simulated boards' PE caches (`--pe-cache-lines`): the cycles the co-processor
    /// stood still for them, which `coproc_cycles` leaves out.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pe_cache: Option<PeCacheReport>,
}

/// What the PE caches of the simulated boards cost (`--pe-cache-lines`), summed over the
/// boards: counted by the RTL (`--coproc rtl`) or by the model's timing of the RTL's caches
/// (`--coproc model --timing rtl`, exact against the RTL with the Verilator harness's
/// fixed-latency memory: rtl/README.md §4.6).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PeCacheReport {
    /// Lines of 8 words per PE.
    pub lines: u32,
    /// The external memory's latency in cycles.
    pub mem_latency: u32,
    /// True when the model counted the stalls, false when the RTL did.
    pub modelled: bool,
    /// Cycles stopped during the scene upload (LOAD_PE's writes, its records' reads back,
    /// the tag clear after the reset).
    pub upload_stall_cycles: u64,
    /// Cycles stopped during the frame.
    pub frame_stall_cycles: u64,
    /// Words read from the external memory during the frame (8 per line filled).
    pub frame_reads: u64,
    /// Words written to it during the upload.
    pub upload_writes: u64,
}

/// Name of a device pipeline stage in the stats JSON.
pub fn stage_name(stage: Stage) -> &'static str {
    match stage {
        Stage::RayGen => "raygen",
        Stage::Traverse => "traverse",
        Stage::FslIo => "fsl_io",
        Stage::Shade => "shade",
        Stage::Encode => "encode",
    }
}

/// `(device_instructions, instructions_per_primary_ray, by stage)` when any stage counted.
#[allow(clippy::type_complexity)]
fn device_instructions(
    stats: &BTreeMap<u8, u64>,
    primary_rays: u64,
) -> (Option<BTreeMap<String, u64>>, Option<f64>, Option<BTreeMap<String, f64>>) {
    let by_stage: BTreeMap<String, u64> = Stage::ALL
        .iter()
        .map(|&s| (stage_name(s).to_string(), stats.get(&s.instret_key()).copied().unwrap_or(0)))
        .collect();
    if by_stage.values().all(|&v| v == 0) {
        return (None, None, None);
    }
    let total: u64 = by_stage.values().sum();
    let per_ray = (primary_rays > 0).then(|| total as f64 / primary_rays as f64);
    let per_ray_by_stage = (primary_rays > 0)
        .then(|| by_stage.iter().map(|(k, &v)| (k.clone(), v as f64 / primary_rays as f64)).collect());
    (Some(by_stage), per_ray, per_ray_by_stage)
}

/// The pipeline plan of a frame and what it cost (SPEC.md §3.13).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PipelineStats {
    /// Stages the host asked for.
    pub plan: Vec<String>,
    /// `render_flags` bits the device reports it followed.
    pub plan_followed: u64,
    /// Row interpolation setting, if any.
    pub interp: Option<crate::plan::Interp>,
    /// Mirror-reflection rays.
    pub reflection_rays: u64,
    /// Pixels whose primary ray was traced.
    pub traced_pixels: u64,
    /// Pixels filled by interpolation.
    pub interpolated_pixels: u64,
    /// `traced_pixels / (traced + interpolated)`.
    pub traced_fraction: f64,
    /// Centre pixels traced after a failed interpolation test.
    pub interp_retraces: u64,
    /// FSL words (both directions) of primary rays.
    pub fsl_words_primary: u64,
    /// FSL words of shadow rays.
    pub fsl_words_shadow: u64,
    /// FSL words of reflection rays.
    pub fsl_words_reflection: u64,
}

impl PipelineStats {
    /// From the plan names, the interpolation setting and the device counters.
    pub fn new(plan: &[&str], interp: Option<crate::plan::Interp>, frame: &RenderedFrame) -> Self {
        let get = |k: u8| frame.stats.get(&k).copied().unwrap_or(0);
        let traced = get(stat::PRIMARY_RAYS);
        let interpolated = get(stat::INTERPOLATED_PIXELS);
        Self {
            plan: plan.iter().map(|s| s.to_string()).collect(),
            plan_followed: get(stat::PLAN),
            interp,
            reflection_rays: get(stat::REFLECTION_RAYS),
            traced_pixels: traced,
            interpolated_pixels: interpolated,
            traced_fraction: if traced + interpolated > 0 {
                traced as f64 / (traced + interpolated) as f64
            } else {
                0.0
            },
            interp_retraces: get(stat::INTERP_RETRACES),
            fsl_words_primary: get(stat::FSL_WORDS_PRIMARY),
            fsl_words_shadow: get(stat::FSL_WORDS_SHADOW),
            fsl_words_reflection: get(stat::FSL_WORDS_REFLECTION),
        }
    }
}

/// Scene-side facts for [`RenderStats::new`].
#[derive(Debug, Clone, PartialEq)]
pub struct SceneFacts {
    /// Scene file.
    pub scene: String,
    /// Dropped zero-area triangles.
    pub dropped_triangles: u64,
    /// Scene image size.
    pub scene_image_bytes: u64,
    /// Bytes host → device on the wire for the upload (framing included).
    pub upload_wire_bytes: u64,
    /// Upload time.
    pub upload_ms: f64,
}

impl RenderStats {
    /// Collects the statistics of `frame` rendered from `grid`.
    pub fn new(facts: &SceneFacts, grid: &Grid, frame: &RenderedFrame) -> Self {
        let instructions =
            device_instructions(&frame.stats, frame.stats.get(&stat::PRIMARY_RAYS).copied().unwrap_or(0));
        let get = |k: u8| frame.stats.get(&k).copied().unwrap_or(0);
        let (primary, shadow) = (get(stat::PRIMARY_RAYS), get(stat::SHADOW_RAYS));
        let (out, inn) = (get(stat::FSL_WORDS_OUT), get(stat::FSL_WORDS_IN));
        Self {
            scene: facts.scene.clone(),
            width: frame.width,
            height: frame.height,
            triangles: grid.triangle_count,
            dropped_triangles: facts.dropped_triangles,
            grid: grid.dims,
            nonempty_voxels: grid.voxels.len() as u64,
            grid_refs: grid.ref_count() as u64,
            pe_count: grid.pe_count,
            pe_mem_words: grid.pe_mem_words,
            max_pe_words: grid.max_pe_words() as u64,
            scene_image_bytes: facts.scene_image_bytes,
            upload_wire_bytes: facts.upload_wire_bytes,
            primary_rays: primary,
            shadow_rays: shadow,
            rays: primary + shadow,
            coproc_rays: get(stat::COPROC_RAYS),
            culled_rays: get(stat::CULLED_RAYS),
            list_entries: get(stat::LIST_ENTRIES),
            fsl_words: out + inn,
            fsl_words_out: out,
            fsl_words_in: inn,
            intersection_tests: get(stat::INTERSECTION_TESTS),
            coproc_cycles: get(stat::COPROC_CYCLES),
            uart_bytes: frame.bytes_tx + frame.bytes_rx,
            uart_bytes_tx: frame.bytes_tx,
            uart_bytes_rx: frame.bytes_rx,
            upload_ms: facts.upload_ms,
            wall_ms: frame.elapsed.as_secs_f64() * 1e3,
            coproc: None,
            reference: None,
            pipeline: None,
            link: LinkReport { encoding: String::new(), baud: 0, modelled_link_s: 0.0, counters: frame.link.clone() },
            devices: Vec::new(),
            device_counters: frame.stats.iter().map(|(&k, &v)| (stat_name(k), v)).collect(),
            device_instructions: instructions.0,
            instructions_per_primary_ray: instructions.1,
            instructions_per_primary_ray_by_stage: instructions.2,
            pe_cache: None,
        }
    }
}

/// The `link` object of [`RenderStats`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LinkReport {
    /// Pixel encoding of the colour spans (`rgb888`, `rgb565`, `rle`).
    pub encoding: String,
    /// Line rate the modelled time is computed for (`--baud`).
    pub baud: u32,
    /// Wire bytes of the render (both directions; with several boards, the busiest one) ×
    /// 10 bit times / baud.
    pub modelled_link_s: f64,
    /// Retransmissions and line errors (`frames resent`, bytes, CRC errors, resyncs, …).
    #[serde(flatten)]
    pub counters: LinkStats,
}

/// Result of `gridrt bench rays`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BenchReport {
    /// Scene file.
    pub scene: String,
    /// Triangles.
    pub triangles: u32,
    /// Grid resolution.
    pub grid: [u16; 3],
    /// PEs.
    pub pe_count: u16,
    /// Image width.
    pub width: u16,
    /// Image height.
    pub height: u16,
    /// Rays per run (one per pixel).
    pub rays: u64,
    /// Rays that hit something.
    pub hits: u64,
    /// Rays clipped away by the grid box (no co-processor query).
    pub culled: u64,
    /// Timed runs.
    pub runs: u32,
    /// Untimed warm-up runs.
    pub warmup: u32,
    /// Best run time.
    pub best_ms: f64,
    /// Median run time.
    pub median_ms: f64,
    /// Nanoseconds per ray (best run).
    pub ns_per_ray: f64,
    /// Million rays per second (best run).
    pub mrays_per_s: f64,
    /// Threads of the timed run (`--threads`; the single-thread rate is reported beside it).
    pub threads: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_fields_are_flattened_and_optional() {
        let c = Comparison {
            psnr_db: None,
            identical: true,
            max_abs_diff: 0,
            differing_pixels: 0,
            hit_mismatches: Some(0),
        };
        let r = ReferenceStats::new(&c, 1.5);
        let v = serde_json::to_value(&r).unwrap();
        assert_eq!(v["psnr_db"], serde_json::Value::Null);
        assert_eq!(v["reference_ms"], 1.5);
        assert_eq!(stat_name(stat::COPROC_CYCLES), "coproc_cycles");
        assert_eq!(stat_name(Stage::Traverse.cycles_key()), "stage_traverse_cycles");
        assert_eq!(stat_name(0x30), "key_48");
        assert_eq!(stat_name(stat::HART_ROWS_BASE), "hart0_rows");
        assert_eq!(stat_name(stat::HART_BUSY_BASE + 3), "hart3_busy_cycles");
        assert_eq!(stat_name(stat::HART_WAIT_BASE + 1), "hart1_wait_cycles");
        assert_eq!(stat_name(stat::HART_WAIT_BASE + 4), "key_92");
    }
}

#[cfg(test)]
mod device_instruction_tests {
    use super::*;

    #[test]
    fn only_reported_when_the_device_counts() {
        let mut stats = BTreeMap::new();
        stats.insert(stat::PRIMARY_RAYS, 4);
        for s in Stage::ALL {
            stats.insert(s.instret_key(), 0);
        }
        assert_eq!(device_instructions(&stats, 4), (None, None, None));
        stats.insert(Stage::Traverse.instret_key(), 100);
        stats.insert(Stage::Shade.instret_key(), 20);
        stats.insert(Stage::Shade.cycles_key(), 999);
        let (by_stage, per_ray, per_ray_by_stage) = device_instructions(&stats, 4);
        let by_stage = by_stage.unwrap();
        assert_eq!(by_stage.len(), 5);
        assert_eq!((by_stage["traverse"], by_stage["shade"], by_stage["raygen"]), (100, 20, 0));
        assert_eq!(per_ray, Some(30.0));
        assert_eq!(per_ray_by_stage.unwrap()["traverse"], 25.0);
    }
}
