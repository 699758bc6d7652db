//! One solve of a built [`Solver`] (docs/DESIGN.md §4): the direct
//! irradiances of the current lights, sky and emitters and the near-hit
//! correction ([`Solver::sources`]), the bounces on the CPU or GPU kernel
//! with hidden vertices replaced as link targets, and the noise-aware
//! smoothing of the gathered part. Irradiance in W/m^2, radiosity in
//! W/(m^2 sr).

use super::{Solution, Solver};
use crate::exchange::{self, GatherResult, SmoothMode};
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
    /// The near-hit correction of the first bounce ([`crate::exchange::near_field`]).
    pub e_near: Vec<Vec3>,
    /// The emitter groups' control variate of the first bounce
    /// ([`crate::exchange::emitter_cv`]): part of the gathered `E_i`.
    pub e_cv: Vec<Vec3>,
    /// What the bounces start from: the lights' bounce source plus `e_sky`, `e_emitter`, `e_near` and `e_cv`.
    pub e_source: Vec<Vec3>,
    /// The emitted exitance the vertex links carry (emitters without emitter links), W/m^2.
    pub emission: Vec<Vec3>,
}

impl Sources {
    /// `E_i` gathered over the links (W/m^2) with the first bounce's
    /// control variate `e_cv` added: what the smoothing smooths.
    pub fn add_control_variate(&self, e_gathered: &mut [Vec3]) {
        if !self.e_cv.is_empty() {
            e_gathered.iter_mut().zip(&self.e_cv).for_each(|(e, d)| *e += *d);
        }
    }

    /// Completes gathered `E_i` (W/m^2) in place: adds the parts not
    /// gathered over the links, the emitters' direct light and the near-hit
    /// correction, and keeps every channel at least 0.
    pub fn add_outside_links(&self, e_gathered: &mut [Vec3]) {
        for ((i, m), d) in e_gathered.iter_mut().zip(&self.e_emitter).zip(&self.e_near) {
            *i = (*i + *m + *d).max(Vec3::ZERO);
        }
    }
}

impl Solver {
    /// Gathers the bounces and smooths.
    pub fn solve(&self) -> Solution {
        self.solve_as(false)
    }

    /// A cheaper [`Solver::solve`] for previews: no hidden-vertex
    /// correction, and smoothing by the fixed one-ring average (no noise
    /// estimate). On dancer at 256 rays about 11 ms against 75 ms.
    pub fn solve_quick(&self) -> Solution {
        self.solve_as(true)
    }

    fn solve_as(&self, quick: bool) -> Solution {
        let s = &self.scene;
        let src = self.sources();
        let reconstruction = self.reconstruction();
        let b0 = self.links_source(&src.e_source, &src.e_emitter, &src.emission);
        // The hidden-vertex substitution runs inside the bounces, on either kernel.
        let stand_ins = if quick { Arc::default() } else { self.stand_ins() };
        let on_gpu = self.gpu.as_ref().map(|g| {
            g.links
                .kernel_from_radiosity(&b0, &s.albedo)
                .and_then(|k| k.with_reconstruction(reconstruction.as_ref()))
                .and_then(|k| exchange::gather::drive(&mut k.with_stand_ins(stand_ins.to_vec()), &self.params.gather))
        });
        let gather = match on_gpu {
            Some(Ok(r)) => r,
            Some(Err(e)) => {
                eprintln!("warning: {e}; gathering on the CPU");
                self.gather_cpu(&b0, &stand_ins, &self.params.gather)
            }
            None => self.gather_cpu(&b0, &stand_ins, &self.params.gather),
        };
        let angle = self.params.smoothing_angle_deg;
        let mut gathered = gather.e_indirect.clone();
        src.add_control_variate(&mut gathered);
        let e_near_gather = if quick { Vec::new() } else { self.near_gather_correction(&src, &gathered, &stand_ins) };
        gathered.iter_mut().zip(&e_near_gather).for_each(|(g, d)| *g += *d);
        let mut e_indirect = if quick {
            exchange::smooth(&gathered, &s.rings, &s.normals, angle)
        } else {
            self.smooth_gathered(&src.e_source, &gathered, angle)
        };
        let mut e_indirect_raw = gathered;
        src.add_outside_links(&mut e_indirect);
        src.add_outside_links(&mut e_indirect_raw);
        Solution {
            e_direct: src.e_direct,
            e_sky: src.e_sky,
            e_emitter: src.e_emitter,
            e_near: src.e_near,
            e_cv: src.e_cv,
            e_near_gather,
            e_source: src.e_source,
            e_indirect_raw,
            e_indirect,
            gather,
            smoothed: angle > 0.0,
        }
    }

    /// The emitters' direct light at every vertex, W/m^2: the emitter links'
    /// ([`crate::exchange::EmitterLinks::irradiance`]) plus, at a vertex of an
    /// emitter group, its own emission over the band of directions that
    /// dive under its own triangles ([`crate::links::shoot::dive_share`]).
    /// In a concave region those directions meet the surface right beside
    /// the vertex, whose radiance is the vertex's own, `(M_e + rho E) / pi`;
    /// the self links carry `rho E / pi` (the vertex's radiosity leaves its
    /// emission to the emitter links), and the emitter links' Lambert
    /// formula sees nothing of the vertex's own triangles (their planes pass
    /// through it), so `M_e` times the band's share is added here, exactly
    /// (Lambert's formula on the band, not the self links' count: the few
    /// shared direction sets put 2.2x the band's share of rays into it on
    /// the furnace sphere, 0.39% against 0.17%). Measured: the emissive
    /// furnace's `E` 0.17% low before (the band), exact after; `window`
    /// (the lamp's shade a 36-sided cone, concave inside): see
    /// [`Solver::sources`].
    pub fn e_emitter(&self) -> Vec<Vec3> {
        let s = &self.scene;
        let mut e = self.emitter_links.irradiance(&s.emission, s.vertex_count());
        if self.emitter_links.is_active() {
            e.par_iter_mut().enumerate().for_each(|(v, e)| {
                if self.emitter_links.covered[v] && s.emission[v] != Vec3::ZERO {
                    *e += s.emission[v] * crate::links::shoot::dive_share(s, v);
                }
            });
        }
        e
    }

    /// The first bounce's correction at near hits, W/m^2: the lights'
    /// ([`crate::exchange::near_field`], `e_src` the lights' bounce source)
    /// plus the emitters' ([`crate::exchange::near_emitters`]) and the
    /// sky's ([`crate::exchange::near_sky`], `e_sky` the vertices' sky
    /// light; computed here when `None` and needed).
    fn near_correction(&self, e_src: &[Vec3], e_sky: Option<&[Vec3]>) -> Vec<Vec3> {
        let s = &self.scene;
        let rays = self.params.links.rays_per_vertex;
        // The corner terms read what the links read (module doc of `exchange::reconstruct`).
        let reconstruction = self.reconstruction().filter(|_| !self.links.near.is_empty());
        let through = |x: &[Vec3]| reconstruction.as_ref().map(|r| r.through_albedo(&s.albedo, x));
        let e_src_read = through(e_src);
        let e_src = e_src_read.as_deref().unwrap_or(e_src);
        let mut d = self.near_light.correction(s, &self.links.near, &s.lights, e_src, rays);
        if !self.near_emitters.is_empty() {
            let em = self.near_emitters.correction(&s.emission, &self.emitter_links.group_vertex, s.vertex_count());
            d.iter_mut().zip(&em).for_each(|(d, e)| *d += *e);
        }
        if !self.near_sky.is_empty() && s.sky.is_some() {
            let owned;
            let e_sky = match e_sky {
                Some(e) => e,
                None => {
                    owned = self.e_sky();
                    &owned
                }
            };
            let e_sky_read = through(e_sky);
            let e_sky = e_sky_read.as_deref().unwrap_or(e_sky);
            let k = self.near_sky.correction(s, &self.links.near, s.sky.as_ref(), e_sky, rays);
            d.iter_mut().zip(&k).for_each(|(d, k)| *d += *k);
        }
        d
    }

    /// The direct irradiances of the current lights, sky and emission, and
    /// what the bounces start from.
    pub fn sources(&self) -> Sources {
        let s = &self.scene;
        let n = s.vertex_count();
        let e_sky = self.e_sky();
        let e_emitter = self.e_emitter();
        let mut e_source = self.light_links.bounce_source(&s.lights, n);
        let e_near = self.near_correction(&e_source, Some(&e_sky));
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
            e_direct: self.light_links.direct(&s.lights, n),
            e_sky,
            e_emitter,
            e_near,
            e_cv,
            e_source,
            emission: self.emitter_links.carried_emission(&s.emission).into_owned(),
        }
    }

    /// The later bounces' correction at near hits
    /// ([`exchange::near_gather`]), W/m^2, for the gathered `E_i`
    /// `gathered` (control variate included) of the sources `src`, with
    /// the hidden vertices' `stand_ins`; empty without near hits.
    pub fn near_gather_correction(
        &self,
        src: &Sources,
        gathered: &[Vec3],
        stand_ins: &[exchange::hidden::StandIn],
    ) -> Vec<Vec3> {
        if self.near_gather.is_empty() {
            return Vec::new();
        }
        let s = &self.scene;
        let mut g_h = gathered.to_vec();
        for (h, linkers) in stand_ins {
            g_h[*h] = exchange::hidden::stand_in_irradiance(linkers, |u| gathered[u]);
        }
        // What the links read of the total and of the gathered part (module
        // doc of `exchange::reconstruct`); the gather rays read it too.
        let mut e_h: Vec<Vec3> = src.e_source.iter().zip(&g_h).map(|(e, g)| *e + *g).collect();
        if let Some(r) = self.reconstruction() {
            e_h = r.through_albedo(&s.albedo, &e_h);
            g_h = r.through_albedo(&s.albedo, &g_h);
        }
        let b_h: Vec<Vec3> = (0..s.vertex_count())
            .into_par_iter()
            .map(|v| {
                s.albedo[v] / std::f32::consts::PI * e_h[v]
                    + src.emission.get(v).map_or(Vec3::ZERO, |m| *m / std::f32::consts::PI)
            })
            .collect();
        self.near_gather.correction(s, &self.links.near, &b_h, &g_h, self.params.links.rays_per_vertex)
    }

    /// The CPU bounces from `e_source` (W/m^2, [`Sources::e_source`], plus
    /// the emission the links carry, [`Sources::emission`]) with hidden
    /// vertices replaced as link targets in every bounce
    /// ([`crate::exchange::hidden`]). The result is the gathered part of
    /// `E_i`, without [`Sources::e_emitter`].
    pub fn gather_corrected(&self, e_source: &[Vec3], params: &exchange::GatherParams) -> GatherResult {
        let s = &self.scene;
        let emission = self.emitter_links.carried_emission(&s.emission);
        let e_emitter = if self.params.reconstruct { self.e_emitter() } else { Vec::new() };
        let b0 = self.links_source(e_source, &e_emitter, &emission);
        self.gather_cpu(&b0, &self.stand_ins(), params)
    }

    /// Irradiance from the scene's sky at every vertex, W/m^2: the link
    /// rays' misses ([`crate::sky::SkyVisibility`], refined cells
    /// [`crate::sky::refine`]) for the directions outside the portals and
    /// the portals' own rays ([`crate::sky::portal`]) for those through
    /// them, smoothed with their noise.
    pub fn e_sky(&self) -> Vec<Vec3> {
        let s = &self.scene;
        let n = s.vertex_count();
        let Some(sky) = s.sky.as_ref() else { return vec![Vec3::ZERO; n] };
        if self.links.sky.is_empty() && self.sky_portals.is_empty() {
            return vec![Vec3::ZERO; n];
        }
        let p = &self.params.links;
        let k = (p.rays_per_vertex as f64).sqrt().round() as u32;
        let (rotations, sets) = crate::sampling::vertex_rotations_and_sets(&s.rings, p.seed);
        let directions = crate::sampling::DirectionSet::new(k, p.seed);
        // Portals the samples were traced for: their directions are left to them.
        let frames = crate::sky::visibility::RayFrames {
            normals: &s.normals,
            rotations: &rotations,
            sets: &sets,
            directions: &directions,
            positions: &s.positions,
            portals: &self.sky_portals.portals,
        };
        let (angle, sp) = (self.params.smoothing_angle_deg, &self.params.smoothing);
        let smooth = sp.sky && sp.mode == SmoothMode::Adaptive && angle > 0.0;
        // The portals' part: stratified over the opening, left unsmoothed (see below).
        let portal_e = self.sky_portals.irradiance(sky, &s.positions, &s.normals, p.seed);
        let add_portals = |mut e: Vec<Vec3>| {
            e.iter_mut().zip(&portal_e).for_each(|(e, pe)| *e += *pe);
            e
        };
        let (e, var): (Vec<Vec3>, Vec<Vec3>) = if self.sky_refine.is_empty() {
            // One ray a cell: the variance of independent rays, pooled, times the stratification ratio.
            let (e, m2): (Vec<Vec3>, Vec<Vec3>) =
                self.links.sky.irradiance_and_moment(Some(sky), &frames, n).into_iter().unzip();
            if !smooth {
                return add_portals(e);
            }
            let mut var = exchange::smooth::pooled_variance(&e, &m2, p.rays_per_vertex, &s.rings, &s.normals, angle);
            let ratio = sp.noise.ratio(p.rays_per_vertex);
            var.iter_mut().for_each(|v| *v *= ratio);
            (e, var)
        } else {
            // Refined cells: their own variance, pooled over the ring.
            let (e, var): (Vec<Vec3>, Vec<Vec3>) =
                self.sky_refine.irradiance(&self.links.sky, Some(sky), &frames, p.seed, n).into_iter().unzip();
            if !smooth {
                return add_portals(e);
            }
            (e, exchange::smooth(&var, &s.rings, &s.normals, angle))
        };
        add_portals(exchange::smooth_adaptive(&e, &var, &s.rings, &s.normals, angle, sp.passes))
    }

    /// Hidden vertices and their linkers ([`exchange::hidden::stand_ins`]),
    /// from the cache when the links and hidden-vertex parameters are unchanged.
    pub(crate) fn stand_ins(&self) -> Arc<Vec<exchange::hidden::StandIn>> {
        let mut cache = self.stand_ins_cache.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((p, v)) = &*cache {
            if *p == self.params.hidden {
                return v.clone();
            }
        }
        let v =
            Arc::new(exchange::hidden::stand_ins(&self.links, self.params.links.rays_per_vertex, &self.params.hidden));
        *cache = Some((self.params.hidden, v.clone()));
        v
    }

    /// Drops what was derived from the links (the hidden vertices'
    /// stand-ins); call it after changing `links` in place.
    pub fn links_changed(&mut self) {
        *self.stand_ins_cache.get_mut().unwrap_or_else(|p| p.into_inner()) = None;
        *self.reconstruction_cache.get_mut().unwrap_or_else(|p| p.into_inner()) = None;
        self.emitters_changed();
    }

    /// Drops what was derived from the links and emitter links together
    /// (the control variate's coefficients): call after changing either.
    pub fn emitters_changed(&mut self) {
        *self.emitter_cv_cache.get_mut().unwrap_or_else(|p| p.into_inner()) = None;
    }

    /// The emitter groups' control variate of the first bounce for the
    /// current links and emitter links ([`exchange::emitter_cv`]), computed
    /// on first use (one pass over the links) and kept; empty when off
    /// ([`super::SolveParams::emitter_cv`]) or without emitter groups.
    pub fn emitter_cv(&self) -> Arc<exchange::EmitterCv> {
        if !self.params.emitter_cv || !self.emitter_links.is_active() {
            return Arc::default();
        }
        let mut cache = self.emitter_cv_cache.lock().unwrap_or_else(|p| p.into_inner());
        cache
            .get_or_insert_with(|| {
                Arc::new(exchange::EmitterCv::compute(&self.scene, &self.links, &self.emitter_links))
            })
            .clone()
    }

    /// The radiosity correction's weights for the current geometry
    /// ([`exchange::reconstruct`]), computed on first use and kept; `None`
    /// when off ([`super::SolveParams::reconstruct`]).
    pub fn reconstruction(&self) -> Option<Arc<exchange::Reconstruction>> {
        if !self.params.reconstruct {
            return None;
        }
        let mut cache = self.reconstruction_cache.lock().unwrap_or_else(|p| p.into_inner());
        Some(cache.get_or_insert_with(|| Arc::new(exchange::Reconstruction::new(&self.scene))).clone())
    }

    /// The radiosity the first bounce gathers, W/(m^2 sr): `rho/pi E + M/pi`
    /// for the source irradiance `e_source` and the emission the links
    /// carry, with `e_source` less the emitters' direct light `e_emitter`
    /// (empty: none) gradient-corrected when the correction is on
    /// ([`exchange::reconstruct`]).
    pub fn links_source(&self, e_source: &[Vec3], e_emitter: &[Vec3], emission: &[Vec3]) -> Vec<Vec3> {
        let s = &self.scene;
        let Some(r) = self.reconstruction() else {
            return exchange::gather::source_radiosity(e_source, &s.albedo, emission);
        };
        let em = |v: usize| e_emitter.get(v).copied().unwrap_or(Vec3::ZERO);
        let rest: Vec<Vec3> = e_source.iter().enumerate().map(|(v, e)| *e - em(v)).collect();
        let mut read = r.through_albedo(&s.albedo, &rest);
        read.iter_mut().enumerate().for_each(|(v, e)| *e += em(v));
        exchange::gather::source_radiosity(&read, &s.albedo, emission)
    }

    /// The CPU bounces from radiosity `b0`, W/(m^2 sr).
    fn gather_cpu(
        &self,
        b0: &[Vec3],
        stand_ins: &[exchange::hidden::StandIn],
        params: &exchange::GatherParams,
    ) -> GatherResult {
        let reconstruction = self.reconstruction();
        let mut kernel = exchange::gather::CpuBounces::from_radiosity(&self.links, &self.scene.albedo, b0)
            .with_stand_ins(stand_ins)
            .with_reconstruction(reconstruction.as_deref());
        exchange::gather::drive(&mut kernel, params).expect("the CPU kernel cannot fail")
    }

    /// Gathered `E_i` with hidden vertices replaced as link targets by the
    /// iteration after the bounces ([`crate::exchange::hidden::correct`]),
    /// W/m^2: the oracle of the substitution [`Solver::solve`] runs inside
    /// the bounces.
    pub fn correct_hidden(&self, e_gathered: &[Vec3]) -> Vec<Vec3> {
        let s = &self.scene;
        exchange::hidden::correct(
            &self.links,
            self.params.links.rays_per_vertex,
            &s.albedo,
            e_gathered,
            &self.params.hidden,
        )
        .0
    }

    /// `E_i` smoothed at feature angle `angle_deg` (0: unchanged) with the
    /// solver's filter: `e_raw` is [`Solution::e_indirect_raw`] (emitters'
    /// direct light and the near-hit correction included, which are left
    /// as they are: only the gathered bounces are smoothed), `e_source`
    /// [`Solution::e_source`], W/m^2.
    pub fn smooth(&self, e_source: &[Vec3], e_raw: &[Vec3], angle_deg: f32) -> Vec<Vec3> {
        let Some(outside) = self.outside_links() else {
            return self.smooth_gathered(e_source, e_raw, angle_deg);
        };
        let gathered: Vec<Vec3> = e_raw.iter().zip(&outside).map(|(e, m)| *e - *m).collect();
        let mut out = self.smooth_gathered(e_source, &gathered, angle_deg);
        out.iter_mut().zip(&outside).for_each(|(o, m)| *o = (*o + *m).max(Vec3::ZERO));
        out
    }

    /// The part of `E_i` not gathered over the links, W/m^2: the emitters'
    /// direct light and the near-hit correction; `None` when both are zero.
    fn outside_links(&self) -> Option<Vec<Vec3>> {
        if !self.emitter_links.is_active() && self.links.near.is_empty() {
            return None;
        }
        let s = &self.scene;
        let n = s.vertex_count();
        let e_src = self.light_links.bounce_source(&s.lights, n);
        let e_near = self.near_correction(&e_src, None);
        let e_emitter = self.e_emitter();
        Some(e_emitter.iter().zip(&e_near).map(|(m, d)| *m + *d).collect())
    }

    /// The gathered bounces `e_raw` (no emitter light, no near-hit
    /// correction: [`Solver::gather_corrected`]'s result) smoothed, with
    /// `e_source` the bounces' source, W/m^2.
    pub fn smooth_gathered(&self, e_source: &[Vec3], e_raw: &[Vec3], angle_deg: f32) -> Vec<Vec3> {
        let s = &self.scene;
        let p = &self.params.smoothing;
        match p.mode {
            _ if angle_deg <= 0.0 => e_raw.to_vec(),
            SmoothMode::Uniform => exchange::smooth(e_raw, &s.rings, &s.normals, angle_deg),
            SmoothMode::Adaptive => {
                let var = self.gathered_noise_variance(e_source, e_raw);
                exchange::smooth_adaptive(e_raw, &var, &s.rings, &s.normals, angle_deg, p.passes)
            }
        }
    }

    /// The noise variance of every vertex's gathered `E_i` ([`crate::exchange::noise`]),
    /// (W/m^2)^2, for `e_raw` = [`Solution::e_indirect_raw`] (the emitters'
    /// direct light and the near-hit correction in it are taken out): the
    /// independent-ray variance times the noise check's local ratio
    /// ([`crate::exchange::noise_check`]; the model's without a check),
    /// averaged over the feature ring ([`crate::exchange::smooth()`]).
    pub fn noise_variance(&self, e_source: &[Vec3], e_raw: &[Vec3]) -> Vec<Vec3> {
        self.gathered_noise_variance(e_source, &self.gathered_part(e_raw))
    }

    /// `e_raw` = [`Solution::e_indirect_raw`] without what was not
    /// gathered over the links ([`Solver::outside_links`]), W/m^2.
    fn gathered_part<'a>(&self, e_raw: &'a [Vec3]) -> std::borrow::Cow<'a, [Vec3]> {
        match self.outside_links() {
            Some(outside) => e_raw.iter().zip(&outside).map(|(e, m)| *e - *m).collect(),
            None => e_raw.into(),
        }
    }

    /// Radiosity and its square per vertex for the noise estimate
    /// ([`exchange::noise::radiosity_moments`]), from the bounces' source
    /// and the gathered `E_i`.
    /// With emitter groups, a group vertex's radiosity is taken less its
    /// group's mean, the part the first bounce's control variate removes
    /// ([`exchange::EmitterCv::adjust_moments`]; the mean of `e_source`,
    /// which holds the control variate itself: its group mean is noise
    /// about zero).
    fn radiosity_moments(&self, e_source: &[Vec3], e_gathered: &[Vec3]) -> Vec<[glam::Vec4; 2]> {
        let s = &self.scene;
        let mut b = exchange::noise::radiosity_moments(
            &s.albedo,
            &self.emitter_links.carried_emission(&s.emission),
            e_source,
            e_gathered,
        );
        let cv = self.emitter_cv();
        if !cv.is_empty() {
            cv.adjust_moments(&mut b, &cv.group_means(&s.albedo, e_source));
        }
        b
    }

    fn gathered_noise_variance(&self, e_source: &[Vec3], e_raw: &[Vec3]) -> Vec<Vec3> {
        let s = &self.scene;
        let b = self.radiosity_moments(e_source, e_raw);
        let rays = self.params.links.rays_per_vertex;
        let mut var = exchange::noise::variance_iid(&self.links, &b, rays);
        match self.noise_check.ratios(&self.links, &b, rays) {
            Some(r) => var.iter_mut().zip(&r).for_each(|(v, r)| *v *= *r),
            None => {
                let ratio = self.params.smoothing.noise.ratio(rays);
                var.iter_mut().for_each(|v| *v *= ratio);
            }
        }
        // Pooled over the feature ring: a vertex's own estimate is correlated with its noise
        // (see the smoothing's module doc).
        exchange::smooth(&var, &s.rings, &s.normals, self.params.smoothing_angle_deg)
    }

    /// The scene-wide ratio of actual to independent-ray variance of `E_i`
    /// for `e_raw` = [`Solution::e_indirect_raw`] and its `e_source`:
    /// measured over the whole sample of the noise check
    /// ([`crate::exchange::noise_check`]), or the model's
    /// ([`crate::exchange::NoiseParams::ratio`]) without a check.
    /// [`Solver::noise_variance`] applies the local ratios around each vertex.
    pub fn noise_ratio(&self, e_source: &[Vec3], e_raw: &[Vec3]) -> f32 {
        let rays = self.params.links.rays_per_vertex;
        let b = self.radiosity_moments(e_source, &self.gathered_part(e_raw));
        self.noise_check.ratio(&self.links, &b, rays).unwrap_or_else(|| self.params.smoothing.noise.ratio(rays))
    }
}
