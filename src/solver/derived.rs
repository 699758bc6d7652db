//! What a solve derives from the traced parts before and around the
//! bounces: the sky's and emitters' irradiance at the vertices, the caches
//! kept between solves (hidden vertices' stand-ins, the emitter control
//! variate, the radiosity correction; dropped by
//! [`Solver::links_changed`](super::Solver) and its emitter counterpart),
//! and the noise estimate the smoothing weighs by. Irradiance in W/m^2.

use super::Solver;
use crate::exchange;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Arc;

impl Solver {
    /// Irradiance from the scene's sky at every vertex, W/m^2
    /// (`crate::sky::SkyRays::irradiance`).
    pub fn e_sky(&self) -> Vec<Vec3> {
        let p = &self.params;
        self.traced.sky.irradiance(&self.scene, &self.links.sky, &p.links, &p.smoothing, p.sky_smoothing_angle())
    }

    /// The emitters' direct light at every vertex, W/m^2: the emitter links'
    /// (`crate::exchange::EmitterLinks::irradiance`) plus, at a vertex of an
    /// emitter group, its own emission over the band of directions that
    /// dive under its own triangles (`crate::links::shoot::dive_share`).
    /// In a concave region those directions meet the surface right beside
    /// the vertex, whose radiance is the vertex's own, `(M_e + rho E) / pi`;
    /// the self links carry `rho E / pi` (the vertex's radiosity leaves its
    /// emission to the emitter links), and the emitter links' Lambert
    /// formula sees nothing of the vertex's own triangles (their planes pass
    /// through it), so `M_e` times the band's share is added here, exactly
    /// (Lambert's formula on the band, not the self links' count: the few
    /// shared direction sets put 2.2x the band's share of rays into it on
    /// the furnace sphere, 0.39% against 0.17%). Measured: the emissive
    /// furnace's `E` 0.17% low before (the band), exact after.
    pub fn e_emitter(&self) -> Vec<Vec3> {
        let s = &self.scene;
        let links = &self.traced.emitter_links;
        let mut e = links.irradiance(&s.emission, s.vertex_count());
        if links.is_active() {
            e.par_iter_mut().enumerate().for_each(|(v, e)| {
                if links.covered[v] && s.emission[v] != Vec3::ZERO {
                    *e += s.emission[v] * crate::links::shoot::dive_share(s, v);
                }
            });
        }
        e
    }

    /// Hidden vertices and their linkers ([`exchange::bounce::hidden::stand_ins`]),
    /// from the cache when the links and hidden-vertex parameters are unchanged.
    pub(crate) fn stand_ins(&self) -> Arc<Vec<exchange::bounce::hidden::StandIn>> {
        if !self.params.terms.hidden {
            return Arc::default();
        }
        let mut cache = self.caches.stand_ins.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((p, v)) = &*cache {
            if *p == self.params.hidden {
                return v.clone();
            }
        }
        let rays = self.params.links.rays_per_vertex;
        let v = Arc::new(exchange::bounce::hidden::stand_ins(&self.links, rays, &self.params.hidden));
        *cache = Some((self.params.hidden, v.clone()));
        v
    }

    internal! {
        /// The emitter groups' control variate of the first bounce for the
        /// current links and emitter links ([`exchange::sources::emitter_cv`]),
        /// computed on first use (one pass over the links) and kept; empty when
        /// off ([`crate::scene::terms::Terms::emitter_cv`]) or without emitter groups.
        pub fn emitter_cv(&self) -> Arc<exchange::EmitterCv> {
            let links = &self.traced.emitter_links;
            if !self.params.terms.emitter_cv || !links.is_active() {
                return Arc::default();
            }
            let mut cache = self.caches.emitter_cv.lock().unwrap_or_else(|p| p.into_inner());
            cache.get_or_insert_with(|| Arc::new(exchange::EmitterCv::compute(&self.scene, &self.links, links))).clone()
        }
    }

    internal! {
        /// The radiosity correction's weights for the current geometry
        /// ([`exchange::bounce::reconstruct`]), computed on first use and kept;
        /// `None` when off ([`crate::scene::terms::Terms::reconstruct`]).
        pub fn reconstruction(&self) -> Option<Arc<exchange::Reconstruction>> {
            if !self.params.terms.reconstruct {
                return None;
            }
            let mut cache = self.caches.reconstruction.lock().unwrap_or_else(|p| p.into_inner());
            Some(cache.get_or_insert_with(|| Arc::new(exchange::Reconstruction::new(&self.scene))).clone())
        }
    }

    internal! {
        /// The noise variance of every vertex's gathered `E_i`
        /// ([`crate::exchange::denoise::noise`]), (W/m^2)^2, for
        /// `e_gathered` = [`super::Solution::e_gathered`] and its `e_source`:
        /// the independent-ray variance times the noise check's local ratio
        /// ([`crate::exchange::denoise::noise_check`]; the model's without a
        /// check), averaged over the feature ring ([`crate::exchange::smooth()`]).
        pub fn noise_variance(&self, e_source: &[Vec3], e_gathered: &[Vec3]) -> Vec<Vec3> {
            let s = &self.scene;
            let b = self.radiosity_moments(e_source, e_gathered);
            let rays = self.params.links.rays_per_vertex;
            let mut var = exchange::denoise::noise::variance_iid(&self.links, &b, rays);
            match self.traced.noise_check.ratios(&self.links, &b, rays) {
                Some(r) => var.iter_mut().zip(&r).for_each(|(v, r)| *v *= *r),
                None => {
                    let ratio = self.params.smoothing.noise.ratio(rays);
                    var.iter_mut().for_each(|v| *v *= ratio);
                }
            }
            // Pooled over the feature ring: a vertex's own estimate is correlated with its noise
            // (see the smoothing's module doc).
            exchange::smooth(&var, &s.rings, &s.normals, self.params.smoothing_angle())
        }
    }

    internal! {
        /// The scene-wide ratio of actual to independent-ray variance of `E_i`
        /// for `e_gathered` = [`super::Solution::e_gathered`] and its
        /// `e_source`: measured over the whole sample of the noise check
        /// ([`crate::exchange::denoise::noise_check`]), or the model's
        /// ([`crate::exchange::NoiseParams::ratio`]) without a check.
        /// [`Solver::noise_variance`] applies the local ratios around each vertex.
        pub fn noise_ratio(&self, e_source: &[Vec3], e_gathered: &[Vec3]) -> f32 {
            let rays = self.params.links.rays_per_vertex;
            let b = self.radiosity_moments(e_source, e_gathered);
            let check = &self.traced.noise_check;
            check.ratio(&self.links, &b, rays).unwrap_or_else(|| self.params.smoothing.noise.ratio(rays))
        }
    }

    /// Radiosity and its square per vertex for the noise estimate
    /// ([`exchange::denoise::noise::radiosity_moments`]), from the bounces'
    /// source and the gathered `E_i`. With emitter groups, a group vertex's
    /// radiosity is taken less its group's mean, the part the first
    /// bounce's control variate removes
    /// ([`exchange::EmitterCv::adjust_moments`]; the mean of `e_source`,
    /// which holds the control variate itself: its group mean is noise
    /// about zero).
    fn radiosity_moments(&self, e_source: &[Vec3], e_gathered: &[Vec3]) -> Vec<[glam::Vec4; 2]> {
        let s = &self.scene;
        let carried = self.traced.emitter_links.carried_emission(&s.emission);
        let mut b = exchange::denoise::noise::radiosity_moments(&s.albedo, &carried, e_source, e_gathered);
        let cv = self.emitter_cv();
        if !cv.is_empty() {
            cv.adjust_moments(&mut b, &cv.group_means(&s.albedo, e_source));
        }
        b
    }
}
