//! The solver: one prepared scene with everything a solve reads built and
//! traced, the solve itself, and one method per change to the scene.
//!
//! A solve from scene to solution:
//!
//! 1. **Build** ([`Solver::new`], [`Solver::new_on`] for a GPU): the
//!    acceleration structure ([`crate::trace::Accel`]: the 8-wide BVH or
//!    the kd-tree; the GPU path walks the kd-tree), then every vertex's
//!    cosine-distributed link rays, whose hits merge into compact
//!    vertex-to-vertex links ([`crate::links`]), then everything else the
//!    solve reads, traced from one list (`traced.rs`): light links,
//!    emitter links, the sky's rays, the four near-hit terms and the
//!    noise check.
//! 2. **Solve** ([`Solver::solve`], the stages in order in [`solve`]):
//!    the sources (the lights' direct light, exact at the vertices; the
//!    sky's; the emitters'; the first bounce's near field and the emitter
//!    control variate), the bounces over the links on the CPU or GPU
//!    kernel with hidden vertices replaced, the later bounces' near field,
//!    the noise-aware smoothing of the gathered part, and the parts not
//!    gathered over the links added back ([`Solution`]).
//! 3. **Change** (`change.rs`, `deform.rs`): lights moved, emission or sky
//!    edited, settings changed, meshes deformed; each method retraces what
//!    the change can have changed and drops the caches derived from it,
//!    so every solve equals a fresh one.
//!
//! Lengths in metres, irradiance in W/m^2, times in ms.

use crate::exchange::{EmitterLinks, HiddenParams, LightLinks, NearField, NoiseCheck};
use crate::gpu::{self, GpuLinks, GpuTracer, GpuWalk, LogicalDevice};
use crate::kdtree::KdTree;
use crate::links::{self, Links, RayHits};
use crate::scene::prep::PreparedScene;
use crate::sky::SkyRays;
use crate::trace::{Accel, TracerKind};
use compute::Tracers;
use std::sync::{Arc, Mutex};
use traced::{Change, Inputs, Part, Traced};

pub mod adaptive;
mod change;
mod compute;
mod decide;
mod deform;
mod derived;
mod params;
mod solve;
mod stats;
mod traced;

pub use compute::{Compute, GpuCompute, GpuState};
pub use decide::TermDecision;
pub use deform::{DeformStats, Preview, PREVIEW_RAYS};
pub use params::SolveParams;
#[cfg(any(test, feature = "internals"))]
pub use solve::Sources;
pub use stats::{Solution, SolveStats};
pub use traced::PartCost;

/// A scene with its acceleration structure, vertex links and every traced
/// part built (module doc). Read with the accessors; changed with the
/// methods of `change.rs` and `deform.rs`.
pub struct Solver {
    scene: PreparedScene,
    params: SolveParams,
    /// The CPU structure rays go through: `params.tracer`'s on the CPU path,
    /// the kd-tree the GPU walks on the GPU path.
    accel: Accel,
    links: Links,
    traced: Traced,
    /// Present when links, light links and bounces run on a GPU.
    gpu: Option<GpuState>,
    compute: Compute,
    /// Every link ray's hit id, kept on the CPU path for scenes with
    /// dynamic meshes only (selective updates, [`Solver::deform`]).
    ray_hits: Option<RayHits>,
    caches: Caches,
    /// What the solve decided about the terms of
    /// [`crate::scene::terms::Terms::DECIDED`] (`decide.rs`); `None` until
    /// the near-field parts are first traced.
    decisions: Option<Vec<TermDecision>>,
}

/// What the solve derives from the links and emitter links, computed on
/// first use and kept until [`Solver::links_changed`] or
/// [`Solver::emitters_changed`] drops it.
#[derive(Default)]
struct Caches {
    /// The hidden vertices' stand-ins, with the parameters they were found
    /// with (two passes over the links: 278 ms on conference).
    stand_ins: Mutex<Option<(HiddenParams, Arc<Vec<crate::exchange::bounce::hidden::StandIn>>)>>,
    /// The emitter groups' control variate.
    emitter_cv: Mutex<Option<Arc<crate::exchange::EmitterCv>>>,
    /// The radiosity correction's weights for the current geometry.
    reconstruction: Mutex<Option<Arc<crate::exchange::Reconstruction>>>,
}

impl Solver {
    /// Builds the acceleration structure (`params.tracer`), the vertex
    /// links (reporting `progress(done, total)` vertices) and every traced
    /// part, on the CPU. Fails only where `params` do not pass
    /// [`SolveParams::validate`].
    pub fn new(
        scene: PreparedScene,
        params: SolveParams,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> crate::Result<Solver> {
        params.validate()?;
        let record = scene.meshes.iter().any(|m| m.dynamic);
        Ok(Solver::cpu(scene, params, record, progress, &Part::ALL))
    }

    /// The CPU solver of `scene` with `params` (valid): its structure
    /// (`params.tracer`) built, then [`Solver::on_cpu`].
    fn cpu(
        scene: PreparedScene,
        params: SolveParams,
        record: bool,
        progress: &(dyn Fn(usize, usize) + Sync),
        parts: &[Part],
    ) -> Solver {
        let accel = Accel::build(params.tracer, &scene.positions, &scene.triangles, &params.bvh, &params.kd);
        Solver::on_cpu(scene, params, accel, record, progress, parts)
    }

    /// The CPU solver with `accel` built over `scene`: links (with per-ray
    /// state when `record` is set: scenes with dynamic meshes, refinement
    /// rounds) and the traced `parts`.
    fn on_cpu(
        mut scene: PreparedScene,
        params: SolveParams,
        accel: Accel,
        record: bool,
        progress: &(dyn Fn(usize, usize) + Sync),
        parts: &[Part],
    ) -> Solver {
        scene.moved_origins = links::buried::find(&scene, &accel, params.links.nudge);
        let keep = links::Recording { near: params.terms.near, ray_hits: record };
        let (links, ray_hits) = links::shoot_links_recording(&scene, &accel, &params.links, keep, progress);
        Solver::assemble(scene, params, accel, links, None, Compute::Cpu, ray_hits, parts)
    }

    /// A solver of `links` over `scene` with the traced `parts` traced (the
    /// others empty until [`Solver::retrace`] traces them).
    #[allow(clippy::too_many_arguments)]
    fn assemble(
        scene: PreparedScene,
        params: SolveParams,
        accel: Accel,
        links: Links,
        gpu: Option<GpuState>,
        compute: Compute,
        ray_hits: Option<RayHits>,
        parts: &[Part],
    ) -> Solver {
        let mut s = Solver {
            scene,
            params,
            accel,
            links,
            traced: Traced::default(),
            gpu,
            compute,
            ray_hits,
            caches: Caches::default(),
            decisions: None,
        };
        s.retrace(parts);
        s
    }

    /// Builds everything on `compute`: on a GPU, the structure
    /// `params.tracer` names on the CPU and uploaded to each logical
    /// device, the links on the GPU's logical devices, and every traced
    /// part on the GPU tracer. Fails where the GPU does (no device, a
    /// driver that cannot build the structure) and where `params` do not
    /// pass [`SolveParams::validate`].
    pub fn new_on(
        scene: PreparedScene,
        params: SolveParams,
        compute: &Compute,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> crate::Result<Solver> {
        Solver::new_tracing(scene, params, compute, progress, &Part::ALL)
    }

    /// [`Solver::new_on`] with only the traced `parts` traced.
    fn new_tracing(
        mut scene: PreparedScene,
        params: SolveParams,
        compute: &Compute,
        progress: &(dyn Fn(usize, usize) + Sync),
        parts: &[Part],
    ) -> crate::Result<Solver> {
        params.validate()?;
        let g = match compute {
            Compute::Cpu => {
                let record = scene.meshes.iter().any(|m| m.dynamic);
                return Ok(Solver::cpu(scene, params, record, progress, parts));
            }
            Compute::Gpu(g) => g,
        };
        let first = g.devices.first().ok_or_else(|| crate::Error::Gpu("no GPU device to solve on".into()))?;
        let mut walk = GpuWalk::choose(params.tracer, first)?;
        let accel = match walk {
            GpuWalk::Kd => Accel::Kd(KdTree::build(&scene.positions, &scene.triangles, &params.kd_gpu)),
            GpuWalk::Bvh | GpuWalk::RayQuery => {
                Accel::build(TracerKind::Bvh, &scene.positions, &scene.triangles, &params.bvh, &params.kd)
            }
        };
        scene.moved_origins = links::buried::find(&scene, &accel, params.links.nudge);
        let mut logical = Vec::new();
        for dev in &g.devices {
            for i in 0..g.logical_per_device {
                let label =
                    if g.logical_per_device > 1 { format!("{} #{i}", dev.info.name) } else { dev.info.name.clone() };
                let delay = g.delays().get(logical.len()).copied().unwrap_or_default();
                let of = |walk| GpuTracer::of(dev.clone(), walk, &accel, &scene.positions, &scene.triangles);
                let tracer = match of(walk) {
                    // `auto` falls back from ray queries (a driver that cannot
                    // build the structure: too many triangles, out of memory) to the BVH walk.
                    Err(e) if walk == GpuWalk::RayQuery && params.tracer == TracerKind::Auto => {
                        log::warn!("{e}; tracing with the BVH walk instead of ray queries");
                        walk = GpuWalk::Bvh;
                        of(walk)?
                    }
                    t => t?,
                };
                logical.push(LogicalDevice { label, tracer, delay_per_vertex: delay });
            }
        }
        let (links, ray_hits, gpu) = Solver::shoot_on_gpu(&scene, &params, logical, g, progress)?;
        Ok(Solver::assemble(scene, params, accel, links, Some(gpu), compute.clone(), ray_hits, parts))
    }

    /// The links of `scene` shot on `logical` (their tracers walking the
    /// solver's structure), with per-ray state for scenes with dynamic
    /// meshes as on the CPU path, and the GPU state that keeps the first
    /// one's tracer for every traced part.
    fn shoot_on_gpu(
        scene: &PreparedScene,
        params: &SolveParams,
        mut logical: Vec<LogicalDevice>,
        g: &compute::GpuCompute,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> crate::Result<(Links, Option<RayHits>, GpuState)> {
        let keep = links::Recording { near: params.terms.near, ray_hits: scene.meshes.iter().any(|m| m.dynamic) };
        let (links, ray_hits, shares) =
            gpu::shoot_links_gpu(scene, &params.links, &g.schedule, &mut logical, keep, progress)?;
        let tracer = logical.swap_remove(0).tracer;
        let gpu_links = GpuLinks::new(tracer.dev.clone(), &links, &scene.albedo)?;
        Ok((links, ray_hits, GpuState { tracer, links: gpu_links, shares }))
    }

    /// Traces `parts` again for the current scene and links. The first
    /// time near-field parts are traced, the terms of
    /// [`crate::scene::terms::Terms::DECIDED`] are decided first (after
    /// the sources among `parts`; `decide.rs`).
    fn retrace(&mut self, parts: &[Part]) {
        self.update_parts(parts, &Change::Fresh)
    }

    /// Brings the traced `parts` up to date after `change`
    /// ([`traced::Traced::update`]); the near-field terms that may be left
    /// out are decided first, once the sources are traced, where they are
    /// not decided yet.
    fn update_parts(&mut self, parts: &[Part], change: &Change) {
        let decided = |p: &Part| crate::scene::terms::Terms::DECIDED.iter().any(|&n| Part::of_decided(n) == Some(*p));
        if self.decisions.is_none() && parts.iter().any(decided) {
            let (sources, rest): (Vec<Part>, Vec<Part>) = parts.iter().partition(|p| Part::SOURCES.contains(p));
            self.update_parts(&sources, change);
            self.decisions = Some(self.decide_terms());
            return self.update_parts(&rest, change);
        }
        let t = Tracers::of(&self.gpu, &self.accel);
        let inputs = Inputs { scene: &self.scene, links: &self.links, near: &self.links.near, params: &self.params };
        self.traced.update(parts, change, inputs, t);
        if parts.contains(&Part::Emitters) {
            self.emitters_changed();
        }
    }

    internal! {
        /// Checks every traced part against a fresh trace of it from this
        /// solver's scene, links and parameters (on the CPU structure): equal
        /// bit for bit in what a solve reads, whatever updates brought it here
        /// (a refinement round's split, a deformation). Parts never traced
        /// (the near field of a marking round) are left out. Returns the parts
        /// checked (or which one differs). Costs a fresh trace of each part: for tests.
        #[cfg(any(test, feature = "internals"))]
        pub fn check_traced(&self) -> Result<usize, String> {
            let parts: Vec<Part> = Part::ALL.into_iter().filter(|&p| self.traced.cost(p).traced).collect();
            let mut fresh = Traced::default();
            let no_gpu = None;
            let t = Tracers::of(&no_gpu, &self.accel);
            let inputs = Inputs { scene: &self.scene, links: &self.links, near: &self.links.near, params: &self.params };
            fresh.update(&parts, &Change::Fresh, inputs, t);
            match parts.iter().find_map(|&p| self.traced.differs(&fresh, p)) {
                Some(name) => Err(format!("the {name} differ from a fresh trace")),
                None => Ok(parts.len()),
            }
        }
    }

    internal! {
        /// Per traced part, its name and what its last update did (a
        /// refinement round's or a deformation's update, or a fresh trace).
        pub fn part_costs(&self) -> Vec<(&'static str, PartCost)> {
            Part::ALL.iter().map(|&p| (p.name(), self.traced.cost(p))).collect()
        }
    }

    internal! {
        /// What the solve decided about the near-field terms it may leave out
        /// (empty: none decided: no near hits, every such term off or forced, or `pay_share` 0).
        pub fn term_decisions(&self) -> &[TermDecision] {
            self.decisions.as_deref().unwrap_or(&[])
        }
    }

    /// Drops what was derived from the links (the hidden vertices'
    /// stand-ins, the radiosity correction, the control variate).
    fn links_changed(&mut self) {
        *self.caches.stand_ins.get_mut().unwrap_or_else(|p| p.into_inner()) = None;
        *self.caches.reconstruction.get_mut().unwrap_or_else(|p| p.into_inner()) = None;
        self.emitters_changed();
    }

    /// Drops what was derived from the links and emitter links together
    /// (the control variate's coefficients).
    fn emitters_changed(&mut self) {
        *self.caches.emitter_cv.get_mut().unwrap_or_else(|p| p.into_inner()) = None;
    }

    /// The scene as the solver sees it now.
    pub fn scene(&self) -> &PreparedScene {
        &self.scene
    }

    /// The parameters its stages run with: those it was built or last set
    /// with, and the terms it decided off (`decide.rs`) off.
    pub fn params(&self) -> &SolveParams {
        &self.params
    }

    internal! {
        /// The CPU acceleration structure.
        pub fn accel(&self) -> &Accel {
            &self.accel
        }
    }

    internal! {
        /// The vertex links.
        pub fn links(&self) -> &Links {
            &self.links
        }
    }

    internal! {
        /// The light links.
        pub fn light_links(&self) -> &LightLinks {
            &self.traced.light_links
        }
    }

    internal! {
        /// The emitter links.
        pub fn emitter_links(&self) -> &EmitterLinks {
            &self.traced.emitter_links
        }
    }

    internal! {
        /// The sky's refined cells and portal samples.
        pub fn sky_rays(&self) -> &SkyRays {
            &self.traced.sky
        }
    }

    internal! {
        /// The near-hit terms.
        pub fn near(&self) -> &NearField {
            &self.traced.near
        }
    }

    internal! {
        /// The noise check.
        pub fn noise_check(&self) -> &NoiseCheck {
            &self.traced.noise_check
        }
    }

    internal! {
        /// The GPU state, when links and bounces run on a GPU.
        pub fn gpu(&self) -> Option<&GpuState> {
            self.gpu.as_ref()
        }
    }

    internal! {
        /// Where the solver computes.
        #[cfg(any(test, feature = "internals"))]
        pub fn compute(&self) -> &Compute {
            &self.compute
        }
    }

    /// Checks every structure and table against the scene (the tests call it).
    pub fn validate(&self) -> Result<(), String> {
        let n = self.scene.vertex_count();
        let rays = self.params.links.rays_per_vertex as usize;
        self.accel.validate().map_err(|e| format!("acceleration structure: {e}"))?;
        self.links.validate().map_err(|e| format!("links: {e}"))?;
        self.traced.emitter_links.validate(n).map_err(|e| format!("emitter links: {e}"))?;
        self.traced.sky.validate(n, rays).map_err(|e| format!("sky rays: {e}"))?;
        let shape = crate::exchange::near::Shape {
            vertices: n,
            near_hits: self.links.near.rows.items.len(),
            triangles: self.scene.triangles.len(),
            groups: self.traced.emitter_links.group_vertex.len(),
        };
        self.traced.near.validate(&shape)?;
        self.emitter_cv().validate(n).map_err(|e| format!("emitter control variate: {e}"))?;
        self.traced.noise_check.validate(n).map_err(|e| format!("noise check: {e}"))
    }

    internal! {
        /// Every link ray's hit id (CPU path, scenes with dynamic meshes only).
        #[cfg(any(test, feature = "internals"))]
        pub fn ray_hits(&self) -> Option<&RayHits> {
            self.ray_hits.as_ref()
        }
    }

    internal! {
        /// Bytes of the per-ray state kept for selective updates.
        pub fn ray_state_bytes(&self) -> u64 {
            self.ray_hits.as_ref().map_or(0, |h| h.bytes())
        }
    }

    /// The tracer the rays go through: "bvh" or "kd" on the CPU path;
    /// "gpu-bvh", "gpu-kd" or "gpu-rq" on the GPU path.
    pub fn tracer_name(&self) -> &'static str {
        match &self.gpu {
            Some(g) => g.tracer.walk().name(),
            None => self.accel.kind().name(),
        }
    }

    internal! {
        /// Build time of the CPU wide BVH, ms; NaN when this solver has none.
        pub fn bvh_build_ms(&self) -> f64 {
            self.accel.bvh().map_or(f64::NAN, |b| b.stats.build_ms)
        }
    }

    internal! {
        /// Build time of the acceleration structure the rays went through, ms.
        pub fn accel_build_ms(&self) -> f64 {
            self.accel.build_ms()
        }
    }

    /// Figures of the built structures and of `solution`.
    pub fn stats(&self, solution: &Solution, smooth_ms: f64) -> SolveStats {
        let t = &self.traced;
        let near = |c: crate::exchange::near::Cost| (c.rays, c.ms);
        use crate::exchange::near::NearTerm;
        let (near_rays, near_ms) = near(t.near.light.cost());
        let (near_emitter_rays, near_emitter_ms) = near(t.near.emitters.cost());
        let (near_sky_rays, near_sky_ms) = near(t.near.sky.cost());
        let (near_gather_rays, near_gather_ms) = near(t.near.gather.cost());
        SolveStats {
            vertices: self.scene.vertex_count(),
            triangles: self.scene.triangles.len(),
            dropped_triangles: self.scene.dropped_triangles,
            accel_build_ms: self.accel.build_ms(),
            accel_bytes: self.accel.bytes(),
            kd: self.accel.kd().map(|k| k.stats),
            bvh: self.accel.bvh().map(|b| b.stats),
            links: self.links.stats,
            shadow_rays: t.light_links.shadow_rays,
            light_links_ms: t.light_links.ms,
            emitter_rays: t.emitter_links.shadow_rays,
            emitter_links_ms: t.emitter_links.ms,
            sky_rays: t.sky.refine.rays,
            sky_ms: t.sky.refine.ms,
            portal_rays: t.sky.portals.rays,
            portal_ms: t.sky.portals.ms,
            noise_check_rays: t.noise_check.rays,
            noise_check_ms: t.noise_check.ms,
            near_hits: self.links.near.rows.items.len() as u64,
            near_emitter_rays,
            near_emitter_ms,
            near_sky_rays,
            near_sky_ms,
            near_gather_rays,
            near_gather_ms,
            near_rays,
            near_ms,
            bounces: solution.gather.bounces,
            tail_relative: solution.gather.tail_relative,
            gather_ms: solution.gather.ms,
            smooth_ms,
            backend: self.compute.describe(),
            tracer: self.tracer_name().to_string(),
            bvh_build_ms: self.bvh_build_ms(),
            shadow_rays_per_second: t.light_links.shadow_rays as f64 / (t.light_links.ms.max(1e-9) * 1e-3),
            devices: self.gpu.as_ref().map(|g| g.shares.clone()).unwrap_or_default(),
            ray_state_bytes: self.ray_state_bytes(),
            cpu_traced_rays: if self.gpu.is_none() { self.links.stats.rays } else { 0 } + t.cpu_rays(),
        }
    }
}
