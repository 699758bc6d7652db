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

use super::traced::Part;
use super::{SolveParams, Solver};
use crate::exchange::near::NearChange;
use crate::links::selective::{reshoot, shoot_groups};
use crate::links::splice::splice_groups;
use crate::links::{LinkParams, ReshootStats};
use crate::scene::motion::Motion;
use crate::scene::prep::PreparedScene;
use crate::trace::Accel;
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
    /// before the move; the full update follows.
    pub fn deform(
        mut self,
        scene: PreparedScene,
        params: SolveParams,
        preview: Preview<'_>,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> (Solver, DeformStats) {
        let start = Instant::now();
        let params = params.staged();
        let same = self.gpu.is_none()
            && self.ray_hits.is_some()
            && params.links == self.params.links
            && params.tracer == self.params.tracer
            && params.bvh == self.params.bvh
            && params.kd == self.params.kd;
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
        let refitted = match &mut self.accel {
            Accel::Bvh(b) => b.update(&scene.positions, &scene.triangles) == crate::bvh::refit::Update::Refit,
            Accel::Kd(_) => {
                self.accel = Accel::build(params.tracer, &scene.positions, &scene.triangles, &params.bvh, &params.kd);
                false
            }
        };
        stats.refitted = refitted;
        stats.accel_ms = t.elapsed().as_secs_f64() * 1e3;
        let old_positions = std::mem::replace(&mut self.scene, scene).positions;
        self.params = params;
        if let Some((rays, show)) = preview {
            self.show_preview(&motion, rays, show);
            stats.preview_ms = start.elapsed().as_secs_f64() * 1e3;
        }
        let mut hits = self.ray_hits.take().expect("checked above");
        let (links, link_stats, near_redone) =
            reshoot(&self.scene, &old_positions, &motion, &self.accel, &params.links, &self.links, &mut hits);
        let near_before = std::mem::take(&mut self.links.near);
        progress(self.scene.vertex_count(), self.scene.vertex_count());
        self.links = links;
        self.links_changed();
        self.ray_hits = Some(hits);
        stats.links = link_stats;
        let t = Instant::now();
        stats.light_links_recomputed = self
            .traced
            .light_links
            .update_deformed(&self.scene, &self.accel, &params.light, &motion)
            .expect("a CPU tracer cannot fail");
        stats.light_links_ms = t.elapsed().as_secs_f64() * 1e3;
        // The near hits' light columns and gather rays: those the motion
        // can have changed traced again.
        let change =
            NearChange { before: &near_before, after: &self.links.near, redone: &near_redone, motion: &motion };
        let near = &mut self.traced.near;
        near.light.update_deformed(&self.scene, &change, &self.accel, &params.light).expect("a CPU tracer cannot fail");
        near.gather
            .update_deformed(&self.scene, &change, &self.accel, &params.near_gather, params.seed())
            .expect("a CPU tracer cannot fail");
        // Everything else is traced anew: any motion can move an emitter or
        // what shades it; the sky's refined cells follow the new links'
        // misses, the portals' rays the new positions, the near hits' sky
        // rays the new hits; the noise check is a few hundred vertices.
        self.retrace(&[Part::Emitters, Part::Sky, Part::NoiseCheck]);
        stats.emitter_links_ms = self.traced.emitter_links.ms;
        stats.ray_state_bytes = self.ray_state_bytes();
        stats.ms = start.elapsed().as_secs_f64() * 1e3;
        (self, stats)
    }

    /// The solver of `scene`, a deformation of this solver's scene (same
    /// vertices and triangles, new positions), with `params`, rebuilt in
    /// full: on the CPU path with an unchanged tracer and triangles, the BVH
    /// is refitted ([`crate::bvh::Bvh::update`], which rebuilds when the
    /// refit's SAH cost has grown past `rebuild_factor`), the kd-tree
    /// rebuilt, then links and every traced part are traced anew. Anything
    /// else builds from scratch ([`Solver::new`]). Returns the solver and
    /// whether the BVH was refitted.
    pub fn deformed(
        self,
        scene: PreparedScene,
        params: SolveParams,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> (Solver, bool) {
        let params = params.staged();
        let same_mesh = self.gpu.is_none()
            && self.scene.triangles == scene.triangles
            && params.tracer == self.params.tracer
            && params.bvh == self.params.bvh
            && params.kd == self.params.kd;
        let Accel::Bvh(mut bvh) = self.accel else {
            return (Solver::new(scene, params, progress), false);
        };
        if !same_mesh {
            return (Solver::new(scene, params, progress), false);
        }
        let refitted = bvh.update(&scene.positions, &scene.triangles) == crate::bvh::refit::Update::Refit;
        let record = scene.meshes.iter().any(|m| m.dynamic);
        (Solver::on_cpu(scene, params, Accel::Bvh(bvh), record, progress), refitted)
    }

    /// Calls `show` with the preview state of the module doc, then restores
    /// the links and light links of before the move.
    fn show_preview(&mut self, motion: &Motion, rays: u32, show: &mut dyn FnMut(&Solver)) {
        let remade: Vec<u32> = (0..self.scene.vertex_count() as u32).filter(|&v| motion.remade[v as usize]).collect();
        let coarse = LinkParams { rays_per_vertex: rays, ..self.params.links };
        let groups = shoot_groups(&self.scene, &self.accel, &coarse, &remade);
        let mut light = self.traced.light_links.clone();
        light
            .preview_deformed(&self.scene, &self.accel, &self.params.light, &remade)
            .expect("a CPU tracer cannot fail");
        let saved = splice_groups(&mut self.links, &groups);
        self.links_changed();
        std::mem::swap(&mut self.traced.light_links, &mut light);
        show(self);
        saved.restore(&mut self.links);
        self.links_changed();
        std::mem::swap(&mut self.traced.light_links, &mut light);
    }
}
