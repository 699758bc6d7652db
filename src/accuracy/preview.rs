//! The light-move preview against the full result after the move: the
//! solver is built at the scene's rays (auto bounces, smoothing at the
//! sweep's angle), the first light is moved ([`moved_lights`]), the
//! preview ([`Solver::preview_lights`]: the moved light's shadow rays from
//! the vertices alone) is solved, then the full update; the preview's
//! `E_d`, `E_i` and total are scored against the full result's (no noise
//! correction: both come from the same links). The preview's `E_d` always
//! equals the full one (the same point rays); with the default light-link
//! parameters (no one-ring oversampling, point bounce source) so does
//! everything else, and the scores are 0. Times in ms.

use super::metrics::{error_stats, ErrorStats};
use crate::scene::prep::PreparedScene;
use crate::scene::{Bounces, Light};
use crate::solver::{SolveParams, Solver};
use glam::Vec3;
use serde::Serialize;
use std::time::Instant;

/// The preview's figures.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PreviewRow {
    /// Rays per vertex.
    pub rays: u32,
    /// Feature angle of smoothing, degrees; 0: smoothing off.
    pub smoothing_deg: f32,
    /// Light links of the preview, ms.
    pub preview_light_links_ms: f64,
    /// Preview light links + gather + smoothing, ms.
    pub preview_ms: f64,
    /// Full light-link update + gather + smoothing, ms.
    pub full_ms: f64,
    /// Shadow rays of the preview's light links.
    pub preview_shadow_rays: u64,
    /// Shadow rays of the full light-link update.
    pub full_shadow_rays: u64,
    /// Errors of the preview's indirect irradiance against the full result's.
    pub e_indirect: ErrorStats,
    /// Errors of the preview's direct irradiance against the full result's.
    pub e_direct: ErrorStats,
    /// Errors of the preview's total irradiance against the full result's.
    pub e_total: ErrorStats,
}

/// `lights` with the first one moved: a point light a fifth of the way
/// toward the centre of the scene's bounds, a directional light turned by
/// about 11 degrees. None without lights.
pub fn moved_lights(scene: &PreparedScene) -> Option<Vec<Light>> {
    let mut lights = scene.lights.clone();
    let first = lights.first_mut()?;
    let (lo, hi) = scene.bounds();
    let delta = match *first {
        Light::Point { position, .. } => 0.2 * (0.5 * (lo + hi) - position),
        Light::Directional { direction, .. } => {
            let side = direction.cross(Vec3::Y).try_normalize().unwrap_or(Vec3::X);
            0.2 * side * direction.length()
        }
    };
    *first = first.moved(delta);
    Some(lights)
}

/// Scores the preview of a move of the first light (see the module doc);
/// None when the scene has no light.
pub fn score(scene: &PreparedScene, smoothing_deg: f32) -> crate::Result<Option<PreviewRow>> {
    let Some(moved) = moved_lights(scene) else { return Ok(None) };
    let mut settings = scene.settings;
    settings.bounces = Bounces::Auto;
    settings.smoothing_angle_deg = smoothing_deg;
    let mut solver = Solver::new(scene.clone(), SolveParams::from_settings(&settings), &|_, _| {})?;
    let t = Instant::now();
    solver.preview_lights(moved.clone());
    let (preview_light_links_ms, preview_shadow_rays) = (solver.light_links().ms, solver.light_links().shadow_rays);
    let preview = solver.solve();
    let preview_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    solver.set_lights(moved);
    let full = solver.solve();
    let full_ms = t.elapsed().as_secs_f64() * 1e3;
    let total = |s: &crate::solver::Solution| -> Vec<Vec3> { s.total() };
    Ok(Some(PreviewRow {
        rays: settings.rays_per_vertex,
        smoothing_deg,
        preview_light_links_ms,
        preview_ms,
        full_ms,
        preview_shadow_rays,
        full_shadow_rays: solver.light_links().shadow_rays,
        e_indirect: error_stats(&preview.e_indirect, &full.e_indirect, &[]),
        e_direct: error_stats(&preview.e_direct, &full.e_direct, &[]),
        e_total: error_stats(&total(&preview), &total(&full), &[]),
    }))
}
