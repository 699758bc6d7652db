//! The indirect light at near hits: a final gather from the hit point.
//! The near fields ([`super::near_field`], [`super::near_emitters`],
//! [`super::near_sky`]) make a near hit's first bounce exact; what it
//! brings of the later bounces is still the hit triangle's corners'
//! gathered irradiance `G(c)`, interpolated. Under an overhang that is
//! wrong: `tearoom`'s bowls stand on feet 3 mm above the table, whose 5 cm
//! triangles have their corners out in the room's light while the table
//! under a foot sees the foot's dark underside (the undersides read 2x the
//! reference there, the scene's largest errors at 1024 rays). Here each
//! near hit `h` sends `m` cosine-distributed rays and takes the radiosity
//! where they land:
//!
//! ```text
//! D_g(x) = 1/n * sum over near hits k of [ rho(h_k) Ghat(h_k) - sum_c beta_c rho_c G_H(c) ]
//! Ghat(h) = pi/m * sum_j B_H(y_j)        (B_H at y_j interpolated from its corners; 0 where a ray left)
//! ```
//!
//! with `B_H = rho/pi (E_src + G_H) + M_e/pi` the total radiosity the links
//! carry (W/(m^2 sr)) and `G_H` the gathered irradiance with a hidden
//! vertex's replaced by its stand-ins' ([`super::hidden`]), as the bounce
//! kernels do. It is added to the gathered `E_i` after the bounces (it is
//! not carried on through them: a second-order term) and smoothed with it.
//!
//! Stored: per vertex, the corners of the gather rays' hits merged with
//! their weights `rho(h) pi beta / (m n)` (RGB), so a new radiosity (a
//! moved light, a changed sky) needs no ray. Rays start `eps * l` off and
//! into the hit's triangle (l its longest edge), as the sky's near-hit
//! rays. Units: irradiance W/m^2, radiosity W/(m^2 sr), lengths metres.
//! Measured: see [`NearGatherParams::rays`]; tearoom's bowls' feet
//! undersides went from 2x the reference (0.28 against 0.135 W/m^2) to
//! within its noise, and the plates of `tests/near_field.rs` from 15-19%
//! low to within 5%.
//!
//! Deviation from the paper: the paper gathers only over vertex links;
//! this is a one-level final gather, as photon mappers and radiosity
//! renderers do at the hit points of their first rays, here only where
//! the links' interpolation is known to fail (near hits).

use crate::kdtree::traverse::{Ray, NO_SKIP};
use crate::links::{NearHit, NearHits};
use crate::sampling::{basis, cosine_hemisphere, splitmix64};
use crate::scene::prep::PreparedScene;
use crate::trace::Tracer;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// How the final gather at near hits is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearGatherParams {
    /// Rays per near hit (0: off); [`Self::for_link_rays`] sets it from
    /// the link rays. Measured (total relative RMSE against the reference,
    /// auto bounces, seed 1, `examples/sky_probe.rs`, `NEAR_GATHER=m`), off
    /// / 1 / 2 / 4 rays a hit: tearoom 1024 link rays 1.67 / 1.18 / 1.12 /
    /// 1.08%, cornell 1.02 / 1.03 / 0.99 / 0.97%; at 64 link rays cornell
    /// 4.84 / 5.10 / - / 4.85% and tearoom 4.77 / 4.85 / - / 4.62% (one ray a
    /// hit adds more noise than it takes bias when a vertex has a few near
    /// hits), at 256 cornell 2.21 / 2.32 / 2.23 / 2.19%, tearoom 2.34 / 2.20
    /// / - / 2.02%. Cost at 1024 link rays on tearoom: 1.74M near hits, 3.5M
    /// rays at 2 a hit beside the links' 13.3M. Without the stand-ins for
    /// hidden vertices (a prototype) cornell read 1.26-1.31% at 1024 rays:
    /// rays from the floor beside a box meet its bottom row, hidden
    /// vertices whose own irradiance is meaningless; added after the
    /// smoothing instead of with the gathered part, tearoom 64 rays read
    /// 5.3%.
    pub rays: u32,
    /// Rays start `eps * l` off and into the hit's triangle (l: its longest edge).
    pub eps: f32,
    pub seed: u64,
}

impl Default for NearGatherParams {
    fn default() -> Self {
        Self { rays: 2, eps: 1e-4, seed: 1 }
    }
}

impl NearGatherParams {
    /// Rays a near hit for `link_rays` link rays a vertex: `1024 / n`
    /// between 2 and 4 (few link rays, few near hits a vertex: more rays
    /// each keep the correction's noise below the links'; see [`Self::rays`]).
    pub fn for_link_rays(link_rays: u32) -> u32 {
        (1024 / link_rays.max(1)).clamp(2, 4)
    }
}

/// Every vertex's near hits' gather weights (see the module doc).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NearGather {
    /// Vertex `v`'s entries are `offsets[v]..offsets[v + 1]` (empty: none anywhere).
    pub offsets: Vec<u32>,
    pub targets: Vec<u32>,
    /// sr per channel: `rho(h) pi beta / (m n)` summed per target.
    pub weights: Vec<Vec3>,
    pub rays: u64,
    pub ms: f64,
}

impl NearGather {
    /// Traces `params.rays` rays from every near hit of `near` (link rays
    /// shot `rays_per_vertex` a vertex) with `tracer`.
    pub fn compute(
        scene: &PreparedScene,
        near: &NearHits,
        tracer: &dyn Tracer,
        params: &NearGatherParams,
        rays_per_vertex: u32,
    ) -> crate::Result<NearGather> {
        let start = Instant::now();
        let n = scene.vertex_count();
        let mut out = NearGather::default();
        if near.is_empty() || params.rays == 0 {
            return Ok(out);
        }
        out.offsets = vec![0; n + 1];
        let scale = std::f32::consts::PI / (params.rays as f32 * rays_per_vertex.max(1) as f32);
        for range in near.vertex_batches(n, 1 << 16) {
            let (v0, v1) = (range.start, range.end);
            let batch: Vec<Vec<(Ray, Vec3)>> = (v0..v1)
                .into_par_iter()
                .map(|v| {
                    let hits = near.of(v);
                    hits.iter()
                        .enumerate()
                        .flat_map(|(i, h)| {
                            let rank = hits[..i].iter().filter(|o| o.tri == h.tri).count();
                            let w = albedo_at(scene, h) * scale;
                            gather_rays(scene, h, params, v, rank).into_iter().map(move |r| (r, w))
                        })
                        .collect()
                })
                .collect();
            let rays: Vec<Ray> = batch.iter().flatten().map(|r| r.0).collect();
            out.rays += rays.len() as u64;
            let found = tracer.closest_hits(&rays)?;
            let mut hit = found.into_iter();
            for (k, samples) in batch.into_iter().enumerate() {
                let mut row: Vec<(u32, Vec3)> = Vec::new();
                for (_, w) in samples {
                    let Some(y) = hit.next().expect("one answer per ray") else { continue };
                    if !y.front {
                        continue;
                    }
                    let tri = scene.triangles[y.tri as usize];
                    for (c, b) in tri.iter().zip(y.barycentrics()) {
                        row.push((*c, w * b));
                    }
                }
                row.sort_by_key(|e| e.0);
                let mut merged: Vec<(u32, Vec3)> = Vec::with_capacity(row.len());
                for (t, w) in row {
                    match merged.last_mut() {
                        Some(last) if last.0 == t => last.1 += w,
                        _ => merged.push((t, w)),
                    }
                }
                out.targets.extend(merged.iter().map(|e| e.0));
                out.weights.extend(merged.iter().map(|e| e.1));
                out.offsets[v0 + k + 1] = out.targets.len() as u32;
            }
        }
        out.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(out)
    }

    /// True when it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.offsets.is_empty()
    }

    /// `D_g` of every vertex (module doc), W/m^2, for the radiosity `b_h`
    /// (W/(m^2 sr)) and gathered irradiance `g_h` (W/m^2) with hidden
    /// vertices' stand-ins applied, over the near hits `near` the rays
    /// were traced from.
    pub fn correction(
        &self,
        scene: &PreparedScene,
        near: &NearHits,
        b_h: &[Vec3],
        g_h: &[Vec3],
        rays_per_vertex: u32,
    ) -> Vec<Vec3> {
        let n = scene.vertex_count();
        if self.is_empty() || near.offsets.len() != n + 1 {
            return vec![Vec3::ZERO; n];
        }
        let inv = 1.0 / rays_per_vertex.max(1) as f32;
        (0..n)
            .into_par_iter()
            .map(|v| {
                let r = self.offsets[v] as usize..self.offsets[v + 1] as usize;
                let gathered: Vec3 =
                    self.targets[r.clone()].iter().zip(&self.weights[r]).map(|(&t, w)| b_h[t as usize] * *w).sum();
                let mut interpolated = Vec3::ZERO;
                for h in near.of(v) {
                    let tri = scene.triangles[h.tri as usize];
                    let beta = [1.0 - h.u - h.v, h.u, h.v];
                    for c in 0..3 {
                        let cv = tri[c] as usize;
                        interpolated += scene.albedo[cv] * g_h[cv] * beta[c];
                    }
                }
                gathered - interpolated * inv
            })
            .collect()
    }

    /// Checks the structure against `n` vertices: CSR offsets, targets in
    /// range and ascending per vertex, finite non-negative weights.
    pub fn validate(&self, n: usize) -> Result<(), String> {
        if self.is_empty() {
            return if self.targets.is_empty() && self.weights.is_empty() {
                Ok(())
            } else {
                Err("targets without offsets".into())
            };
        }
        if self.offsets.len() != n + 1
            || self.offsets[0] != 0
            || self.offsets.windows(2).any(|w| w[0] > w[1])
            || *self.offsets.last().unwrap() as usize != self.targets.len()
            || self.targets.len() != self.weights.len()
        {
            return Err(format!(
                "{} offsets, {} targets, {} weights for {n} vertices",
                self.offsets.len(),
                self.targets.len(),
                self.weights.len()
            ));
        }
        for v in 0..n {
            let row = &self.targets[self.offsets[v] as usize..self.offsets[v + 1] as usize];
            if row.iter().any(|&t| t as usize >= n) || row.windows(2).any(|w| w[0] >= w[1]) {
                return Err(format!("vertex {v}: targets out of range or order"));
            }
        }
        if let Some(w) = self.weights.iter().find(|w| !(w.is_finite() && w.min_element() >= 0.0)) {
            return Err(format!("weight {w}"));
        }
        Ok(())
    }
}

/// The albedo at near hit `h`, interpolated from its triangle's corners.
fn albedo_at(scene: &PreparedScene, h: &NearHit) -> Vec3 {
    let tri = scene.triangles[h.tri as usize];
    let beta = [1.0 - h.u - h.v, h.u, h.v];
    (0..3).map(|c| scene.albedo[tri[c] as usize] * beta[c]).sum()
}

/// The gather rays of near hit `h` of vertex `v` (the `rank`-th of its
/// hits on that triangle: the directions hash from the vertex, the
/// triangle and the rank, as [`super::near_sky`]'s).
fn gather_rays(scene: &PreparedScene, h: &NearHit, params: &NearGatherParams, v: usize, rank: usize) -> Vec<Ray> {
    let (p, normal, l) = super::near_field::hit_frame(scene, h);
    let eps = params.eps * l;
    let centroid = scene.triangles[h.tri as usize].map(|i| scene.positions[i as usize]).iter().sum::<Vec3>() / 3.0;
    let origin = p + normal * eps + (centroid - p).normalize_or_zero() * eps;
    let key = splitmix64(
        splitmix64(splitmix64(params.seed ^ 0x9b05_688c_2b3e_6c1f) ^ v as u64)
            ^ (u64::from(h.tri) | (rank as u64) << 32),
    );
    let (t, b) = basis(normal);
    let unit = |x: u64| (x >> 40) as f32 / (1u64 << 24) as f32;
    (0..params.rays)
        .filter_map(|j| {
            let hash = splitmix64(key ^ u64::from(j));
            let local = cosine_hemisphere(Vec2::new(unit(hash), unit(splitmix64(hash))));
            let dir = (t * local.x + b * local.y + normal * local.z).normalize_or_zero();
            (dir != Vec3::ZERO && local.z > 0.0).then_some(Ray {
                origin,
                dir,
                tmin: 0.0,
                tmax: f32::INFINITY,
                skip: NO_SKIP,
            })
        })
        .collect()
}
