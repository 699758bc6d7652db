//! Tracing parts of a built [`Solver`] again after an edit that changes
//! what they see, so every solve still equals a fresh one: the emitter
//! links when a surface starts emitting, the emitters' light at near hits
//! with them, and the sky's portal samples, refined cells and near-hit
//! samples when the portals change or a sky appears. Also the builders the constructors share for those
//! parts ([`sky_rays`], [`near_emitters`]).

use super::{SolveParams, Solver};
use crate::exchange::EmitterLinks;
use crate::links::Links;
use crate::scene::prep::PreparedScene;
use glam::Vec3;

impl Solver {
    /// Traces the emitter links again if some vertex emits that they do
    /// not cover (a surface started emitting after they were built, so a
    /// solve equals a fresh one); other emission edits need no rays.
    /// Returns whether it traced.
    pub fn update_emitters(&mut self) -> bool {
        let e = &self.emitter_links;
        let uncovered = self.scene.emission.iter().zip(&e.covered).any(|(m, &c)| *m != Vec3::ZERO && !c);
        if !uncovered || e.fallback.is_some() || self.params.emitter.samples == 0 {
            return false;
        }
        let traced = match &self.gpu {
            Some(g) => EmitterLinks::compute(&self.scene, &g.tracer, &self.params.emitter).or_else(|err| {
                eprintln!("warning: {err}; tracing emitter links on the CPU");
                EmitterLinks::compute(&self.scene, &self.accel, &self.params.emitter)
            }),
            None => EmitterLinks::compute(&self.scene, &self.accel, &self.params.emitter),
        };
        self.emitter_links = traced.expect("a CPU tracer cannot fail");
        self.emitters_changed();
        self.refresh_near_emitters();
        true
    }

    /// Traces the emitters' light at the near hits again (after the emitter
    /// links or the links changed).
    pub(crate) fn refresh_near_emitters(&mut self) {
        let traced = match &self.gpu {
            Some(g) => {
                near_emitters(&self.scene, &self.links, &self.emitter_links, &g.tracer, &self.params).or_else(|err| {
                    eprintln!("warning: {err}; tracing near-hit emitter light on the CPU");
                    near_emitters(&self.scene, &self.links, &self.emitter_links, &self.accel, &self.params)
                })
            }
            None => near_emitters(&self.scene, &self.links, &self.emitter_links, &self.accel, &self.params),
        };
        self.near_emitters = traced.expect("a CPU tracer cannot fail");
    }

    /// Brings the sky's portal samples (and the refined cells, which
    /// leave the portals' directions to them, and the near hits' sky
    /// samples) up to date with the scene's sky, so the result equals a
    /// fresh solve's: traces them when the portals changed since they were
    /// traced, or when a sky is set where none was traced. Returns true if it traced.
    pub fn update_portals(&mut self) -> bool {
        let same_portals = portals_of(&self.scene, &self.params) == self.sky_portals.portals.as_slice();
        // A sky where there was none at the last trace: its rays were never traced.
        let untraced = self.scene.sky.is_some() && !self.near_sky.traced;
        if same_portals && !untraced {
            return false;
        }
        let traced = match &self.gpu {
            Some(g) => sky_rays(&self.scene, &g.tracer, &self.links, &self.params).or_else(|err| {
                eprintln!("warning: {err}; tracing sky portals on the CPU");
                sky_rays(&self.scene, &self.accel, &self.links, &self.params)
            }),
            None => sky_rays(&self.scene, &self.accel, &self.links, &self.params),
        };
        (self.sky_refine, self.sky_portals, self.near_sky) = traced.expect("a CPU tracer cannot fail");
        true
    }
}

/// The portals of `scene`'s sky that get rays with `params` (none without
/// a sky or with portal rays off).
pub(crate) fn portals_of<'a>(scene: &'a PreparedScene, params: &SolveParams) -> &'a [crate::sky::Portal] {
    match &scene.sky {
        Some(s) if params.sky.portal.side() > 0 => &s.portals,
        _ => &[],
    }
}

/// The sky's rays beside the links': refined cells, portal samples and the
/// near hits' sky samples for `links` (none without a sky).
pub(crate) fn sky_rays(
    scene: &PreparedScene,
    tracer: &dyn crate::trace::Tracer,
    links: &Links,
    params: &SolveParams,
) -> crate::Result<(crate::sky::SkyRefinement, crate::sky::PortalSamples, crate::exchange::NearSky)> {
    if scene.sky.is_none() {
        return Ok(Default::default());
    }
    let vis = &links.sky;
    // One ray setup (origins, frames, wedges) for both.
    let setup = crate::links::RaySetup::new(scene, &params.links);
    let (portals, seed) = (portals_of(scene, params), params.links.seed);
    let refine = crate::sky::SkyRefinement::compute(scene, tracer, &setup, vis, portals, seed, &params.sky)?;
    let samples = crate::sky::PortalSamples::compute(scene, tracer, &setup, portals, seed, &params.sky.portal)?;
    let near = crate::exchange::NearSky::compute(
        scene,
        &links.near,
        portals,
        tracer,
        &params.near_sky,
        params.links.rays_per_vertex,
    )?;
    Ok((refine, samples, near))
}

/// The final gather from the near hits of `links`, traced with `tracer`.
pub(crate) fn near_gather(
    scene: &PreparedScene,
    links: &Links,
    tracer: &dyn crate::trace::Tracer,
    params: &SolveParams,
) -> crate::Result<crate::exchange::NearGather> {
    crate::exchange::NearGather::compute(scene, &links.near, tracer, &params.near_gather)
}

/// The emitters' light at the near hits of `links`, traced with `tracer`.
pub(crate) fn near_emitters(
    scene: &PreparedScene,
    links: &Links,
    emitter_links: &EmitterLinks,
    tracer: &dyn crate::trace::Tracer,
    params: &SolveParams,
) -> crate::Result<crate::exchange::NearEmitters> {
    crate::exchange::NearEmitters::compute(
        scene,
        &links.near,
        emitter_links,
        tracer,
        &params.near_emitter,
        params.links.rays_per_vertex,
    )
}
