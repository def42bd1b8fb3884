//! Watertightness probe: one ray aimed at a shared edge or vertex of a mesh, crossing the
//! surface transversally there, tested with a kernel against the closed disk of triangles
//! around its aim point, and settled by the exact reference when the kernel finds nothing.
//!
//! Source: pbrt-v4's `TEST(Triangle, Watertight)` (src/pbrt/shapes_test.cpp): rays from
//! inside a closed, jittered sphere mesh must never get out. Made local: the "fan" of a probe
//! is a topological disk around the aim point — the star of a vertex, or the union of the
//! stars of an edge's two endpoints — and the ray crosses it transversally near its centre
//! (the caller keeps it within ~30° of the surface normal). Rounding may move the ray, or
//! which triangle of the disk it hits, by ~10⁻⁷ of the scene size, but a watertight test
//! cannot let a transversal ray through a disk whose boundary is a whole edge length away.
//! So a kernel that hits *none* of the disk's triangles while the exact predicates
//! (`crate::exact`) say the ray crosses the disk has a crack: a leak.
//!
//! (Counting only the two triangles of an edge, or rays from outside a convex mesh at
//! grazing angles, is not a crack test: a grazing ray that the exact geometry lets enter and
//! leave within 10⁻⁶ may miss the rounded geometry entirely, consistently.)

use crate::exact;
use crate::isect::{Intersector, Record, Triangle};
use crate::numeric::Overflow;
use gridrt_shared::math::Ray;

/// Outcome of one probe.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Probe {
    /// The kernel hit a triangle of the fan.
    Caught,
    /// The exact reference says the ray crosses the disk in front of its origin, but the
    /// kernel hit none of its triangles: a crack.
    Leak,
    /// The kernel hit nothing and at least one test overflowed its fixed-point range
    /// (reported separately: not a crack, not a pass).
    Overflow,
    /// Neither the kernel nor the exact reference finds a hit (the ray does not cross the
    /// disk, e.g. it starts beyond it): not counted.
    Outside,
}

/// Tests `ray` against the disk `fan` (triangles with their records precomputed by `is`).
pub fn probe(is: &Intersector, fan: &[(Triangle, Record)], ray: &Ray) -> Probe {
    let mut overflow = false;
    for (_, rec) in fan {
        match is.intersect(ray, rec, f32::INFINITY) {
            Ok(Some(_)) => return Probe::Caught,
            Ok(None) => {}
            Err(Overflow) => overflow = true,
        }
    }
    if overflow {
        return Probe::Overflow;
    }
    if fan.iter().any(|(tri, _)| exact::intersect(ray, tri).is_some()) {
        Probe::Leak
    } else {
        Probe::Outside
    }
}

/// Counts of a series of probes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ProbeStats {
    /// Rays probed.
    pub rays: u64,
    /// Rays caught by the kernel.
    pub caught: u64,
    /// Cracks (see [`Probe::Leak`]).
    pub leaks: u64,
    /// Fixed-point overflows.
    pub overflows: u64,
    /// Rays outside the fan by the exact reference too.
    pub outside: u64,
}

impl ProbeStats {
    /// Adds one outcome.
    pub fn add(&mut self, p: Probe) {
        self.rays += 1;
        match p {
            Probe::Caught => self.caught += 1,
            Probe::Leak => self.leaks += 1,
            Probe::Overflow => self.overflows += 1,
            Probe::Outside => self.outside += 1,
        }
    }

    /// Leaks per ray that the exact reference says crosses the fan (0 when there is none).
    pub fn leak_rate(&self) -> f64 {
        let applicable = self.rays - self.outside;
        if applicable == 0 {
            0.0
        } else {
            self.leaks as f64 / applicable as f64
        }
    }
}
