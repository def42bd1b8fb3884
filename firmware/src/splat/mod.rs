//! Seed 001's point-splat renderer (Maršík 2008): oriented points → 64-bit codewords →
//! depth-tested 16-line stripe buffer → finished lines. SPEC.md §6 has the formats.
//!
//! | module | unit of the point-splatting design | what |
//! |---|---|---|
//! | [`table`] | the PC's precomputed tables | the shape table `LUT[size][nx][ny]` of codeword templates |
//! | [`codegen`] | the DSP ("code generator") | transform, lookup, codewords, Y buckets, `shift` commands |
//! | [`stage`] | the FPGA render core | decoder, material table, lighting, depth test, stripe ring |
//!
//! Both halves run in the firmware: the co-processor's FSL link carries one ray request at a
//! time and has no opcode for splats, while the stage needs only 48 KiB of line buffers and a
//! word-at-a-time interface ([`stage::SplatStage::push`]), exactly what a hardware block
//! behind a FIFO would take; the codeword stream between the two is the seed's DMA stream.
//! [`SplatEngine`] owns the points, the table, the buckets and the stage, and renders a pass.

pub mod codegen;
pub mod stage;
pub mod table;

use codegen::{Buckets, CodegenStats, Pass, SplatLight, SplatPoint, View};
use gridrt_shared::math::Vec3;
use gridrt_shared::scene::{PointRecord, PointsHead, SceneError};
use gridrt_shared::splat::MaterialTerm;
use stage::{SplatStage, StageError};
use table::{ShapeTable, TableConfig, TableError};

/// Counters of a splat pass (or a sum of passes).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SplatStats {
    /// Code generator counters.
    pub codegen: CodegenStats,
    /// Box pixels the stage depth-tested.
    pub fragments: u64,
    /// `[cycles, instructions]` of the code generator.
    pub codegen_clock: [u64; 2],
    /// `[cycles, instructions]` of the stage.
    pub stage_clock: [u64; 2],
}

impl SplatStats {
    /// Adds another pass's counters.
    pub fn add(&mut self, o: &Self) {
        let c = &mut self.codegen;
        c.points += o.codegen.points;
        c.culled += o.codegen.culled;
        c.clamped += o.codegen.clamped;
        c.codewords += o.codegen.codewords;
        c.commands += o.codegen.commands;
        self.fragments += o.fragments;
        for i in 0..2 {
            self.codegen_clock[i] = self.codegen_clock[i].wrapping_add(o.codegen_clock[i]);
            self.stage_clock[i] = self.stage_clock[i].wrapping_add(o.stage_clock[i]);
        }
    }
}

/// Why a pass failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PassError<E> {
    /// The shape table could not be built.
    Table(TableError),
    /// The stage refused a word (a firmware bug: the generator writes only valid words).
    Stage(StageError),
    /// The line consumer failed.
    Line(E),
}

/// Points, shape table, buckets and stage of the splat path: up to `P` points and a table of
/// up to `T` words.
pub struct SplatEngine<const P: usize, const T: usize> {
    points: heapless::Vec<SplatPoint, P>,
    bounds: [Vec3; 2],
    /// Points announced by the scene's point section (≤ `P`).
    expected: u32,
    table: ShapeTable<T>,
    buckets: Buckets<P>,
    stage: SplatStage,
}

impl<const P: usize, const T: usize> SplatEngine<P, T> {
    /// No points, no table yet.
    pub const fn new() -> Self {
        Self {
            points: heapless::Vec::new(),
            bounds: [Vec3::ZERO, Vec3::ZERO],
            expected: 0,
            table: ShapeTable::new(),
            buckets: Buckets::new(),
            stage: SplatStage::new(),
        }
    }

    /// Drops the points (a new scene is coming).
    pub fn clear(&mut self) {
        self.points.clear();
        self.expected = 0;
    }

    /// The point section's head: refuses more points than fit.
    pub fn begin(&mut self, head: &PointsHead) -> Result<(), SceneError> {
        self.points.clear();
        if head.count as usize > P {
            return Err(SceneError::TooManyPoints);
        }
        self.expected = head.count;
        self.bounds = [Vec3::from_array(head.bounds_min), Vec3::from_array(head.bounds_max)];
        // The table is built once, while the scene loads, not in the first frame's time (a
        // table that does not fit fails that frame with `PassError::Table`).
        if head.count > 0 {
            let _ = self.table.build(TableConfig::DEVICE);
        }
        Ok(())
    }

    /// One point record (validated by the scene parser).
    pub fn push(&mut self, p: &PointRecord) -> Result<(), SceneError> {
        let normal = Vec3::from_array(p.normal).try_normalize().ok_or(SceneError::BadRecord)?;
        let sp = SplatPoint { pos: Vec3::from_array(p.pos), normal, radius: p.radius, material: p.material as u8 };
        self.points.push(sp).map_err(|_| SceneError::TooManyPoints)
    }

    /// The points loaded.
    pub fn points(&self) -> &[SplatPoint] {
        &self.points
    }

    /// Box of the whole cloud (from the point section's head).
    pub fn bounds(&self) -> [Vec3; 2] {
        self.bounds
    }

    /// True when the scene has a point section with every point loaded.
    pub fn has_points(&self) -> bool {
        self.expected as usize == self.points.len()
    }

    /// Builds the shape table for `config` (once; later calls with the same config are free).
    pub fn build_table(&mut self, config: TableConfig) -> Result<(), TableError> {
        self.table.build(config)
    }

    /// Renders one pass: files the points, streams the codewords into the stage, and hands
    /// every finished line of the pass to `line(y, colours 0x00RRGGBB, depths)` top to bottom
    /// (`y` an image row). `clock()` returns `[cycles, instructions]` for the counters.
    #[allow(clippy::too_many_arguments)]
    pub fn render_pass<E>(
        &mut self,
        view: &View,
        light: &SplatLight,
        pass: &Pass,
        materials: &[[MaterialTerm; 3]],
        ambient: u8,
        background: u32,
        clock: &dyn Fn() -> [u64; 2],
        line: &mut impl FnMut(u16, &[u32], &[u16]) -> Result<(), E>,
    ) -> Result<SplatStats, PassError<E>> {
        if self.table.config().is_none() {
            self.table.build(TableConfig::DEVICE).map_err(PassError::Table)?;
        }
        let mut st = SplatStats::default();
        let t0 = clock();
        codegen::file_points(&self.points, &self.table, view, light, pass, &mut self.buckets, &mut st.codegen);
        let stage = &mut self.stage;
        stage.begin(pass.columns, background, view.pixel_depth);
        stage.fragments = 0;
        let (y0, rows) = (pass.y0 as u32, pass.rows as u32);
        let mut in_stage = [0u64; 2];
        let mut failure = None;
        let mut emit = |w: u64| -> Result<(), ()> {
            let a = clock();
            let r = stage.push(w, &mut |l, c: &[u32], d: &[u16]| {
                // Stripe line l is image row y0 − 7 + l; lines above the pass are not its own.
                match l.checked_sub(7) {
                    Some(r) if r < rows => line((y0 + r) as u16, c, d),
                    _ => Ok(()),
                }
            });
            let b = clock();
            in_stage[0] = in_stage[0].wrapping_add(b[0].wrapping_sub(a[0]));
            in_stage[1] = in_stage[1].wrapping_add(b[1].wrapping_sub(a[1]));
            r.map_err(|e| {
                failure = Some(e);
            })
        };
        let streamed = codegen::stream(
            &self.table,
            materials,
            ambient,
            pass,
            view.pixel_depth,
            &mut self.buckets,
            &mut st.codegen,
            &mut emit,
        );
        let t1 = clock();
        st.fragments = self.stage.fragments;
        st.stage_clock = in_stage;
        st.codegen_clock =
            [t1[0].wrapping_sub(t0[0]).wrapping_sub(in_stage[0]), t1[1].wrapping_sub(t0[1]).wrapping_sub(in_stage[1])];
        match (streamed, failure) {
            (Ok(()), _) => Ok(st),
            (Err(()), Some(Ok(e))) => Err(PassError::Stage(e)),
            (Err(()), Some(Err(e))) => Err(PassError::Line(e)),
            (Err(()), None) => Err(PassError::Stage(StageError::MaterialOverflow)),
        }
    }
}

/// Where the scene loader puts the point section (SPEC.md §5.10).
pub trait PointSink {
    /// A new scene: forget the points.
    fn clear(&mut self);
    /// The section's head.
    fn begin(&mut self, head: &PointsHead) -> Result<(), SceneError>;
    /// The next point.
    fn push(&mut self, p: &PointRecord) -> Result<(), SceneError>;
}

/// A device without the splat path: refuses any point section.
pub struct NoPoints;

impl PointSink for NoPoints {
    fn clear(&mut self) {}
    fn begin(&mut self, _head: &PointsHead) -> Result<(), SceneError> {
        Err(SceneError::TooManyPoints)
    }
    fn push(&mut self, _p: &PointRecord) -> Result<(), SceneError> {
        Err(SceneError::TooManyPoints)
    }
}

impl<const P: usize, const T: usize> PointSink for SplatEngine<P, T> {
    fn clear(&mut self) {
        SplatEngine::clear(self);
    }
    fn begin(&mut self, head: &PointsHead) -> Result<(), SceneError> {
        SplatEngine::begin(self, head)
    }
    fn push(&mut self, p: &PointRecord) -> Result<(), SceneError> {
        SplatEngine::push(self, p)
    }
}

impl<const P: usize, const T: usize> Default for SplatEngine<P, T> {
    fn default() -> Self {
        Self::new()
    }
}
