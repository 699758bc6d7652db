//! The sweep over rays per vertex, bounces and smoothing (see
//! [`crate::accuracy`]): links built once per ray count, gather and
//! smoothing redone per setting, each setting timed (ms) and compared with
//! the reference.

use super::metrics::{error_stats, ErrorStats};
use crate::exchange;
use crate::reference::Reference;
use crate::scene::{prep::PreparedScene, Bounces};
use crate::solver::{SolveParams, Solver};
use glam::Vec3;
use serde::Serialize;
use std::time::Instant;

/// What to sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepParams {
    /// Rays per vertex (square numbers; default 16, 64, 256, 1024).
    pub rays: Vec<u32>,
    /// Bounce settings (default 1..=6 and auto).
    pub bounces: Vec<Bounces>,
    /// Feature angle of smoothing when on, degrees (default: the scene's, or 30 if it has none).
    pub smoothing_angle_deg: Option<f32>,
}

impl Default for SweepParams {
    fn default() -> Self {
        Self {
            rays: vec![16, 64, 256, 1024],
            bounces: (1..=6).map(Bounces::Fixed).chain([Bounces::Auto]).collect(),
            smoothing_angle_deg: None,
        }
    }
}

/// One setting's run times (ms) and errors.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SweepRow {
    /// Rays per vertex.
    pub rays: u32,
    /// "1".."6" or "auto".
    pub bounces: String,
    /// Bounces the gather ran.
    pub bounces_used: u32,
    /// Feature angle, degrees; 0: smoothing off.
    pub smoothing_deg: f32,
    /// Building the acceleration structure (kd-tree or BVH), ms.
    pub kd_ms: f64,
    /// Shooting and merging the links, ms.
    pub links_ms: f64,
    /// The rest of the solver's build, ms: light and emitter links, the
    /// sky's rays, the near hits' light and final gather, the noise check
    /// (the build's wall time less the structure and the links).
    pub light_links_ms: f64,
    /// Bounces and the hidden-vertex correction, ms.
    pub gather_ms: f64,
    /// Smoothing, ms.
    pub smooth_ms: f64,
    /// The build's wall time (kd + links + the rest) + gather + smoothing.
    pub total_ms: f64,
    /// Errors of the indirect irradiance against the reference.
    pub e_indirect: ErrorStats,
    /// Errors of the direct irradiance against the reference.
    pub e_direct: ErrorStats,
    /// Errors of the total irradiance (direct, sky and indirect) against the reference.
    pub e_total: ErrorStats,
}

impl SweepRow {
    /// True for the paper's default: 256 rays, 3 bounces, smoothing on.
    pub fn is_paper_default(&self) -> bool {
        self.rays == 256 && self.bounces == "3" && self.smoothing_deg > 0.0
    }
}

fn label(b: Bounces) -> String {
    match b {
        Bounces::Fixed(n) => n.to_string(),
        Bounces::Auto => "auto".into(),
    }
}

/// Runs the sweep on `scene` against `reference`; `progress(done, total)`
/// after each ray count.
pub fn sweep(
    scene: &PreparedScene,
    reference: &Reference,
    params: &SweepParams,
    progress: &dyn Fn(usize, usize),
) -> crate::Result<Vec<SweepRow>> {
    let angle = params.smoothing_angle_deg.unwrap_or(if scene.settings.smoothing_angle_deg > 0.0 {
        scene.settings.smoothing_angle_deg
    } else {
        30.0
    });
    let total_ref = reference.total();
    let mut rows = Vec::new();
    for (k, &rays) in params.rays.iter().enumerate() {
        let mut settings = scene.settings;
        settings.rays_per_vertex = rays;
        let solve_params = SolveParams::from_settings(&settings);
        let t = Instant::now();
        let solver = Solver::new(scene.clone(), solve_params, &|_, _| {})?;
        let build_ms = t.elapsed().as_secs_f64() * 1e3;
        let (kd_ms, links_ms) = (solver.accel_build_ms(), solver.links().stats.shoot_ms);
        // Everything else the build traced or computed, timed as a whole.
        let light_ms = (build_ms - kd_ms - links_ms).max(0.0);
        let n = solver.scene().vertex_count();
        let src = solver.sources();
        let (e_direct, e_sky, e_source) = (&src.e_direct, &src.e_sky, &src.e_source);
        let ed_err = error_stats(e_direct, &reference.e_direct, &[]);
        for &b in &params.bounces {
            let gp = exchange::GatherParams { bounces: b, ..solve_params.gather };
            let t = Instant::now();
            let g = solver.gathered(&src, &gp, false);
            let gather_ms = t.elapsed().as_secs_f64() * 1e3;
            for smoothing in [angle, 0.0] {
                let t = Instant::now();
                let mut e_i = solver.smooth(e_source, &g.e, smoothing);
                src.add_outside_links(&mut e_i);
                let smooth_ms = t.elapsed().as_secs_f64() * 1e3;
                let total: Vec<Vec3> = (0..n).map(|v| e_direct[v] + e_sky[v] + e_i[v]).collect();
                rows.push(SweepRow {
                    rays,
                    bounces: label(b),
                    bounces_used: g.bounces.bounces,
                    smoothing_deg: smoothing,
                    kd_ms,
                    links_ms,
                    light_links_ms: light_ms,
                    gather_ms,
                    smooth_ms,
                    total_ms: kd_ms + links_ms + light_ms + gather_ms + smooth_ms,
                    e_indirect: error_stats(&e_i, &reference.e_indirect, &reference.e_indirect_stderr),
                    e_direct: ed_err,
                    e_total: error_stats(&total, &total_ref, &reference.e_total_stderr),
                });
            }
        }
        progress(k + 1, params.rays.len());
    }
    Ok(rows)
}
