//! The sky's own rays beside the links' and the irradiance they give:
//! refined cells where a vertex's view of the sky has an edge
//! ([`super::refine`]) and rays toward the portals ([`super::portal`]),
//! traced together ([`SkyRays::trace`]); `E_sky` from the links' misses,
//! the refined cells and the portals, smoothed with its own noise
//! ([`SkyRays::irradiance`]): one ray a cell pools the independent rays'
//! variance over the ring times the stratification ratio, refined cells
//! bring their own variance; the portals' part is stratified over the
//! opening and left unsmoothed. Irradiance in W/m^2.

use super::{Portal, PortalSamples, SkyRefineParams, SkyRefinement, SkyVisibility};
use crate::exchange::denoise::smooth::{pooled_variance, smooth, smooth_adaptive, SmoothMode, SmoothParams};
use crate::links::{Lineage, LinkParams, RaySetup};
use crate::scene::prep::PreparedScene;
use crate::scene::terms::Terms;
use crate::trace::Tracer;
use glam::Vec3;

/// The refined cells and portal samples of a scene's sky (empty without one).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkyRays {
    /// The sky's refined cells.
    pub refine: SkyRefinement,
    /// The portal samples.
    pub portals: PortalSamples,
}

/// The portals of `scene`'s sky that get rays under `terms` (none without
/// a sky or with the `sky_portals` term off).
pub fn portals_of<'a>(scene: &'a PreparedScene, terms: &Terms) -> &'a [Portal] {
    match &scene.sky {
        Some(s) if terms.sky_portals => &s.portals,
        _ => &[],
    }
}

impl SkyRays {
    /// Traces the refined cells of the links' misses `vis` (links shot with
    /// `link`) and the portal samples with `tracer`, each where its term of
    /// `terms` is on (`sky_refine`, `sky_portals`); nothing without a sky.
    pub fn trace(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        vis: &SkyVisibility,
        link: &LinkParams,
        params: &SkyRefineParams,
        terms: &Terms,
    ) -> crate::Result<SkyRays> {
        if scene.sky.is_none() {
            return Ok(SkyRays::default());
        }
        // One ray setup (origins, frames, wedges) for both.
        let setup = RaySetup::new(scene, link);
        let (portals, seed) = (portals_of(scene, terms), link.seed);
        let refine = if terms.sky_refine {
            SkyRefinement::compute(scene, tracer, &setup, vis, portals, seed, params)?
        } else {
            SkyRefinement::default()
        };
        let portals = PortalSamples::compute(scene, tracer, &setup, portals, seed, &params.portal)?;
        Ok(SkyRays { refine, portals })
    }

    /// The sky's rays of `scene`, a split of `before` (a refinement round)
    /// whose links' misses were `vis_before` and whose sky rays `old` were
    /// traced with the same `link` and `params`, by `lineage`. A kept
    /// vertex whose one-ring no split touched ([`Lineage::whole`]), with
    /// the same ray origin, colour (so the same rotation and direction
    /// set) and miss mask, keeps its refined cells' bits: the same rays
    /// meet the same (unmoved) surfaces. The others trace. Equal to
    /// [`SkyRays::trace`] bit for bit (`tests/refine.rs`); with portals
    /// (their samples are keyed by the vertex's index) everything is
    /// traced anew. Returns the rays and the vertices that kept their rows.
    #[allow(clippy::too_many_arguments)]
    pub fn after_split(
        old: &SkyRays,
        before: &PreparedScene,
        vis_before: &SkyVisibility,
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        vis: &SkyVisibility,
        lineage: &Lineage,
        link: &LinkParams,
        params: &SkyRefineParams,
        terms: &Terms,
    ) -> crate::Result<(SkyRays, u64)> {
        let portals = portals_of(scene, terms);
        if scene.sky.is_none() || !portals.is_empty() || !old.portals.is_empty() || old.refine.is_empty() {
            return Ok((Self::trace(scene, tracer, vis, link, params, terms)?, 0));
        }
        let setup = RaySetup::new(scene, link);
        let rows: Vec<Option<usize>> = lineage
            .carried(before, scene, link.nudge)
            .into_iter()
            .enumerate()
            .map(|(w, c)| c.filter(|&v| before.colours[v] == scene.colours[w] && vis_before.vertex(v) == vis.vertex(w)))
            .collect();
        let kept_rows = rows.iter().filter(|r| r.is_some()).count() as u64;
        let cells = &old.refine.cells;
        let kept = |w: usize| rows[w].map(|v| cells.row(v));
        let refine = SkyRefinement::keeping(scene, tracer, &setup, vis, portals, link.seed, params, &kept)?;
        Ok((SkyRays { refine, portals: PortalSamples::default() }, kept_rows))
    }

    /// Irradiance from the scene's sky at every vertex, W/m^2: the link
    /// rays' misses `vis` (shot with `link`) and refined cells for the
    /// directions outside the portals, the portals' own rays for those
    /// through them, smoothed with their noise at feature angle `angle_deg`
    /// (0: not smoothed; `crate::solver::SolveParams::sky_smoothing_angle`)
    /// by `smoothing`'s adaptive filter (module doc). Zero without a sky or
    /// where no ray missed.
    pub fn irradiance(
        &self,
        scene: &PreparedScene,
        vis: &SkyVisibility,
        link: &LinkParams,
        smoothing: &SmoothParams,
        angle_deg: f32,
    ) -> Vec<Vec3> {
        let s = scene;
        let n = s.vertex_count();
        let Some(sky) = s.sky.as_ref() else { return vec![Vec3::ZERO; n] };
        if vis.is_empty() && self.portals.is_empty() {
            return vec![Vec3::ZERO; n];
        }
        let p = link;
        let k = (p.rays_per_vertex as f64).sqrt().round() as u32;
        let (rotations, sets) = crate::sampling::vertex_rotations_and_sets(&s.colours, p.seed);
        let directions = crate::sampling::DirectionSet::new(k, p.seed);
        // Portals the samples were traced for: their directions are left to them.
        let frames = super::visibility::RayFrames {
            normals: &s.normals,
            rotations: &rotations,
            sets: &sets,
            directions: &directions,
            positions: &s.positions,
            portals: &self.portals.portals,
        };
        let (angle, sp) = (angle_deg, smoothing);
        let smoothed = sp.mode == SmoothMode::Adaptive && angle > 0.0;
        // The portals' part: stratified over the opening, left unsmoothed.
        let portal_e = self.portals.irradiance(sky, &s.positions, &s.normals, p.seed);
        let add_portals = |mut e: Vec<Vec3>| {
            e.iter_mut().zip(&portal_e).for_each(|(e, pe)| *e += *pe);
            e
        };
        let (e, var): (Vec<Vec3>, Vec<Vec3>) = if self.refine.is_empty() {
            // One ray a cell: the variance of independent rays, pooled, times the stratification ratio.
            let (e, m2): (Vec<Vec3>, Vec<Vec3>) = vis.irradiance_and_moment(Some(sky), &frames, n).into_iter().unzip();
            if !smoothed {
                return add_portals(e);
            }
            let mut var = pooled_variance(&e, &m2, p.rays_per_vertex, &s.rings, &s.normals, angle);
            let ratio = sp.noise.ratio(p.rays_per_vertex);
            var.iter_mut().for_each(|v| *v *= ratio);
            (e, var)
        } else {
            // Refined cells: their own variance, pooled over the ring.
            let (e, var): (Vec<Vec3>, Vec<Vec3>) =
                self.refine.irradiance(vis, Some(sky), &frames, p.seed, n).into_iter().unzip();
            if !smoothed {
                return add_portals(e);
            }
            (e, smooth(&var, &s.rings, &s.normals, angle))
        };
        add_portals(smooth_adaptive(&e, &var, &s.rings, &s.normals, angle, sp.passes))
    }

    /// Checks both parts against `n` vertices shot with `rays` rays each.
    pub fn validate(&self, n: usize, rays: usize) -> Result<(), String> {
        self.refine.validate(n, rays)?;
        self.portals.validate(n)
    }

}
