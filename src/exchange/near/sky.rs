//! Exact sky light at near hits: the sky's counterpart of
//! [`crate::exchange::near::light`] and [`crate::exchange::near::emitters`]. A link ray of
//! vertex `x` that meets a triangle close by ([`crate::links::near`])
//! brings, in its first bounce, the sky light interpolated from the
//! triangle's corners, `sum_c beta_c rho_c E_sky(c)`. Where an object
//! stands close to a large triangle that is wrong in both directions: the
//! wall behind `window`'s cabinet is lit by the window above the 5 cm gap
//! and dark inside it, within one 25 cm triangle (the cabinet's back read
//! 40% dark in its first bounce), and the floor vertices on the cabinet's
//! foot line see half a sky, so the floor just in front of it is
//! interpolated darker than it is (the cabinet's front row 65% dark). Here
//! the hit point's own sky light is estimated and replaces the
//! interpolated one:
//!
//! ```text
//! D_sky(x) = 1/n * sum over near hits k of [ rho(h_k) E_sky(h_k) - sum_c beta_c rho_c E_sky(c) ]
//! E_sky(h) = pi/m_c * sum_{j < m_c} V_j L(w_j)                               (cosine directions)
//!          + sum_p 1/m_p * sum_{j < m_p} V_j L(w_j) cos_h cos_p A_p / r_j^2   (portal points)
//! ```
//!
//! split as the vertices' `E_sky` is ([`crate::sky::portal`]): `m_c`
//! cosine-distributed directions about the hit triangle's normal whose
//! rays leave the scene (`V_j`) and cross no portal, plus `m_p` points on
//! each portal (jittered on a grid, first portal first). Each is an
//! unbiased estimate at the hit; their noise averages over the vertex's
//! near hits. `E_sky(c)` is the corners' `E_sky` as the bounces use it.
//!
//! Stored: the directions that reached the sky and their weights
//! (`rho(h)` and the estimator's factor over `n`), per vertex, so a
//! changed, turned or rescaled sky is integrated again with one radiance
//! lookup per stored direction and no ray (the sky edit stays
//! gather-only). Traced with the sky's other rays ([`crate::solver`]'s
//! `sky_rays`): when the portals change, when a sky appears, after a
//! deformation. Units: `E` in W/m^2, `L` in W/(m^2 sr), lengths in
//! metres, weights W/m^2 per W/(m^2 sr).
//!
//! Measured on `window` (16384-path reference, total relative RMSE, auto
//! bounces; `cargo test --release --test measured -- --ignored
//! sky_at_near_hits_lowers_window_error` compares with `--off near_sky`;
//! seed 1 now 1.27 -> 1.10%, the cabinet 5.49 -> 1.58%): at 1024 rays over seeds 1 / 2 / 3 1.44 / 1.49 / 1.47% without,
//! 1.19 / 1.25 / 1.22% with (the cabinet alone 7.9 -> 3.8%); when it came
//! (before [`crate::exchange::sources::emitter_cv`]) 256 rays 2.27 -> 2.13% and 64 rays 4.60 ->
//! 4.53% on seed 1.
//! Where it came from: with the sky alone, the first bounce of the sky's
//! light read 16% low on the cabinet and 1.2% low over the room against
//! the reference (paths cut after one bounce), the room's 1% dark bias of
//! earlier measurements. The samples a hit barely matter, the noise
//! averages over the vertex's near hits: (cosine, portal) samples (1, 1)
//! 1.218%, (4, 4) 1.221%, (8, 16) 1.221%, (0, 4) 1.243% (the cosine
//! directions find the sky beside the portal). Cost at (1, 1), the
//! default: 604k rays, 70-90 ms for 331k near hits at 1024 rays (2.4M
//! rays, 254 ms at (4, 4)).

use super::{albedo_and_interpolated, hit_albedo, hit_origin, trace_by_vertex};
use super::{Bounce, Cost, Fields, NearTerm, Shape};
use crate::csr::{Csr, RowBuilder};
use crate::trace::ray::{NO_SKIP, Ray};
use crate::links::near::triangle_ranks;
use crate::links::{NearHit, NearHits};
use crate::sampling::stream::{cosine_direction, fold, Stream};
use crate::scene::prep::PreparedScene;
use crate::sky::{portal, Portal};
use crate::trace::{Tracer, RAY_OFFSET};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// How the sky at near hits is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearSkyParams {
    /// Cosine-distributed directions per near hit, at least 1 (the
    /// `near_sky` term switches the part off). Default 1 (module doc: more
    /// read the same).
    pub samples: u32,
    /// Points per near hit and portal, rounded down to a square grid; at least 1. Default 1.
    pub portal_samples: u32,
}

impl NearSkyParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: NearSkyParams = Self { samples: 1, portal_samples: 1 };
}

impl Default for NearSkyParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl NearSkyParams {
    /// Cells a side of a portal's grid.
    pub fn portal_side(&self) -> u32 {
        ((self.portal_samples.min(portal::MAX_SIDE * portal::MAX_SIDE) as f64).sqrt().floor() as u32)
            .min(portal::MAX_SIDE)
    }
}

/// The directions from every vertex's near hits that reached the sky.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NearSky {
    /// True once traced for a sky (with [`Self::portals`]).
    pub traced: bool,
    /// The portals the samples were traced for.
    pub portals: Vec<Portal>,
    /// Per vertex, the unit directions toward the sky that were free, with
    /// their weights: `rho(h)` times the estimator's factor over the link
    /// rays `n` (W/m^2 per W/(m^2 sr), per channel). Empty: none anywhere.
    pub rows: Csr<(Vec3, Vec3)>,
    /// Rays, time and memory of the last trace.
    pub cost: Cost,
}

/// One sample's ray and its weight without the albedo.
struct Candidate {
    ray: Ray,
    weight: f32,
}

impl NearSky {
    /// Traces the samples of every near hit of `near` (link rays shot
    /// `rays_per_vertex` a vertex) toward the sky and through `portals`
    /// with `tracer`.
    pub fn compute(
        scene: &PreparedScene,
        near: &NearHits,
        portals: &[Portal],
        tracer: &dyn Tracer,
        params: &NearSkyParams,
        seed: u64,
        rays_per_vertex: u32,
    ) -> crate::Result<NearSky> {
        let start = Instant::now();
        let n = scene.vertex_count();
        let mut out = NearSky { traced: true, portals: portals.to_vec(), ..Default::default() };
        if near.is_empty() {
            return Ok(out);
        }
        let inv = 1.0 / rays_per_vertex.max(1) as f32;
        let mut rows = RowBuilder::new();
        // Per vertex: per sample, its direction and its weight with the hit's albedo, and its ray.
        let samples = |v: usize, hits: &[NearHit]| -> (Vec<(Vec3, Vec3)>, Vec<Ray>) {
            let ranks = triangle_ranks(hits);
            hits.iter()
                .zip(ranks)
                .flat_map(|(h, rank)| {
                    let rho = hit_albedo(scene, h) * (inv * h.weight);
                    candidates(scene, h, portals, params, seed, v, rank as usize)
                        .into_iter()
                        .map(move |c| ((c.ray.dir, rho * c.weight), c.ray))
                })
                .unzip()
        };
        let rays = trace_by_vertex(near, n, tracer, samples, |_, found: Vec<(Vec3, Vec3)>, visible: &[bool]| {
            rows.extend(found.into_iter().zip(visible).filter(|(_, &free)| free).map(|(s, _)| s));
            rows.end_row();
        })?;
        out.rows = rows.finish();
        out.cost = Cost { rays, ms: start.elapsed().as_secs_f64() * 1e3, bytes: out.rows.bytes() };
        Ok(out)
    }
}

impl NearTerm for NearSky {
    fn name(&self) -> &'static str {
        "sky"
    }

    fn bounce(&self) -> Bounce {
        Bounce::First
    }

    fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// `D_sky` of every vertex (module doc), W/m^2, under the fields' sky
    /// with their `e_sky` the vertices' sky light as the bounces use it;
    /// `None` without a sky, samples or sky light.
    fn correction(&self, f: &Fields) -> Option<Vec<Vec3>> {
        let n = f.scene.vertex_count();
        let sky = f.sky?;
        if self.is_empty() || f.near.rows.offsets.len() != n + 1 || f.e_sky.len() != n {
            return None;
        }
        let radiance = sky.radiance_fn();
        let inv = 1.0 / f.rays_per_vertex.max(1) as f32;
        Some(
            (0..n)
                .into_par_iter()
                .map(|v| {
                    let exact: Vec3 = self.rows.row(v).iter().map(|(d, w)| radiance(*d) * *w).sum();
                    let interpolated: Vec3 =
                        f.near.of(v).iter().map(|h| albedo_and_interpolated(f.scene, h, f.e_sky).1 * h.weight).sum();
                    exact - interpolated * inv
                })
                .collect(),
        )
    }

    fn cost(&self) -> Cost {
        self.cost
    }

    /// CSR rows over the vertices, unit directions, finite non-negative
    /// weights, valid portals.
    fn validate(&self, shape: &Shape) -> Result<(), String> {
        for p in &self.portals {
            p.validate()?;
        }
        self.rows.validate(shape.vertices, |_, (d, w)| {
            if !(d.is_finite() && (d.length() - 1.0).abs() < 1e-3) {
                return Err(format!("direction {d} is not a unit vector"));
            }
            if !(w.is_finite() && w.min_element() >= 0.0) {
                return Err(format!("weight {w}"));
            }
            Ok(())
        })
    }
}

/// The shadow rays of near hit `h` of vertex `v`, the `rank`-th of its
/// hits on that triangle, with their estimator weights (no albedo, no
/// `1/n`). The samples hash from the vertex, the triangle and that rank,
/// not from the hit's place in the vertex's list: where the CPU and GPU
/// tracers give a vertex one near hit more or less (a ray at `t = 0` on a
/// contact line), its hits on other triangles keep their samples. (Not
/// from the barycentrics: the two tracers' differ in the sixth digit, and
/// quantized to 2^-16 they fell on either side of a step often enough that
/// `window`'s `E_i` agreed within 1e-4 at a third of the vertices.)
fn candidates(
    scene: &PreparedScene,
    h: &NearHit,
    portals: &[Portal],
    params: &NearSkyParams,
    seed: u64,
    v: usize,
    rank: usize,
) -> Vec<Candidate> {
    let (origin, normal) = hit_origin(scene, h, RAY_OFFSET);
    let key = Stream::NEAR_SKY.hit_key(seed, v, h.tri, rank);
    let mut out = Vec::new();
    // From t = 0 (with `tmin = eps` rays from the floor's edge left the
    // room through its one-sided walls: `window` at 1024 rays 1.24 / 1.30 /
    // 1.26% -> 1.30 / 1.52 / 1.39% over seeds 1-3).
    let ray = |dir: Vec3| Ray { origin, dir, tmin: 0.0, tmax: f32::INFINITY, skip: NO_SKIP };
    if params.samples > 0 {
        let w = std::f32::consts::PI / params.samples as f32;
        for j in 0..params.samples {
            let Some(dir) = cosine_direction(fold(key, &[0, u64::from(j)]), normal) else { continue };
            // A direction through a portal is the portals' samples'.
            if portal::through_any(portals, origin, dir) {
                continue;
            }
            out.push(Candidate { ray: ray(dir), weight: w });
        }
    }
    let side = params.portal_side();
    let m = side * side;
    for pi in 0..portals.len() {
        for j in 0..m {
            let hash = fold(key, &[1 + pi as u64, u64::from(j)]);
            let Some(s) = portal::sample_jittered(portals, pi, side, j, origin, normal, hash) else { continue };
            out.push(Candidate { ray: ray(s.dir), weight: s.cos_x / s.density / m as f32 });
        }
    }
    out
}
