//! One solve of a built [`Solver`] (docs/DESIGN.md §4), as a sequence of
//! stages that [`Solver::solve`] runs in order and the accuracy sweep
//! (`linkgi error`) runs with other bounce and smoothing settings:
//!
//! 1. [`Solver::sources`]: the direct irradiances of the lights, sky and
//!    emitters, the first bounce's near field, the emitter control
//!    variate, and what the bounces start from.
//! 2. [`Solver::gathered`]: the bounces over the links (GPU kernel when the
//!    solver has one, else the CPU's) with hidden vertices replaced as link
//!    targets, plus the control variate and the later bounces' near field.
//! 3. [`Solver::smooth`]: the noise-aware smoothing of the gathered part.
//! 4. [`Sources::add_outside_links`]: the emitters' direct light and the
//!    first bounce's near field added back (they were not gathered over
//!    the links, so they are not smoothed).
//!
//! [`Solver::solve_quick`] skips the hidden-vertex correction and the
//! later near field and smooths by the fixed one-ring average. Irradiance
//! in W/m^2, radiosity in W/(m^2 sr).

use super::compute::gpu_else_cpu;
use super::{Solution, Solver};
use crate::exchange::bounce::hidden::StandIn;
use crate::exchange::bounce::operator::radiosity;
use crate::exchange::near::{Bounce, Fields};
use crate::exchange::{self, GatherParams, GatherResult, SmoothMode};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Arc;

/// The direct irradiances of one solve ([`Solver::sources`]), W/m^2.
#[derive(Clone, Debug, Default)]
pub struct Sources {
    /// Point and directional lights, exact at the vertex.
    pub e_direct: Vec<Vec3>,
    /// The sky.
    pub e_sky: Vec<Vec3>,
    /// Emissive surfaces with emitter links.
    pub e_emitter: Vec<Vec3>,
    /// The first bounce's near field ([`crate::exchange::near`]).
    pub e_near: Vec<Vec3>,
    /// The emitter groups' control variate of the first bounce
    /// ([`crate::exchange::sources::emitter_cv`]): part of the gathered `E_i`.
    pub e_cv: Vec<Vec3>,
    /// What the bounces start from: the lights' bounce source plus `e_sky`, `e_emitter`, `e_near` and `e_cv`.
    pub e_source: Vec<Vec3>,
    /// The emitted exitance the vertex links carry (emitters without emitter links), W/m^2.
    pub emission: Vec<Vec3>,
}

impl Sources {
    internal! {
        /// `E_i` gathered over the links (W/m^2) with the first bounce's
        /// control variate `e_cv` added: what the smoothing smooths.
        pub fn add_control_variate(&self, e_gathered: &mut [Vec3]) {
            if !self.e_cv.is_empty() {
                e_gathered.iter_mut().zip(&self.e_cv).for_each(|(e, d)| *e += *d);
            }
        }
    }

    internal! {
        /// Completes gathered `E_i` (W/m^2) in place: adds the parts not
        /// gathered over the links, the emitters' direct light and the near-hit
        /// correction, and keeps every channel at least 0.
        pub fn add_outside_links(&self, e_gathered: &mut [Vec3]) {
            for ((i, m), d) in e_gathered.iter_mut().zip(&self.e_emitter).zip(&self.e_near) {
                *i = (*i + *m + *d).max(Vec3::ZERO);
            }
        }
    }
}

/// The gathered part of `E_i` ([`Solver::gathered`]), W/m^2.
#[derive(Clone, Debug, Default)]
pub struct Gathered {
    /// The bounces (after the hidden-vertex correction).
    pub bounces: GatherResult,
    /// The later bounces' near field (empty without near hits or in a quick solve).
    pub e_near_gather: Vec<Vec3>,
    /// The bounces plus the control variate and `e_near_gather`: what the smoothing smooths.
    pub e: Vec<Vec3>,
}

impl Solver {
    /// Gathers the bounces and smooths (module doc).
    pub fn solve(&self) -> Solution {
        self.solve_as(false)
    }

    /// A cheaper [`Solver::solve`] for previews: no hidden-vertex
    /// correction, no later near field, and smoothing by the fixed one-ring
    /// average (no noise estimate). On dancer at 256 rays about 11 ms
    /// against 75 ms.
    pub fn solve_quick(&self) -> Solution {
        self.solve_as(true)
    }

    fn solve_as(&self, quick: bool) -> Solution {
        let s = &self.scene;
        let angle = self.params.smoothing_angle();
        let src = self.sources();
        let gathered = self.gathered(&src, &self.params.gather, quick);
        let mut e_indirect = if quick {
            exchange::smooth(&gathered.e, &s.rings, &s.normals, angle)
        } else {
            self.smooth(&src.e_source, &gathered.e, angle)
        };
        let mut e_indirect_raw = gathered.e.clone();
        src.add_outside_links(&mut e_indirect);
        src.add_outside_links(&mut e_indirect_raw);
        Solution {
            e_direct: src.e_direct,
            e_sky: src.e_sky,
            e_emitter: src.e_emitter,
            e_near: src.e_near,
            e_cv: src.e_cv,
            e_near_gather: gathered.e_near_gather,
            e_source: src.e_source,
            e_gathered: gathered.e,
            e_indirect_raw,
            e_indirect,
            gather: gathered.bounces,
            smoothed: angle > 0.0,
        }
    }

    internal! {
        /// Stage 1: the direct irradiances of the current lights, sky and
        /// emission, the first bounce's near field and control variate, and
        /// what the bounces start from.
        pub fn sources(&self) -> Sources {
            let s = &self.scene;
            let n = s.vertex_count();
            let e_sky = self.e_sky();
            let e_emitter = self.e_emitter();
            let mut e_source = self.traced.light_links.bounce_source(&s.lights, n);
            let e_near = self.near_first(&e_source, &e_sky);
            for (e, ((k, m), d)) in e_source.iter_mut().zip(e_sky.iter().zip(&e_emitter).zip(&e_near)) {
                *e += *k + *m + *d;
            }
            let cv = self.emitter_cv();
            let e_cv = if cv.is_empty() {
                Vec::new()
            } else {
                let d = cv.correction(&cv.group_means(&s.albedo, &e_source), n);
                e_source.iter_mut().zip(&d).for_each(|(e, d)| *e += *d);
                d
            };
            Sources {
                e_direct: self.traced.light_links.direct(&s.lights, n),
                e_sky,
                e_emitter,
                e_near,
                e_cv,
                e_source,
                emission: self.traced.emitter_links.carried_emission(&s.emission).into_owned(),
            }
        }
    }

    /// The fields the near-hit terms read, with those of the first bounce
    /// or the later ones filled in by the caller.
    fn fields<'a>(&'a self, e_lights: &'a [Vec3], e_sky: &'a [Vec3]) -> Fields<'a> {
        let s = &self.scene;
        Fields {
            scene: s,
            near: &self.links.near,
            rays_per_vertex: self.params.links.rays_per_vertex,
            lights: &s.lights,
            e_lights,
            sky: s.sky.as_ref(),
            e_sky,
            emission: &s.emission,
            group_vertex: &self.traced.emitter_links.group_vertex,
            b_later: &[],
            g_later: &[],
        }
    }

    /// The first bounce's near field, W/m^2, for the lights' bounce source
    /// `e_src` and the vertices' sky light `e_sky`, each read as the links
    /// read it (module doc of `exchange::bounce::reconstruct`).
    fn near_first(&self, e_src: &[Vec3], e_sky: &[Vec3]) -> Vec<Vec3> {
        let s = &self.scene;
        let near = &self.traced.near;
        let reconstruction = self.reconstruction().filter(|_| !self.links.near.is_empty());
        let through = |x: &[Vec3]| reconstruction.as_ref().map(|r| r.through_albedo(&s.albedo, x));
        let e_src_read = through(e_src);
        let e_src = e_src_read.as_deref().unwrap_or(e_src);
        // The sky's field only where its term has samples to correct.
        use exchange::near::NearTerm;
        let sky_needed = !near.sky.is_empty() && s.sky.is_some();
        let sky_read = if sky_needed { through(e_sky) } else { None };
        let e_sky = if sky_needed { sky_read.as_deref().unwrap_or(e_sky) } else { &[] };
        let fields = self.fields(e_src, e_sky);
        near.correction(Bounce::First, &fields).unwrap_or_else(|| vec![Vec3::ZERO; s.vertex_count()])
    }

    internal! {
        /// Stage 2: the bounces from `src` with `gather`'s bounce count (on the
        /// GPU kernel when the solver has one; the CPU's when it fails), hidden
        /// vertices replaced as link targets in every bounce
        /// ([`crate::exchange::bounce::hidden`]; not when `quick`), with the
        /// control variate and the later bounces' near field added (not when `quick`).
        pub fn gathered(&self, src: &Sources, gather: &GatherParams, quick: bool) -> Gathered {
            let s = &self.scene;
            let reconstruction = self.reconstruction();
            let b0 = self.links_source(&src.e_source, &src.e_emitter, &src.emission);
            let stand_ins = if quick { Arc::default() } else { self.stand_ins() };
            let on_gpu = self.gpu.as_ref().map(|g| {
                g.links
                    .kernel_from_radiosity(&b0, &s.albedo)
                    .and_then(|k| k.with_reconstruction(reconstruction.as_ref()))
                    .and_then(|k| exchange::bounce::gather::drive(&mut k.with_stand_ins(stand_ins.to_vec()), gather))
            });
            let bounces = gpu_else_cpu("gathering", on_gpu, || self.gather_cpu(&b0, &stand_ins, gather));
            let mut e = bounces.e_indirect.clone();
            src.add_control_variate(&mut e);
            let e_near_gather = if quick { Vec::new() } else { self.near_later(src, &e, &stand_ins) };
            e.iter_mut().zip(&e_near_gather).for_each(|(g, d)| *g += *d);
            Gathered { bounces, e_near_gather, e }
        }
    }

    /// The later bounces' near field ([`exchange::near::gather`]), W/m^2,
    /// for the gathered `E_i` `gathered` (control variate included) of the
    /// sources `src`, with the hidden vertices' `stand_ins`; empty without
    /// near hits.
    pub(super) fn near_later(&self, src: &Sources, gathered: &[Vec3], stand_ins: &[StandIn]) -> Vec<Vec3> {
        use exchange::near::NearTerm;
        if self.traced.near.gather.is_empty() {
            return Vec::new();
        }
        let s = &self.scene;
        let mut g_h = gathered.to_vec();
        for (h, linkers) in stand_ins {
            g_h[*h] = exchange::bounce::hidden::stand_in_irradiance(linkers, |u| gathered[u]);
        }
        // What the links read of the total and of the gathered part (module
        // doc of `exchange::bounce::reconstruct`); the gather rays read it too.
        let mut e_h: Vec<Vec3> = src.e_source.iter().zip(&g_h).map(|(e, g)| *e + *g).collect();
        if let Some(r) = self.reconstruction() {
            e_h = r.through_albedo(&s.albedo, &e_h);
            g_h = r.through_albedo(&s.albedo, &g_h);
        }
        let b_h: Vec<Vec3> = (0..s.vertex_count())
            .into_par_iter()
            .map(|v| radiosity(s.albedo[v], e_h[v], src.emission.get(v).copied().unwrap_or(Vec3::ZERO)))
            .collect();
        let fields = Fields { b_later: &b_h, g_later: &g_h, ..self.fields(&[], &[]) };
        self.traced.near.correction(Bounce::Later, &fields).unwrap_or_default()
    }

    internal! {
        /// The radiosity the first bounce gathers, W/(m^2 sr): `rho/pi E + M/pi`
        /// for the source irradiance `e_source` and the emission the links
        /// carry, with `e_source` less the emitters' direct light `e_emitter`
        /// (empty: none) gradient-corrected when the correction is on
        /// ([`exchange::bounce::reconstruct`]).
        pub fn links_source(&self, e_source: &[Vec3], e_emitter: &[Vec3], emission: &[Vec3]) -> Vec<Vec3> {
            let s = &self.scene;
            let Some(r) = self.reconstruction() else {
                return exchange::bounce::operator::source_radiosity(e_source, &s.albedo, emission);
            };
            let em = |v: usize| e_emitter.get(v).copied().unwrap_or(Vec3::ZERO);
            let rest: Vec<Vec3> = e_source.iter().enumerate().map(|(v, e)| *e - em(v)).collect();
            let mut read = r.through_albedo(&s.albedo, &rest);
            read.iter_mut().enumerate().for_each(|(v, e)| *e += em(v));
            exchange::bounce::operator::source_radiosity(&read, &s.albedo, emission)
        }
    }

    /// The CPU bounces from radiosity `b0`, W/(m^2 sr).
    fn gather_cpu(&self, b0: &[Vec3], stand_ins: &[StandIn], params: &GatherParams) -> GatherResult {
        let reconstruction = self.reconstruction();
        let mut kernel = exchange::bounce::gather::CpuBounces::from_radiosity(&self.links, &self.scene.albedo, b0)
            .with_stand_ins(stand_ins)
            .with_reconstruction(reconstruction.as_deref());
        exchange::bounce::gather::drive(&mut kernel, params).expect("the CPU kernel cannot fail")
    }

    internal! {
        /// Gathered `E_i` with hidden vertices replaced as link targets by the
        /// iteration after the bounces ([`crate::exchange::bounce::hidden::correct`]),
        /// W/m^2: the oracle of the substitution [`Solver::solve`] runs inside
        /// the bounces.
        #[cfg(any(test, feature = "internals"))]
        pub fn correct_hidden(&self, e_gathered: &[Vec3]) -> Vec<Vec3> {
            let s = &self.scene;
            let rays = self.params.links.rays_per_vertex;
            exchange::bounce::hidden::correct(&self.links, rays, &s.albedo, e_gathered, &self.params.hidden).0
        }
    }

    internal! {
        /// Stage 3: the gathered part of `E_i`, `e_gathered` (W/m^2,
        /// [`Solution::e_gathered`]), smoothed at feature angle `angle_deg` (0:
        /// unchanged) with the solver's filter, `e_source` the bounces' source.
        pub fn smooth(&self, e_source: &[Vec3], e_gathered: &[Vec3], angle_deg: f32) -> Vec<Vec3> {
            let s = &self.scene;
            let p = &self.params.smoothing;
            match p.mode {
                _ if angle_deg <= 0.0 => e_gathered.to_vec(),
                SmoothMode::Uniform => exchange::smooth(e_gathered, &s.rings, &s.normals, angle_deg),
                SmoothMode::Adaptive => {
                    let var = self.noise_variance(e_source, e_gathered);
                    exchange::smooth_adaptive(e_gathered, &var, &s.rings, &s.normals, angle_deg, p.passes)
                }
            }
        }
    }
}
