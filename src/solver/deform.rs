//! A solver after a deformation (docs/DESIGN.md §6, §7): [`Solver::deform`]
//! refits the acceleration structure, then redoes only what the motion can
//! have changed ([`crate::links::selective`] for the vertex links,
//! [`crate::exchange::LightLinks::update_deformed`] for the light links;
//! the emitter links, [`crate::exchange::sources::emitter_links`], are traced anew), optionally after
//! a preview in which the remade vertices' links are shot at
//! [`PREVIEW_RAYS`] rays and their light links from the vertices alone.
//!
//! Selective updates need the per-ray state ([`Solver::ray_hits`], kept on
//! the CPU path for scenes with dynamic meshes), the same link, tracer and
//! acceleration parameters, and the same triangles; otherwise the update
//! is a full one ([`Solver::deformed`]). Either way the result equals a
//! full solve of the deformed scene with the same seed. Times in ms.

use super::compute::{gpu_else_cpu, Tracers};
use super::traced::{Change, Inputs, Part};
use super::{Compute, SolveParams, Solver};
use crate::exchange::near::NearChange;
use crate::gpu::{GpuLinks, LogicalDevice};
use crate::kdtree::KdTree;
use crate::links::selective::{reshoot, shoot_groups};
use crate::links::splice::splice_groups;
use crate::links::{LinkParams, ReshootStats};
use crate::scene::motion::Motion;
use crate::scene::prep::PreparedScene;
use crate::trace::{Accel, Tracer};
use std::time::Instant;

/// Rays per vertex of the remade vertices in a deformation preview.
pub const PREVIEW_RAYS: u32 = 16;

/// A preview request of [`Solver::deform`]: the rays per vertex of the
/// remade vertices, and what to call with the solver in its preview state.
pub type Preview<'a> = Option<(u32, &'a mut dyn FnMut(&Solver))>;

/// Figures of one deformation update.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeformStats {
    /// Only what the motion can have changed was redone.
    pub selective: bool,
    /// The BVH was refitted (false: rebuilt, or a kd-tree built).
    pub refitted: bool,
    /// Acceleration structure update, ms.
    pub accel_ms: f64,
    /// The link figures (a full update re-shoots and rebuilds everything).
    pub links: ReshootStats,
    /// (vertex, light) entries of the light links recomputed.
    pub light_links_recomputed: u64,
    /// Time of the light links, ms.
    pub light_links_ms: f64,
    /// Emitter links traced anew (all of them), ms.
    pub emitter_links_ms: f64,
    /// Time from the start to the preview's callback returning, ms (0: no preview).
    pub preview_ms: f64,
    /// Bytes of the per-ray state kept after the update.
    pub ray_state_bytes: u64,
    /// Time of the whole update, ms.
    pub ms: f64,
}

impl DeformStats {
    /// Share of the static (not remade) vertices' rays traced again.
    pub fn static_rays_fraction(&self) -> f64 {
        self.links.static_rays_reshot as f64 / self.links.static_rays.max(1) as f64
    }
}

impl Solver {
    /// This solver brought to `scene`, a deformation of its scene (see the
    /// module doc), with `params`. With `preview = Some((rays, show))`, a
    /// selective update first calls `show` with the solver in its preview
    /// state: the remade vertices' link groups shot at `rays` rays, their
    /// light links traced from the vertices alone, everything else as
    /// before the move; the full update follows. `params` that do not
    /// pass [`SolveParams::validate`] are logged as an error and the
    /// solver's own kept: a deformation always lands.
    pub fn deform(
        mut self,
        scene: PreparedScene,
        params: SolveParams,
        preview: Preview<'_>,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> (Solver, DeformStats) {
        let start = Instant::now();
        let params = self.deform_params(params);
        let scene = self.keeping_moved_origins(scene);
        let same = self.ray_hits.is_some() && params.same_links(&self.params);
        let motion = if same { Motion::between(&self.scene, &scene) } else { None };
        let Some(motion) = motion else {
            let (s, refitted) = self.deformed(scene, params, progress);
            let rays = s.links.stats.rays;
            let stats = DeformStats {
                selective: false,
                refitted,
                links: ReshootStats {
                    rays_reshot: rays,
                    remade_vertices: s.scene.vertex_count() as u64,
                    groups_patched: s.scene.vertex_count() as u64,
                    ms: s.links.stats.shoot_ms,
                    ..Default::default()
                },
                light_links_recomputed: (s.scene.vertex_count() * s.scene.lights.len()) as u64,
                light_links_ms: s.traced.light_links.ms,
                emitter_links_ms: s.traced.emitter_links.ms,
                ray_state_bytes: s.ray_state_bytes(),
                ms: start.elapsed().as_secs_f64() * 1e3,
                ..Default::default()
            };
            return (s, stats);
        };
        let mut stats = DeformStats { selective: true, ..Default::default() };
        let t = Instant::now();
        let refitted = self.update_accel(&scene, &params);
        stats.refitted = refitted;
        stats.accel_ms = t.elapsed().as_secs_f64() * 1e3;
        let old_positions = std::mem::replace(&mut self.scene, scene).positions;
        self.params = params;
        if let Some((rays, show)) = preview {
            self.show_preview(&motion, rays, show);
            stats.preview_ms = start.elapsed().as_secs_f64() * 1e3;
        }
        let mut hits = self.ray_hits.take().expect("checked above");
        // On the GPU path the GPU re-shoots (every ray of the vertices with
        // one to trace again); where it fails, the CPU structure does.
        let batch = self.gpu.as_ref().map(|g| &g.tracer as &dyn Tracer);
        let on_gpu = batch.map(|b| {
            reshoot(&self.scene, &old_positions, &motion, &self.accel, Some(b), &params.links, &self.links, &mut hits)
        });
        let (links, link_stats, near_redone) = gpu_else_cpu("re-shooting links", on_gpu, || {
            reshoot(&self.scene, &old_positions, &motion, &self.accel, None, &params.links, &self.links, &mut hits)
                .expect("a CPU tracer cannot fail")
        });
        let near_before = std::mem::take(&mut self.links.near);
        progress(self.scene.vertex_count(), self.scene.vertex_count());
        self.links = links;
        self.links_changed();
        self.upload_links();
        self.ray_hits = Some(hits);
        stats.links = link_stats;
        // Every traced part brought along (`Traced::update`): the light
        // links, the near hits' light columns and their gather rays redo
        // what the motion can have changed; the rest is traced anew (any
        // motion can move an emitter or what shades it; the sky's refined
        // cells follow the new links' misses, the portals' rays the new
        // positions, the near hits' sky rays the new hits; the noise check
        // is a few hundred vertices).
        let tracers = Tracers::of(&self.gpu, &self.accel);
        let change = Change::Deformed(NearChange {
            before: &near_before,
            after: &self.links.near,
            redone: &near_redone,
            motion: &motion,
        });
        let inputs = Inputs { scene: &self.scene, links: &self.links, near: &self.links.near, params: &self.params };
        self.traced.update(&Part::ALL, &change, inputs, tracers);
        self.emitters_changed();
        let light = self.traced.cost(Part::LightLinks);
        (stats.light_links_recomputed, stats.light_links_ms) = (light.redone, light.ms);
        stats.emitter_links_ms = self.traced.emitter_links.ms;
        stats.ray_state_bytes = self.ray_state_bytes();
        stats.ms = start.elapsed().as_secs_f64() * 1e3;
        (self, stats)
    }

    /// `scene` (this solver's deformed) with the buried vertices' ray
    /// origins of this solver's scene: the probe reads static meshes only
    /// ([`crate::links::buried`]), which a deformation does not move.
    fn keeping_moved_origins(&self, mut scene: PreparedScene) -> PreparedScene {
        if scene.triangles == self.scene.triangles {
            scene.moved_origins = self.scene.moved_origins.clone();
        }
        scene
    }

    /// The solver of `scene`, a deformation of this solver's scene (same
    /// vertices and triangles, new positions), with `params`, rebuilt in
    /// full: with an unchanged tracer and triangles the structure is
    /// updated (`Solver::update_accel`: the BVH refitted, or rebuilt when
    /// the refit's SAH cost has grown past `rebuild_factor`; the kd-tree
    /// rebuilt; the GPU's copy or the driver's structure brought along),
    /// then links and every traced part are traced anew, on the GPU on the
    /// GPU path. Anything else builds from scratch (`Solver::new_on`).
    /// Returns the solver and whether the BVH was refitted.
    pub fn deformed(
        mut self,
        scene: PreparedScene,
        params: SolveParams,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> (Solver, bool) {
        let params = self.deform_params(params);
        let scene = self.keeping_moved_origins(scene);
        let same_mesh = self.scene.triangles == scene.triangles && params.same_structures(&self.params);
        let compute = self.compute.clone();
        if !same_mesh || (self.gpu.is_none() && !matches!(self.accel, Accel::Bvh(_))) {
            return (rebuilt(scene, params, &compute, progress), false);
        }
        let refitted = self.update_accel(&scene, &params);
        let record = scene.meshes.iter().any(|m| m.dynamic);
        let (Some(g), Compute::Gpu(gc)) = (self.gpu.take(), &compute) else {
            return (Solver::on_cpu(scene, params, self.accel, record, progress, &Part::ALL), refitted);
        };
        let label = g.tracer.dev.info.name.clone();
        let logical = vec![LogicalDevice { label, tracer: g.tracer, delay_per_vertex: Default::default() }];
        match Solver::shoot_on_gpu(&scene, &params, logical, gc, progress) {
            Ok((links, hits, gpu)) => {
                (Solver::assemble(scene, params, self.accel, links, Some(gpu), compute, hits, &Part::ALL), refitted)
            }
            Err(e) => {
                log::warn!("{e}; the deformed scene is solved on the CPU");
                (Solver::on_cpu(scene, params, self.accel, record, progress, &Part::ALL), refitted)
            }
        }
    }

    /// Brings the CPU structure and the GPU tracer to `scene`'s positions
    /// (same triangles): the BVH refitted, or rebuilt past its rebuild
    /// factor; the kd-tree rebuilt (with the GPU's parameters on the GPU
    /// path); the GPU's copy uploaded or the driver's structure refitted.
    /// Returns whether the BVH was refitted. A GPU tracer that fails to
    /// follow is dropped with a warning: the solver goes on on the CPU.
    fn update_accel(&mut self, scene: &PreparedScene, params: &SolveParams) -> bool {
        let refitted = match &mut self.accel {
            Accel::Bvh(b) => b.update(&scene.positions, &scene.triangles) == crate::bvh::refit::Update::Refit,
            Accel::Kd(_) => {
                let kd = if self.gpu.is_some() { &params.kd_gpu } else { &params.kd };
                self.accel = Accel::Kd(KdTree::build(&scene.positions, &scene.triangles, kd));
                false
            }
        };
        if let Some(g) = &mut self.gpu {
            if let Err(e) = g.tracer.update(self.accel.bvh(), self.accel.kd(), &scene.positions) {
                log::warn!("{e}; the solver goes on on the CPU");
                self.gpu = None;
            }
        }
        refitted
    }

    /// Uploads the links to the GPU after they changed (the bounces read
    /// them there); where that fails, the solver goes on on the CPU.
    fn upload_links(&mut self) {
        if let Some(g) = &mut self.gpu {
            match GpuLinks::new(g.tracer.dev.clone(), &self.links, &self.scene.albedo) {
                Ok(l) => g.links = l,
                Err(e) => {
                    log::warn!("{e}; the solver goes on on the CPU");
                    self.gpu = None;
                }
            }
        }
    }

    /// Calls `show` with the preview state of the module doc, then restores
    /// the links and light links of before the move.
    fn show_preview(&mut self, motion: &Motion, rays: u32, show: &mut dyn FnMut(&Solver)) {
        let remade: Vec<u32> = (0..self.scene.vertex_count() as u32).filter(|&v| motion.remade[v as usize]).collect();
        let coarse = LinkParams { rays_per_vertex: rays, ..self.params.links };
        let tracers = Tracers::of(&self.gpu, &self.accel);
        let scene = &self.scene;
        let groups = tracers.any("shooting the preview's links", |tr| shoot_groups(scene, tr, &coarse, &remade));
        let mut light = self.traced.light_links.clone();
        tracers.any("the preview's light links", |tr| light.preview_deformed(scene, tr, &self.params.light, &remade));
        let saved = splice_groups(&mut self.links, &groups);
        self.links_changed();
        // The GPU's bounces read the preview's links (the update uploads its own after).
        self.upload_links();
        std::mem::swap(&mut self.traced.light_links, &mut light);
        show(self);
        saved.restore(&mut self.links);
        self.links_changed();
        std::mem::swap(&mut self.traced.light_links, &mut light);
    }
}

/// A solver of `scene` built from scratch on `compute`; on the CPU where
/// the GPU fails (with a warning).
impl Solver {
    /// What a deformation runs with: `params` with the terms this solver
    /// decided off kept off; parameters that do not pass
    /// [`SolveParams::validate`] leave the solver's own in place (the
    /// deformation goes on; the error is logged).
    fn deform_params(&self, params: SolveParams) -> SolveParams {
        match params.validate() {
            Ok(()) => self.with_decisions(params),
            Err(e) => {
                log::error!("{e}; the deformation keeps the solver's parameters");
                self.params
            }
        }
    }
}

fn rebuilt(
    scene: PreparedScene,
    params: SolveParams,
    compute: &Compute,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Solver {
    match Solver::new_on(scene.clone(), params, compute, progress) {
        Ok(s) => s,
        Err(e) => {
            log::warn!("{e}; solving on the CPU");
            let record = scene.meshes.iter().any(|m| m.dynamic);
            Solver::cpu(scene, params, record, progress, &Part::ALL)
        }
    }
}
