//! Everything a solve reads that is traced beside the links, in one list
//! ([`Part`]): the light links, the emitter links, the sky's rays, the
//! four near-hit terms (lights, emitters, sky, final gather) and the noise
//! check. Building a solver traces every part ([`Part::ALL`]); the
//! refinement rounds before the last trace only what marking edges reads
//! ([`Part::SOURCES`], `adaptive.rs`) and the last one the rest
//! ([`Part::NEAR_AND_NOISE`]); a deformation retraces the parts it does
//! not update selectively; an emission or sky edit retraces only its own
//! parts (a near term after the source it reads). Each part runs on the
//! GPU tracer when the solver has one, else (or when it fails) on the CPU
//! structure ([`super::compute::Tracers::any`]). Which parts the CPU structure traced is kept
//! ([`Traced::on_cpu`]), so a solve can say how many of its rays ran on
//! the CPU (`SolveStats::cpu_traced_rays`).

use super::compute::Tracers;
use super::SolveParams;
use crate::exchange::{EmitterLinks, LightLinks, NearEmitters, NearField, NearGather, NearLight, NearSky, NoiseCheck};
use crate::links::{Links, NearHits};
use crate::scene::prep::PreparedScene;
use crate::sky::rays::portals_of;
use crate::sky::SkyRays;

/// The traced parts of a solver.
#[derive(Clone, Debug, Default)]
pub struct Traced {
    /// Point and directional lights' visibility and geometry at the vertices.
    pub light_links: LightLinks,
    /// Direct light of emissive surfaces by next-event estimation.
    pub emitter_links: EmitterLinks,
    /// The sky's refined cells and portal samples.
    pub sky: SkyRays,
    /// The four near-hit terms.
    pub near: NearField,
    /// A second estimate at a sample of vertices, which calibrates the noise estimate.
    pub noise_check: NoiseCheck,
    /// Per part (in [`Part::ALL`] order): whether the CPU structure traced
    /// some of its current rays ([`Traced::cpu_rays`]).
    pub on_cpu: [bool; 8],
}

/// One traced part.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// The light links.
    LightLinks,
    /// The emitter links.
    Emitters,
    /// The sky's rays (refined cells and portal samples).
    Sky,
    /// The lights' near field.
    NearLight,
    /// The emitters' near field (reads the emitter links: traced after them).
    NearEmitters,
    /// The sky's near field.
    NearSky,
    /// The final gather at near hits.
    NearGather,
    /// The noise check.
    NoiseCheck,
}

impl Part {
    /// Every part, in the order they are traced.
    pub const ALL: [Part; 8] = [
        Part::LightLinks,
        Part::Emitters,
        Part::Sky,
        Part::NearLight,
        Part::NearEmitters,
        Part::NearSky,
        Part::NearGather,
        Part::NoiseCheck,
    ];

    /// The direct light's parts: what a solve needs for every vertex's
    /// irradiance without the near-field corrections and the noise
    /// check's calibration (a refinement round's marks read this).
    pub const SOURCES: [Part; 3] = [Part::LightLinks, Part::Emitters, Part::Sky];

    /// The parts [`Part::SOURCES`] leaves out.
    pub const NEAR_AND_NOISE: [Part; 5] =
        [Part::NearLight, Part::NearEmitters, Part::NearSky, Part::NearGather, Part::NoiseCheck];

    /// The near-field part that traces term `name` of
    /// [`crate::scene::terms::Terms::DECIDED`] (`None` for another name).
    pub fn of_decided(name: &str) -> Option<Part> {
        match name {
            "near_emitters" => Some(Part::NearEmitters),
            "near_sky" => Some(Part::NearSky),
            "near_gather" => Some(Part::NearGather),
            _ => None,
        }
    }

    /// The part's place in [`Part::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

impl Traced {
    /// Traces `parts` of `scene` with `links` into `self`.
    pub fn trace(&mut self, parts: &[Part], scene: &PreparedScene, links: &Links, params: &SolveParams, t: Tracers) {
        self.trace_from(parts, scene, links, &links.near, params, t)
    }

    /// [`Traced::trace`] with the near-field parts traced from the near
    /// hits `near` (the links' own, or a sample of them: `decide.rs`).
    pub fn trace_from(
        &mut self,
        parts: &[Part],
        scene: &PreparedScene,
        links: &Links,
        near: &NearHits,
        params: &SolveParams,
        t: Tracers,
    ) {
        let (rays, seed) = (params.links.rays_per_vertex, params.seed());
        for part in parts {
            t.take_cpu_used();
            match part {
                Part::LightLinks => {
                    self.light_links =
                        t.any("computing light links", |tr| LightLinks::compute_with(scene, tr, &params.light))
                }
                Part::Emitters => {
                    self.emitter_links =
                        t.any("tracing emitter links", |tr| EmitterLinks::compute(scene, tr, &params.emitter, seed));
                }
                Part::NearEmitters => {
                    let e = &self.emitter_links;
                    self.near.emitters = t.any("tracing near-hit emitter light", |tr| {
                        NearEmitters::compute(scene, near, e, tr, &params.near_emitter, seed, rays)
                    });
                }
                Part::Sky => {
                    self.sky = t.any("tracing sky rays", |tr| {
                        SkyRays::trace(scene, tr, &links.sky, &params.links, &params.sky)
                    });
                }
                Part::NearSky => {
                    self.near.sky = if scene.sky.is_none() {
                        NearSky::default()
                    } else {
                        let portals = portals_of(scene, &params.sky);
                        t.any("tracing near-hit sky light", |tr| {
                            NearSky::compute(scene, near, portals, tr, &params.near_sky, seed, rays)
                        })
                    };
                }
                Part::NearLight => {
                    self.near.light =
                        t.any("tracing near-hit light", |tr| NearLight::compute(scene, near, tr, &params.light))
                }
                Part::NearGather => {
                    self.near.gather = t.any("tracing the near hits' final gather", |tr| {
                        NearGather::compute(scene, near, tr, &params.near_gather, seed)
                    })
                }
                Part::NoiseCheck => {
                    self.noise_check = t.any("tracing the noise check", |tr| {
                        NoiseCheck::compute(scene, tr, &params.links, &params.smoothing.noise)
                    })
                }
            }
            self.on_cpu[part.index()] = t.take_cpu_used();
        }
    }

    /// Rays of the parts the CPU structure traced (all of a part's rays
    /// where it traced some of them): 0 when the GPU tracer served them all.
    pub fn cpu_rays(&self) -> u64 {
        Part::ALL.iter().filter(|p| self.on_cpu[p.index()]).map(|&p| self.rays(p)).sum()
    }

    /// Rays `part` traced when it was last traced.
    pub fn rays(&self, part: Part) -> u64 {
        use crate::exchange::near::NearTerm;
        let n = &self.near;
        match part {
            Part::LightLinks => self.light_links.shadow_rays,
            Part::Emitters => self.emitter_links.shadow_rays,
            Part::Sky => self.sky.refine.rays + self.sky.portals.rays,
            Part::NearLight => n.light.cost().rays,
            Part::NearEmitters => n.emitters.cost().rays,
            Part::NearSky => n.sky.cost().rays,
            Part::NearGather => n.gather.cost().rays,
            Part::NoiseCheck => self.noise_check.rays,
        }
    }
}
