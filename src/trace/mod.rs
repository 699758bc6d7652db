//! One tracing interface for every stage that traces rays (docs/DESIGN.md §1b):
//! link shooting, light links, the reference path tracer and the CPU
//! renderer ask a [`Tracer`] for closest hits (link rays) and any-hit
//! visibility (shadow rays), whatever answers them: the CPU wide BVH
//! ([`crate::bvh::Bvh`], the CPU default), the CPU kd-tree rope walk
//! ([`crate::kdtree::KdTree`], the GPU shader's oracle) or the wgpu compute
//! tracer ([`crate::gpu::GpuTracer`]).
//!
//! [`CpuTracer`] adds single-ray queries and the rays of one origin (a
//! vertex's rays), which the CPU structures answer without batching;
//! [`Accel`] is the CPU structure a solver built, chosen by
//! [`TracerKind`] (`tracer = "auto" | "bvh" | "kd" | "rq"` in the scene TOML, `--tracer`).
//!
//! The core every tracer shares lives in [`ray`]: the ray segment and its
//! one shadow-segment rule, the hit, the triangle as traced and the
//! watertight triangle test; the kd-tree and the BVH import it, and only
//! this module's [`Accel`] imports them. Every tracer orders hits with equal `t` by triangle
//! id, so they return the same hit for the same ray (up to the documented
//! rope-walk ties of [`crate::kdtree`]). Distances are metres along unit
//! directions.

use crate::bvh::Bvh;
use crate::kdtree::KdTree;
use crate::trace::ray::{Hit, Ray};
use glam::Vec3;
use rayon::prelude::*;

pub mod ray;

pub use crate::scene::TracerKind;

/// How far rays leave a surface, and how short of their end shadow segments
/// stop ([`Ray::shadow`]), as a fraction of the local length: the mean edge
/// at a vertex (light and emitter links), the hit triangle's longest edge at
/// a near hit (the near field's rays). One value for every stage: it keeps
/// f32 rounding of the start point off the surface it leaves and is far
/// below any feature the solver resolves.
pub const RAY_OFFSET: f32 = 1e-4;

/// Rays of several origins sharing one table of local directions (the
/// vertex ray sets of link shooting): origin `i` shoots the
/// `per_origin` directions of set `sets[i]`
/// (`directions[sets[i] * per_origin..][..per_origin]`), each turned into
/// its frame `frames[i]` (tangent, bitangent, normal) with
/// [`crate::sampling::world_direction`], over `[0, inf)`, skipping vertex
/// `skip[i]`. Answers come origin after origin, in direction order.
#[derive(Clone, Debug, Default)]
pub struct OriginRays {
    /// Ray origins, metres.
    pub origins: Vec<Vec3>,
    /// The vertex each origin's rays skip.
    pub skip: Vec<u32>,
    /// Each origin's frame (tangent, bitangent, normal).
    pub frames: Vec<(Vec3, Vec3, Vec3)>,
    /// Which direction set each origin shoots.
    pub sets: Vec<u32>,
    /// The direction sets (local frame, unit), one after the other.
    pub directions: Vec<Vec3>,
    /// Directions a set.
    pub per_origin: usize,
}

impl OriginRays {
    /// Rays in the batch.
    pub fn len(&self) -> usize {
        self.origins.len() * self.per_origin
    }

    /// True when the batch holds no ray.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Origin `i`'s world directions, in order.
    pub fn world_directions(&self, i: usize) -> impl Iterator<Item = Vec3> + '_ {
        let set = self.sets[i] as usize * self.per_origin;
        let frame = self.frames[i];
        self.directions[set..set + self.per_origin].iter().map(move |d| crate::sampling::world_direction(frame, *d))
    }
}

/// Batches of rays: closest hits, any-hit visibility and the rays of
/// several origins sharing a direction table.
pub trait Tracer: Sync {
    /// Short name for figures ("bvh", "kd", "gpu-bvh", "gpu-kd", "gpu-rq").
    #[cfg(any(test, feature = "internals"))]
    fn name(&self) -> &'static str;

    /// The nearest hit of every ray of `batch` (see [`OriginRays`]),
    /// origin after origin.
    fn origin_rays(&self, batch: &OriginRays) -> crate::Result<Vec<Option<Hit>>>;

    /// The nearest hit (front or back face) of every ray in `[tmin, tmax]`,
    /// ignoring triangles with the ray's `skip` vertex as a corner; `None`
    /// where the ray meets nothing.
    fn closest_hits(&self, rays: &[Ray]) -> crate::Result<Vec<Option<Hit>>>;

    /// Any-hit: `true` where nothing (front or back face) lies on the
    /// segment `[tmin, tmax]` of the ray.
    fn visible(&self, rays: &[Ray]) -> crate::Result<Vec<bool>>;
}

/// Rays in a run of this many share start hints (nearby shadow rays).
const RUN: usize = 64;

/// Single rays and rays of one origin, answered on the CPU. Every CPU
/// tracer is a [`Tracer`] too: batches are split over rayon threads.
pub trait CpuTracer: Sync {
    /// Short name for figures ("bvh", "kd").
    #[cfg(any(test, feature = "internals"))]
    fn name(&self) -> &'static str;

    /// Nearest hit of one ray (see [`Tracer::closest_hits`]).
    fn intersect(&self, ray: &Ray) -> Option<Hit>;

    /// True if anything lies on the ray's segment.
    fn occluded(&self, ray: &Ray) -> bool;

    /// Nearest hits of rays leaving `origin` along `dirs` (unit), each
    /// skipping `skip`, into `out[i]` for `dirs[i]` (`t` in `[0, inf)`).
    /// A tracer may share work between them; the hits are those of
    /// [`CpuTracer::intersect`].
    fn intersect_origin(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        for (d, o) in dirs.iter().zip(out.iter_mut()) {
            *o = self.intersect(&Ray { origin, dir: *d, tmin: 0.0, tmax: f32::INFINITY, skip });
        }
    }

    /// Nearest hits of a run of rays, `out[i]` for `rays[i]`. A tracer may
    /// walk several at once; the hits are those of [`CpuTracer::intersect`].
    fn intersect_run(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = self.intersect(r);
        }
    }

    /// Visibility of a run of nearby shadow rays (one vertex's
    /// oversampling points), `out[i]` for `rays[i]`. A tracer may carry
    /// start hints from ray to ray; the answers are those of
    /// [`CpuTracer::occluded`].
    fn visible_run(&self, rays: &[Ray], out: &mut [bool]) {
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = !self.occluded(r);
        }
    }
}

impl<T: CpuTracer> Tracer for T {
    #[cfg(any(test, feature = "internals"))]
    fn name(&self) -> &'static str {
        CpuTracer::name(self)
    }

    /// Each origin's rays together ([`CpuTracer::intersect_origin`]), origins over rayon threads.
    fn origin_rays(&self, batch: &OriginRays) -> crate::Result<Vec<Option<Hit>>> {
        let mut out = vec![None; batch.len()];
        if batch.per_origin > 0 {
            out.par_chunks_mut(batch.per_origin).enumerate().for_each(|(i, o)| {
                let dirs: Vec<Vec3> = batch.world_directions(i).collect();
                self.intersect_origin(batch.origins[i], batch.skip[i], &dirs, o);
            });
        }
        Ok(out)
    }

    /// Runs of `RUN` rays ([`CpuTracer::intersect_run`]) over rayon threads.
    fn closest_hits(&self, rays: &[Ray]) -> crate::Result<Vec<Option<Hit>>> {
        let mut out = vec![None; rays.len()];
        out.par_chunks_mut(RUN).zip(rays.par_chunks(RUN)).for_each(|(o, r)| self.intersect_run(r, o));
        Ok(out)
    }

    /// Runs of `RUN` nearby rays ([`CpuTracer::visible_run`]) over rayon threads.
    fn visible(&self, rays: &[Ray]) -> crate::Result<Vec<bool>> {
        let mut out = vec![false; rays.len()];
        out.par_chunks_mut(RUN).zip(rays.par_chunks(RUN)).for_each(|(o, r)| self.visible_run(r, o));
        Ok(out)
    }
}

/// The CPU acceleration structure a solver traces with.
#[derive(Clone, Debug)]
pub enum Accel {
    /// The 8-wide BVH.
    Bvh(Bvh),
    /// The kd-tree with ropes.
    Kd(KdTree),
}

impl Accel {
    /// Builds the CPU structure `kind` names ([`TracerKind::cpu`]) over `triangles` (vertex ids into
    /// `positions`) with its parameters.
    pub fn build(
        kind: TracerKind,
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        bvh: &crate::bvh::BvhBuildParams,
        kd: &crate::kdtree::KdBuildParams,
    ) -> Accel {
        match kind.cpu() {
            TracerKind::Kd => Accel::Kd(KdTree::build(positions, triangles, kd)),
            _ => Accel::Bvh(Bvh::build(positions, triangles, bvh)),
        }
    }

    /// Which structure this is.
    pub fn kind(&self) -> TracerKind {
        match self {
            Accel::Bvh(_) => TracerKind::Bvh,
            Accel::Kd(_) => TracerKind::Kd,
        }
    }

    /// Build time, ms.
    pub fn build_ms(&self) -> f64 {
        match self {
            Accel::Bvh(b) => b.stats.build_ms,
            Accel::Kd(k) => k.stats.build_ms,
        }
    }

    /// Bytes of the structure.
    pub fn bytes(&self) -> usize {
        match self {
            Accel::Bvh(b) => b.bytes(),
            Accel::Kd(k) => k.bytes() + k.accel.bytes(),
        }
    }

    /// Checks the structure's invariants (see each structure's `validate`).
    pub fn validate(&self) -> Result<(), String> {
        match self {
            Accel::Bvh(b) => b.validate(),
            Accel::Kd(k) => k.validate(),
        }
    }

    /// The kd-tree, when this is one.
    pub fn kd(&self) -> Option<&KdTree> {
        match self {
            Accel::Kd(k) => Some(k),
            Accel::Bvh(_) => None,
        }
    }

    /// The BVH, when this is one.
    pub fn bvh(&self) -> Option<&Bvh> {
        match self {
            Accel::Bvh(b) => Some(b),
            Accel::Kd(_) => None,
        }
    }
}

impl CpuTracer for Accel {
    #[cfg(any(test, feature = "internals"))]
    fn name(&self) -> &'static str {
        self.kind().name()
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match self {
            Accel::Bvh(b) => b.intersect(ray),
            Accel::Kd(k) => k.intersect(ray),
        }
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        match self {
            Accel::Bvh(b) => b.occluded(ray),
            Accel::Kd(k) => k.occluded(ray),
        }
    }

    fn intersect_origin(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        match self {
            Accel::Bvh(b) => b.intersect_origin(origin, skip, dirs, out),
            Accel::Kd(k) => k.intersect_origin(origin, skip, dirs, out),
        }
    }

    fn intersect_run(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        match self {
            Accel::Bvh(b) => b.intersect_run(rays, out),
            Accel::Kd(k) => k.intersect_run(rays, out),
        }
    }

    fn visible_run(&self, rays: &[Ray], out: &mut [bool]) {
        match self {
            Accel::Bvh(b) => b.visible_run(rays, out),
            Accel::Kd(k) => k.visible_run(rays, out),
        }
    }
}

impl CpuTracer for KdTree {
    #[cfg(any(test, feature = "internals"))]
    fn name(&self) -> &'static str {
        "kd"
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        KdTree::intersect(self, ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        KdTree::occluded(self, ray)
    }

    /// The walk from the root to the start leaf is shared per direction
    /// octant ([`crate::kdtree::traverse::StartLeaves`]); runs a build of
    /// the walk for AVX2 where the CPU has it (the same arithmetic, so the
    /// same hits: Rust never fuses a multiply and an add).
    fn intersect_origin(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2 (checked just above).
            unsafe { kd_origin_avx2(self, origin, skip, dirs, out) };
            return;
        }
        kd_origin(self, origin, skip, dirs, out)
    }

    /// Consecutive rays share a start-leaf hint ([`crate::kdtree::traverse::LeafHint`]).
    fn visible_run(&self, rays: &[Ray], out: &mut [bool]) {
        let mut hint = crate::kdtree::traverse::LeafHint::default();
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            *o = !self.occluded_near(r, &mut hint);
        }
    }
}

#[inline(always)]
fn kd_origin(kd: &KdTree, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
    let mut start = crate::kdtree::traverse::StartLeaves::new(origin);
    for (d, o) in dirs.iter().zip(out.iter_mut()) {
        *o = kd.intersect_from(&Ray { origin, dir: *d, tmin: 0.0, tmax: f32::INFINITY, skip }, &mut start);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn kd_origin_avx2(kd: &KdTree, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
    kd_origin(kd, origin, skip, dirs, out)
}

impl CpuTracer for Bvh {
    #[cfg(any(test, feature = "internals"))]
    fn name(&self) -> &'static str {
        "bvh"
    }

    #[inline]
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        Bvh::intersect(self, ray)
    }

    #[inline]
    fn occluded(&self, ray: &Ray) -> bool {
        Bvh::occluded(self, ray)
    }

    fn intersect_origin(&self, origin: Vec3, skip: u32, dirs: &[Vec3], out: &mut [Option<Hit>]) {
        Bvh::intersect_origin(self, origin, skip, dirs, out)
    }

    fn intersect_run(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        Bvh::intersect_run(self, rays, out)
    }

    fn visible_run(&self, rays: &[Ray], out: &mut [bool]) {
        Bvh::visible_run(self, rays, out)
    }
}
