//! Everything a solve reads that is traced beside the links, in one list
//! ([`Part`]): the light links, the emitter links, the sky's rays, the
//! four near-hit terms (lights, emitters, sky, final gather) and the noise
//! check.
//!
//! One interface brings every part up to date ([`Traced::update`]) after
//! a [`Change`]: [`Change::Fresh`] traces it from scratch (a new solver, a
//! retrace, an edit of what it reads); [`Change::Split`] (a refinement
//! round) and [`Change::Deformed`] (a deformation) redo only what the
//! change can have touched, for the parts that know how (the light links,
//! the emitter links and the sky's refined cells after a split; the light
//! links, the near hits' light and their final gather after a
//! deformation), and trace the others anew. Either
//! way the part equals a fresh trace of the changed scene bit for bit (the
//! light links after a deformation within 1e-6: they sum in another
//! order), checked after every refinement round and deformation in
//! `tests/refine.rs` and `tests/selective.rs` through
//! [`super::Solver::check_traced`]. What each update did and cost is
//! kept ([`Traced::cost`]).
//!
//! Building a solver traces every part ([`Part::ALL`]); the
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
use crate::exchange::near::NearChange;
use crate::exchange::{EmitterLinks, LightLinks, NearEmitters, NearField, NearGather, NearLight, NearSky, NoiseCheck};
use crate::links::{Lineage, Links, NearHits};
use crate::scene::prep::PreparedScene;
use crate::scene::terms::Terms;
use crate::sky::rays::portals_of;
use crate::sky::SkyRays;
use std::time::Instant;

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
    /// Per part (in [`Part::ALL`] order): what its last update did.
    pub costs: [PartCost; 8],
}

/// What a part is brought up to date after ([`Traced::update`]).
pub enum Change<'a> {
    /// Nothing to start from: the part is traced from scratch.
    Fresh,
    /// A refinement round split triangles of `before` into the current
    /// scene: `traced` are `before`'s parts and `links` its links, traced
    /// with the same parameters; `lineage` says which new vertex keeps
    /// which old one.
    Split {
        /// The scene before the split.
        before: &'a PreparedScene,
        /// Its links.
        links: &'a Links,
        /// Its traced parts.
        traced: &'a Traced,
        /// How the new vertices and triangles come from the old.
        lineage: &'a Lineage,
    },
    /// A deformation moved vertices: the motion and the near hits before
    /// and after it (same triangles, same parameters).
    Deformed(NearChange<'a>),
}

/// What the last update of one part did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PartCost {
    /// Rays it traced.
    pub rays: u64,
    /// Time of the update, ms.
    pub ms: f64,
    /// The update redid only what the change touched (false: traced from scratch).
    pub selective: bool,
    /// Of a selective update, the units it redid: vertices (emitter
    /// links), (vertex, light) entries (light links), near-hit rows.
    pub redone: u64,
    /// The part was brought up to date at least once (false: it is empty
    /// because it was never traced, as the near field in a marking round).
    pub traced: bool,
}

/// What a part is traced from: the scene, its links, the near hits the
/// near-field parts start from (the links' own, or a sample of them:
/// `decide.rs`) and the parameters.
#[derive(Clone, Copy)]
pub struct Inputs<'a> {
    /// The scene.
    pub scene: &'a PreparedScene,
    /// Its links.
    pub links: &'a Links,
    /// The near hits the near-field parts are traced from.
    pub near: &'a NearHits,
    /// The parameters.
    pub params: &'a SolveParams,
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

    /// The part's name, as `solve` prints it.
    pub fn name(self) -> &'static str {
        match self {
            Part::LightLinks => "light links",
            Part::Emitters => "emitter links",
            Part::Sky => "sky rays",
            Part::NearLight => "near-hit light",
            Part::NearEmitters => "near-hit emitter light",
            Part::NearSky => "near-hit sky light",
            Part::NearGather => "near-hit final gather",
            Part::NoiseCheck => "noise check",
        }
    }

    /// Whether `terms` leave the part anything to trace. The switched-off
    /// parts of the near field are traced over no near hits and the others
    /// left empty, which is what a part gives that has nothing to trace
    /// (no emitters, no near hits). The light links and the sky's rays are
    /// always traced (the sky's two terms, `sky_refine` and
    /// `sky_portals`, are read by [`SkyRays::trace`]).
    pub fn on(self, terms: &Terms) -> bool {
        match self {
            Part::LightLinks | Part::Sky => true,
            Part::Emitters => terms.emitter_links,
            Part::NearLight => terms.near,
            Part::NearEmitters => terms.near && terms.near_emitters,
            Part::NearSky => terms.near && terms.near_sky,
            Part::NearGather => terms.near && terms.near_gather,
            Part::NoiseCheck => terms.noise_check,
        }
    }

    /// The part's place in [`Part::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

impl Traced {
    /// Brings `parts` (in that order) up to date after `change`, from
    /// `inputs` (module doc); records each part's [`PartCost`] and whether
    /// the CPU structure traced some of it.
    pub fn update(&mut self, parts: &[Part], change: &Change, inputs: Inputs, t: Tracers) {
        let Inputs { scene, links, near: near_hits, params } = inputs;
        let (rays, seed, terms) = (params.links.rays_per_vertex, params.seed(), &params.terms);
        let no_hits = NearHits::default();
        for &part in parts {
            t.take_cpu_used();
            let start = Instant::now();
            let mut redone = None;
            let on = part.on(terms);
            // A switched-off part is traced afresh, a near-field one from no near hits.
            let (near, change) = if on { (near_hits, change) } else { (&no_hits, &Change::Fresh) };
            match (part, change) {
                (Part::Emitters, _) if !on => self.emitter_links = EmitterLinks::none(scene.vertex_count()),
                (Part::NoiseCheck, _) if !on => self.noise_check = NoiseCheck::default(),
                (Part::LightLinks, Change::Deformed(c)) => {
                    let light = &mut self.light_links;
                    redone =
                        Some(t.any("updating light links", |tr| {
                            light.update_deformed(scene, tr, &params.light, c.motion)
                        }));
                }
                (Part::NearLight, Change::Deformed(c)) => {
                    let light = &mut self.near.light;
                    redone =
                        Some(t.any("updating near-hit light", |tr| light.update_deformed(scene, c, tr, &params.light)));
                }
                (Part::NearGather, Change::Deformed(c)) => {
                    let gather = &mut self.near.gather;
                    redone = Some(t.any("updating the near hits' final gather", |tr| {
                        gather.update_deformed(scene, c, tr, &params.near_gather, seed)
                    }));
                }
                (Part::LightLinks, Change::Split { before, traced, lineage, .. }) => {
                    let (light, entries) = t.any("updating light links", |tr| {
                        LightLinks::after_split(&traced.light_links, before, scene, lineage, tr, &params.light)
                    });
                    self.light_links = light;
                    redone = Some(entries);
                }
                (Part::Emitters, Change::Split { before, traced, lineage, .. }) => {
                    let (links, kept) = t.any("updating emitter links", |tr| {
                        EmitterLinks::after_split(
                            &traced.emitter_links,
                            before,
                            scene,
                            lineage,
                            tr,
                            &params.emitter,
                            seed,
                        )
                    });
                    self.emitter_links = links;
                    redone = (kept > 0).then(|| scene.vertex_count() as u64 - kept);
                }
                (Part::Sky, Change::Split { before, links: links_before, traced, lineage }) => {
                    let (sky, kept) = t.any("updating sky rays", |tr| {
                        SkyRays::after_split(
                            &traced.sky,
                            before,
                            &links_before.sky,
                            scene,
                            tr,
                            &links.sky,
                            lineage,
                            &params.links,
                            &params.sky,
                            terms,
                        )
                    });
                    self.sky = sky;
                    redone = (kept > 0).then(|| scene.vertex_count() as u64 - kept);
                }
                (Part::LightLinks, _) => {
                    self.light_links =
                        t.any("computing light links", |tr| LightLinks::compute_with(scene, tr, &params.light))
                }
                (Part::Emitters, _) => {
                    self.emitter_links =
                        t.any("tracing emitter links", |tr| EmitterLinks::compute(scene, tr, &params.emitter, seed));
                }
                (Part::NearEmitters, _) => {
                    let e = &self.emitter_links;
                    self.near.emitters = t.any("tracing near-hit emitter light", |tr| {
                        NearEmitters::compute(scene, near, e, tr, &params.near_emitter, seed, rays)
                    });
                }
                (Part::Sky, _) => {
                    self.sky = t.any("tracing sky rays", |tr| {
                        SkyRays::trace(scene, tr, &links.sky, &params.links, &params.sky, terms)
                    });
                }
                (Part::NearSky, _) => {
                    self.near.sky = if scene.sky.is_none() {
                        NearSky::default()
                    } else {
                        let portals = portals_of(scene, terms);
                        t.any("tracing near-hit sky light", |tr| {
                            NearSky::compute(scene, near, portals, tr, &params.near_sky, seed, rays)
                        })
                    };
                }
                (Part::NearLight, _) => {
                    self.near.light =
                        t.any("tracing near-hit light", |tr| NearLight::compute(scene, near, tr, &params.light))
                }
                (Part::NearGather, _) => {
                    self.near.gather = t.any("tracing the near hits' final gather", |tr| {
                        NearGather::compute(scene, near, tr, &params.near_gather, seed)
                    })
                }
                (Part::NoiseCheck, _) => {
                    self.noise_check = t.any("tracing the noise check", |tr| {
                        NoiseCheck::compute(scene, tr, &params.links, &params.smoothing.noise)
                    })
                }
            }
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let rays = self.rays(part);
            self.costs[part.index()] =
                PartCost { rays, ms, selective: redone.is_some(), redone: redone.unwrap_or_default(), traced: true };
            self.on_cpu[part.index()] = t.take_cpu_used();
        }
    }

    /// Where `part` of `self` and of `other` differ in what a solve reads
    /// (bit for bit; the figures of how it was traced are left out), named;
    /// `None` where they agree.
    #[cfg(any(test, feature = "internals"))]
    pub fn differs(&self, other: &Traced, part: Part) -> Option<&'static str> {
        let (a, b) = (self, other);
        let same = match part {
            Part::LightLinks => {
                // After a deformation the updated factors sum in another
                // order: equal within 1e-6 (`tests/selective.rs`).
                let (x, y) = (&a.light_links, &b.light_links);
                let close = |p: &[Vec<f32>], q: &[Vec<f32>]| {
                    p.len() == q.len()
                        && p.iter().zip(q).all(|(p, q)| {
                            p.len() == q.len() && p.iter().zip(q).all(|(x, y)| (x - y).abs() <= 1e-6 * y.abs())
                        })
                };
                close(&x.factors, &y.factors)
                    && close(&x.point, &y.point)
                    && (&x.positions, &x.coarse) == (&y.positions, &y.coarse)
            }
            Part::Emitters => {
                let (x, y) = (&a.emitter_links, &b.emitter_links);
                (&x.rows, &x.group_vertex, &x.covered, &x.vertex_group, &x.fallback)
                    == (&y.rows, &y.group_vertex, &y.covered, &y.vertex_group, &y.fallback)
            }
            Part::Sky => {
                let (x, y) = (&a.sky, &b.sky);
                (x.refine.sub, &x.refine.cells) == (y.refine.sub, &y.refine.cells)
                    && (&x.portals.portals, x.portals.side, &x.portals.masks, x.portals.words)
                        == (&y.portals.portals, y.portals.side, &y.portals.masks, y.portals.words)
            }
            Part::NearLight => a.near.light.columns == b.near.light.columns,
            Part::NearEmitters => a.near.emitters.rows == b.near.emitters.rows,
            Part::NearSky => (a.near.sky.traced, &a.near.sky.rows) == (b.near.sky.traced, &b.near.sky.rows),
            Part::NearGather => {
                (a.near.gather.per_hit, &a.near.gather.hits) == (b.near.gather.per_hit, &b.near.gather.hits)
            }
            Part::NoiseCheck => {
                let (x, y) = (&a.noise_check, &b.noise_check);
                (&x.vertices, &x.groups, &x.kernel) == (&y.vertices, &y.groups, &y.kernel)
            }
        };
        (!same).then_some(part.name())
    }

    /// What the last update of `part` did.
    pub fn cost(&self, part: Part) -> PartCost {
        self.costs[part.index()]
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
