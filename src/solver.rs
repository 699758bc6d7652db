//! The whole CPU pipeline for one prepared scene: kd-tree, vertex links,
//! light links, bounces, smoothing (DESIGN.md pipeline), with the figures
//! of every stage. Lengths in metres, irradiance in W/m^2, times in ms.

use crate::exchange::{self, GatherParams, GatherResult, LightLinkParams, LightLinks};
use crate::kdtree::{KdBuildParams, KdStats, KdTree};
use crate::links::{self, LinkParams, LinkStats, Links};
use crate::scene::prep::PreparedScene;
use crate::scene::Settings;
use glam::Vec3;
use std::time::Instant;

/// All stage parameters, defaults from DESIGN.md.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveParams {
    pub kd: KdBuildParams,
    pub links: LinkParams,
    pub light: LightLinkParams,
    pub gather: GatherParams,
    /// Feature angle of smoothing, degrees; 0: off.
    pub smoothing_angle_deg: f32,
}

impl SolveParams {
    /// Parameters with the scene's settings applied.
    pub fn from_settings(s: &Settings) -> SolveParams {
        let mut p = SolveParams::default();
        p.links.rays_per_vertex = s.rays_per_vertex;
        p.links.seed = s.seed;
        p.gather.bounces = s.bounces;
        p.smoothing_angle_deg = s.smoothing_angle_deg;
        p
    }
}

/// Figures of one solve.
#[derive(Clone, Debug, Default)]
pub struct SolveStats {
    pub vertices: usize,
    pub triangles: usize,
    pub dropped_triangles: usize,
    pub kd: KdStats,
    pub kd_bytes: usize,
    pub links: LinkStats,
    pub shadow_rays: u64,
    pub light_links_ms: f64,
    pub bounces: u32,
    pub tail_relative: f32,
    pub gather_ms: f64,
    pub smooth_ms: f64,
}

/// Per-vertex results.
#[derive(Clone, Debug, Default)]
pub struct Solution {
    /// Direct irradiance, W/m^2.
    pub e_direct: Vec<Vec3>,
    /// Indirect irradiance after smoothing, W/m^2.
    pub e_indirect: Vec<Vec3>,
    /// Indirect irradiance before smoothing, W/m^2.
    pub e_indirect_raw: Vec<Vec3>,
    pub gather: GatherResult,
    /// False when smoothing was skipped (feature angle 0): `e_indirect` is then `e_indirect_raw`.
    pub smoothed: bool,
}

/// A scene with its kd-tree, vertex links and light links built.
pub struct Solver {
    pub scene: PreparedScene,
    pub params: SolveParams,
    pub kd: KdTree,
    pub links: Links,
    pub light_links: LightLinks,
}

impl Solver {
    /// Builds the kd-tree, the vertex links (reporting `progress(done, total)`
    /// vertices) and the light links.
    pub fn new(scene: PreparedScene, params: SolveParams, progress: &(dyn Fn(usize, usize) + Sync)) -> Solver {
        let kd = KdTree::build(&scene.positions, &scene.triangles, &params.kd);
        let links = links::shoot_links(&scene, &kd, &params.links, progress);
        let light_links = LightLinks::compute(&scene, &kd, &params.light);
        Solver { scene, params, kd, links, light_links }
    }

    /// Recomputes the light links (after lights moved).
    pub fn update_lights(&mut self) {
        self.light_links = LightLinks::compute(&self.scene, &self.kd, &self.params.light);
    }

    /// Gathers the bounces and smooths.
    pub fn solve(&self) -> Solution {
        let e_direct = self.light_links.direct(&self.scene.lights, self.scene.vertex_count());
        let gather = exchange::gather(&self.links, &self.scene.albedo, &e_direct, &self.params.gather);
        let smoothed = self.params.smoothing_angle_deg > 0.0;
        let e_indirect = exchange::smooth(
            &gather.e_indirect,
            &self.scene.rings,
            &self.scene.normals,
            self.params.smoothing_angle_deg,
        );
        Solution { e_direct, e_indirect_raw: gather.e_indirect.clone(), e_indirect, gather, smoothed }
    }

    /// Figures of the built structures and of `solution`.
    pub fn stats(&self, solution: &Solution, smooth_ms: f64) -> SolveStats {
        SolveStats {
            vertices: self.scene.vertex_count(),
            triangles: self.scene.triangles.len(),
            dropped_triangles: self.scene.dropped_triangles,
            kd: self.kd.stats,
            kd_bytes: self.kd.bytes(),
            links: self.links.stats,
            shadow_rays: self.light_links.shadow_rays,
            light_links_ms: self.light_links.ms,
            bounces: solution.gather.bounces,
            tail_relative: solution.gather.tail_relative,
            gather_ms: solution.gather.ms,
            smooth_ms,
        }
    }
}

/// Convenience: build and solve in one call, timing smoothing too.
pub fn solve(scene: PreparedScene, params: SolveParams) -> (Solver, Solution, SolveStats) {
    let solver = Solver::new(scene, params, &|_, _| {});
    let t = Instant::now();
    let solution = solver.solve();
    let total_ms = t.elapsed().as_secs_f64() * 1e3;
    let stats = solver.stats(&solution, (total_ms - solution.gather.ms).max(0.0));
    (solver, solution, stats)
}
