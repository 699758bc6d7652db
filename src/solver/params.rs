//! The parameters of a solve: every stage's, with their defaults, in one
//! struct ([`SolveParams`]); the scene's `[settings]` applied by
//! [`SolveParams::from_settings`]; presets as functions
//! ([`SolveParams::preview`], [`SolveParams::reference`]).
//!
//! One seed: the links' ([`SolveParams::seed`]); every other random
//! number derives from it through a named stream
//! ([`crate::sampling::Stream`]). Each stage's struct documents its fields
//! (effect, unit, trade-off); the measurements behind the defaults are in
//! `docs/ACCURACY.md` and `docs/PERFORMANCE.md`.

use crate::bvh::BvhBuildParams;
use crate::exchange::{
    EmitterLinkParams, GatherParams, HiddenParams, LightLinkParams, NearEmitterParams, NearGatherParams, NearSkyParams,
    SmoothParams,
};
use crate::kdtree::KdBuildParams;
use crate::links::LinkParams;
use crate::scene::{Settings, TracerKind};

/// All stage parameters, defaults as listed in docs/DESIGN.md, "Defaults".
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolveParams {
    /// The CPU structure rays go through (the GPU path always walks its kd-tree).
    pub tracer: TracerKind,
    /// The wide BVH of `tracer = bvh`.
    pub bvh: BvhBuildParams,
    /// kd-tree of `tracer = kd` on the CPU.
    pub kd: KdBuildParams,
    /// kd-tree for the GPU path, whose shader tests one triangle per step
    /// ([`KdBuildParams::for_gpu`]); the hits are the same.
    pub kd_gpu: KdBuildParams,
    pub links: LinkParams,
    pub light: LightLinkParams,
    /// Next-event estimation toward emissive surfaces ([`crate::exchange::sources::emitter_links`]).
    pub emitter: EmitterLinkParams,
    /// The emitters' light at near hits ([`crate::exchange::near::emitters`]).
    pub near_emitter: NearEmitterParams,
    /// The sky's light at near hits ([`crate::exchange::near::sky`]).
    pub near_sky: NearSkyParams,
    /// The emitter groups as a control variate of the first bounce
    /// ([`crate::exchange::sources::emitter_cv`]); default on.
    pub emitter_cv: bool,
    /// The later bounces' light at near hits ([`crate::exchange::near::gather`]).
    pub near_gather: NearGatherParams,
    /// Gradient-corrected radiosity at link hits ([`crate::exchange::bounce::reconstruct`]):
    /// removes linear interpolation's dark bias at surfaces' borders; default on.
    pub reconstruct: bool,
    pub gather: GatherParams,
    /// Correction of hidden vertices as link targets ([`crate::exchange::bounce::hidden`]).
    pub hidden: HiddenParams,
    /// More rays where a vertex's view of the sky has an edge ([`crate::sky::refine`]).
    pub sky: crate::sky::SkyRefineParams,
    /// Feature angle of smoothing, degrees; 0: off.
    pub smoothing_angle_deg: f32,
    /// The smoothing filter (noise-aware by default, [`mod@crate::exchange::smooth`]).
    pub smoothing: SmoothParams,
}

impl Default for SolveParams {
    fn default() -> Self {
        SolveParams {
            tracer: TracerKind::default(),
            bvh: BvhBuildParams::default(),
            kd: KdBuildParams::default(),
            kd_gpu: KdBuildParams::for_gpu(),
            links: LinkParams::default(),
            light: LightLinkParams::default(),
            emitter: EmitterLinkParams::default(),
            near_emitter: Default::default(),
            near_sky: Default::default(),
            emitter_cv: true,
            near_gather: Default::default(),
            reconstruct: true,
            gather: GatherParams::default(),
            hidden: HiddenParams::default(),
            sky: Default::default(),
            smoothing_angle_deg: 0.0,
            smoothing: SmoothParams::default(),
        }
    }
}

impl SolveParams {
    /// Parameters with the scene's settings applied.
    pub fn from_settings(s: &Settings) -> SolveParams {
        let mut p = SolveParams::default();
        p.links.rays_per_vertex = s.rays_per_vertex;
        p.links.seed = s.seed;
        // Emitters' direct light as many rays as the links (at least 64): its noise falls with theirs.
        p.emitter.samples = s.rays_per_vertex.max(64);
        // Sky portals' rays likewise scale with the links'.
        p.sky.portal = crate::sky::PortalParams::for_link_rays(s.rays_per_vertex);
        p.tracer = s.tracer;
        p.gather.bounces = s.bounces;
        p.smoothing_angle_deg = s.smoothing_angle_deg;
        p
    }

    /// The seed of every sample the solve draws (the link directions' and,
    /// through named streams, all others').
    pub fn seed(&self) -> u64 {
        self.links.seed
    }

    /// A quick preview: 16 rays a vertex, no near-field terms, no noise
    /// check, emitter links at 16 samples; for a first picture in well
    /// under a second on scenes of 100k vertices.
    pub fn preview() -> SolveParams {
        let mut p = SolveParams::default();
        p.links.rays_per_vertex = 16;
        p.links.near.factor = 0.0;
        p.emitter.samples = 16;
        p.smoothing.noise.check_vertices = 0;
        p.sky.portal = crate::sky::PortalParams::for_link_rays(16);
        p
    }

    /// Reference quality: 1024 rays a vertex, auto bounces, every
    /// correction on, emitter links with as many samples as link rays.
    pub fn reference() -> SolveParams {
        let mut p = SolveParams::default();
        p.links.rays_per_vertex = 1024;
        p.emitter.samples = 1024;
        p.gather.bounces = crate::scene::Bounces::Auto;
        p.sky.portal = crate::sky::PortalParams::for_link_rays(1024);
        p
    }
}
