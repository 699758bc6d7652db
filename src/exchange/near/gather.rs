//! The indirect light at near hits: a final gather from the hit point.
//! The near fields ([`crate::exchange::near::light`], [`crate::exchange::near::emitters`],
//! [`crate::exchange::near::sky`]) make a near hit's first bounce exact; what it
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
//! vertex's replaced by its stand-ins' ([`crate::exchange::bounce::hidden`]), as the bounce
//! kernels do. It is added to the gathered `E_i` after the bounces (it is
//! not carried on through them: a second-order term) and smoothed with it.
//!
//! Stored: where each gather ray landed (triangle and barycentrics to
//! 2^-16, 8 bytes a ray: 28 MB for tearoom's 3.5M at 1024 rays), so a new
//! radiosity (a moved light, a changed sky) needs no ray. Rays start `eps * l` off and
//! into the hit's triangle (l its longest edge), as the sky's near-hit
//! rays. After a deformation only the rays the motion can have changed
//! are traced again ([`NearGather::update_deformed`]: dancer's update at
//! t = 0.25 s traces 522k of its 1.03M, 2026-11-26). Units: irradiance W/m^2, radiosity W/(m^2 sr), lengths metres.
//! Measured: see [`NearGatherParams::rays`]; tearoom's bowls' feet
//! undersides went from 2x the reference (0.28 against 0.135 W/m^2) to
//! within its noise, and the plates of `tests/near_field.rs` from 15-19%
//! low to within 5%.
//!
//! Deviation from the paper: the paper gathers only over vertex links;
//! this is a one-level final gather, as photon mappers and radiosity
//! renderers do at the hit points of their first rays, here only where
//! the links' interpolation is known to fail (near hits).

use super::{correct_by_hits, hit_origin, trace_by_vertex, Bounce, Cost, Fields, NearChange, NearTerm, Shape};
use crate::trace::ray::{NO_SKIP, Ray};
use crate::trace::ray::Hit;
use crate::links::near::triangle_ranks;
use crate::links::{NearHit, NearHits};
use crate::sampling::stream::{cosine_direction, fold, Stream};
use crate::scene::prep::PreparedScene;
use crate::trace::{Tracer, RAY_OFFSET};
use glam::Vec3;
use std::time::Instant;

/// How the final gather at near hits is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearGatherParams {
    /// Rays per near hit, at least 1 (the `near_gather` term switches the part off), default 2. Measured (total relative RMSE against the reference,
    /// auto bounces, seed 1, `near_gather.rays = m`; `cargo test --release --test measured -- --ignored
    /// final_gather_lowers_tearoom_error` checks tearoom at 1024 link rays
    /// against `--off near_gather`, 1.68 -> 1.03% now), off
    /// / 1 / 2 / 4 rays a hit: tearoom 1024 link rays 1.67 / 1.18 / 1.12 /
    /// 1.08%, cornell 1.02 / 1.03 / 0.99 / 0.97%; at 64 link rays cornell
    /// 4.84 / 5.10 / - / 4.85% and tearoom 4.77 / 4.85 / - / 4.62% (one ray a
    /// hit adds more noise than it takes bias when a vertex has a few near
    /// hits), at 256 cornell 2.21 / 2.32 / 2.23 / 2.19%, tearoom 2.34 / 2.20
    /// / - / 2.02%; 2 a hit: cornell 4.90 / 2.23 / 0.99%, tearoom 4.70 /
    /// 2.08 / 1.12% at 64 / 256 / 1024. Cost at 1024 link rays on tearoom:
    /// 1.74M near hits, 3.5M rays at 2 a hit beside the links' 13.3M,
    /// 0.7-1.0 s against the links' 1.7 s in the same runs (arbitrary rays,
    /// then one at a time: 3.6-5.0M rays/s against the links' 7.8-7.9M;
    /// now four in flight, `Bvh::intersect_run`). Four a hit lowers the error at 64
    /// and 256 link rays a little more but costs more than it gains at
    /// equal time (tearoom 64 rays: 5.0x against the path tracer with 4,
    /// 5.5x with 2). Without the stand-ins for
    /// hidden vertices (a prototype) cornell read 1.26-1.31% at 1024 rays:
    /// rays from the floor beside a box meet its bottom row, hidden
    /// vertices whose own irradiance is meaningless; added after the
    /// smoothing instead of with the gathered part, tearoom 64 rays read
    /// 5.3%.
    pub rays: u32,
}

impl NearGatherParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: NearGatherParams = Self { rays: 2 };
}

impl Default for NearGatherParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Where one gather ray landed: a front face's triangle and barycentrics
/// `(u, v)` in units of 1/65535, or [`GatherHit::NONE`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GatherHit {
    /// The triangle hit, or `u32::MAX` for [`GatherHit::NONE`].
    pub tri: u32,
    /// First barycentric coordinate (weight of the triangle's second corner), in units of 1/65535.
    pub u: u16,
    /// Second barycentric coordinate (weight of the triangle's third corner), in units of 1/65535.
    pub v: u16,
}

impl GatherHit {
    /// A ray that left the scene or met a back face: it brings nothing.
    pub const NONE: GatherHit = GatherHit { tri: u32::MAX, u: 0, v: 0 };

    /// The corner weights `(1 - u - v, u, v)`.
    pub fn barycentrics(&self) -> [f32; 3] {
        let (u, v) = (self.u as f32 / 65535.0, self.v as f32 / 65535.0);
        [(1.0 - u - v).max(0.0), u, v]
    }
}

/// Every near hit's gather rays (see the module doc).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NearGather {
    /// Rays a near hit: near hit `k` (in [`NearHits::hits`] order) owns
    /// `hits[k * per_hit..(k + 1) * per_hit]`; 0 when there is nothing.
    pub per_hit: u32,
    /// Every gather ray's landing point, `per_hit` per near hit.
    pub hits: Vec<GatherHit>,
    /// Rays, time and memory of the last trace.
    pub cost: Cost,
}

/// What becomes of one gather ray in a trace ([`NearGather::trace_with`]).
enum Slot {
    /// Its old landing point stands.
    Keep(GatherHit),
    /// Traced (the next answer).
    Trace,
    /// A direction on the horizon: no ray.
    Horizon,
}

impl NearGather {
    /// Traces `params.rays` rays from every near hit of `near` with `tracer`.
    pub fn compute(
        scene: &PreparedScene,
        near: &NearHits,
        tracer: &dyn Tracer,
        params: &NearGatherParams,
        seed: u64,
    ) -> crate::Result<NearGather> {
        Self::trace_with(scene, near, tracer, params, seed, |_, _, _, _| None)
    }

    /// The gather rays after a deformation, from `self` traced over the
    /// near hits `change.before`: the rays of hits whose vertex was redone
    /// or that lie on a moved triangle, of rays that landed on a moved
    /// triangle and of rays whose segment (to where they landed, or the
    /// whole ray where they did not) meets a box of the motion are traced;
    /// the others keep their landing point, since nothing on their segment
    /// moved. Equals a fresh [`NearGather::compute`]. Returns the rays traced.
    pub fn update_deformed(
        &mut self,
        scene: &PreparedScene,
        change: &NearChange,
        tracer: &dyn Tracer,
        params: &NearGatherParams,
        seed: u64,
    ) -> crate::Result<u64> {
        let m = params.rays as usize;
        let comparable =
            self.per_hit == params.rays && change.aligned() && self.hits.len() == change.before.rows.items.len() * m;
        let old = std::mem::take(self);
        *self = if comparable {
            Self::trace_with(scene, change.after, tracer, params, seed, |v, i, h, rays| {
                let k = change.kept_at(v, i, h)?;
                let landed = &old.hits[k * m..(k + 1) * m];
                let unmoved = rays.iter().zip(landed).all(|(r, y)| match r {
                    None => true,
                    Some(r) => !may_land_elsewhere(scene, change, r, y),
                });
                unmoved.then(|| landed.to_vec())
            })?
        } else {
            Self::compute(scene, change.after, tracer, params, seed)?
        };
        Ok(self.cost.rays)
    }

    /// Traces the gather rays of every near hit of `near`, except where
    /// `keep(v, i, hit, rays)` gives the landing points of the `i`-th near
    /// hit of vertex `v` (its rays as [`gather_rays`] makes them).
    fn trace_with(
        scene: &PreparedScene,
        near: &NearHits,
        tracer: &dyn Tracer,
        params: &NearGatherParams,
        seed: u64,
        keep: impl Fn(usize, usize, &NearHit, &[Option<Ray>]) -> Option<Vec<GatherHit>> + Sync,
    ) -> crate::Result<NearGather> {
        let start = Instant::now();
        let n = scene.vertex_count();
        let mut out = NearGather::default();
        if near.is_empty() {
            return Ok(out);
        }
        out.per_hit = params.rays;
        out.hits.reserve(near.rows.items.len() * params.rays as usize);
        // Per ray of the vertex's near hits in order, what becomes of it, and the rays to trace.
        let samples = |v: usize, hits: &[NearHit]| -> (Vec<Slot>, Vec<Ray>) {
            let (mut slots, mut rays) = (Vec::new(), Vec::new());
            let ranks = triangle_ranks(hits);
            for (i, h) in hits.iter().enumerate() {
                let mine = gather_rays(scene, h, params, seed, v, ranks[i] as usize);
                match keep(v, i, h, &mine) {
                    Some(landed) => slots.extend(landed.into_iter().map(Slot::Keep)),
                    None => {
                        slots.extend(mine.iter().map(|r| if r.is_some() { Slot::Trace } else { Slot::Horizon }));
                        rays.extend(mine.into_iter().flatten());
                    }
                }
            }
            (slots, rays)
        };
        let hits = &mut out.hits;
        let rays = trace_by_vertex(near, n, tracer, samples, |_, slots: Vec<Slot>, found: &[Option<Hit>]| {
            let mut found = found.iter();
            hits.extend(slots.into_iter().map(|slot| match slot {
                Slot::Keep(y) => y,
                Slot::Horizon => GatherHit::NONE,
                Slot::Trace => match found.next().expect("one answer per ray") {
                    Some(y) if y.front => GatherHit {
                        tri: y.tri,
                        u: (y.u.clamp(0.0, 1.0) * 65535.0).round() as u16,
                        v: (y.v.clamp(0.0, 1.0) * 65535.0).round() as u16,
                    },
                    _ => GatherHit::NONE,
                },
            }));
        })?;
        out.cost = Cost {
            rays,
            ms: start.elapsed().as_secs_f64() * 1e3,
            bytes: std::mem::size_of_val(out.hits.as_slice()) as u64,
        };
        Ok(out)
    }
}

/// Whether gather ray `r`, which landed at `y` before the motion, can
/// land elsewhere now: `y` is on a moved triangle, or the ray's segment
/// meets a box of the motion. The segment runs to `y`'s point (its
/// barycentrics are rounded to 2^-16, so it is lengthened by the
/// triangle's longest edge over 2^12); a ray that met nothing or a back
/// face (`NONE`, whose distance is not kept) is taken whole.
fn may_land_elsewhere(scene: &PreparedScene, change: &NearChange, r: &Ray, y: &GatherHit) -> bool {
    let tmax = if *y == GatherHit::NONE {
        f32::INFINITY
    } else {
        if change.motion.moved_triangle[y.tri as usize] {
            return true;
        }
        let corners = scene.triangles[y.tri as usize].map(|i| scene.positions[i as usize]);
        let [a, b, c] = y.barycentrics();
        let p = corners[0] * a + corners[1] * b + corners[2] * c;
        let edge = (corners[1] - corners[0])
            .length()
            .max((corners[2] - corners[1]).length())
            .max((corners[0] - corners[2]).length());
        (p - r.origin).length() * (1.0 + 1e-4) + edge / 4096.0
    };
    change.segment_moved(r, tmax)
}

impl NearTerm for NearGather {
    fn name(&self) -> &'static str {
        "gather"
    }

    fn bounce(&self) -> Bounce {
        Bounce::Later
    }

    fn is_empty(&self) -> bool {
        self.per_hit == 0
    }

    /// `D_g` of every vertex (module doc), W/m^2, for the fields' radiosity
    /// `b_later` (W/(m^2 sr)) and gathered irradiance `g_later` (W/m^2)
    /// with hidden vertices' stand-ins applied, over the near hits the rays
    /// were traced from (`None` when they are not those).
    fn correction(&self, f: &Fields) -> Option<Vec<Vec3>> {
        let (scene, near) = (f.scene, f.near);
        let n = scene.vertex_count();
        let m = self.per_hit as usize;
        if self.is_empty() || near.rows.offsets.len() != n + 1 || self.hits.len() != near.rows.items.len() * m {
            return None;
        }
        let (b_h, g_h) = (f.b_later, f.g_later);
        let per_ray = std::f32::consts::PI / m as f32;
        let at = |tri: u32, beta: [f32; 3], x: &[Vec3]| -> Vec3 {
            let t = scene.triangles[tri as usize];
            (0..3).map(|c| x[t[c] as usize] * beta[c]).sum()
        };
        // What hit k's gather rays met, radiosity read at their hits.
        let gathered = |k: usize| -> Vec3 {
            self.hits[k * m..(k + 1) * m]
                .iter()
                .filter(|y| y.tri != GatherHit::NONE.tri)
                .map(|y| at(y.tri, y.barycentrics(), b_h))
                .sum::<Vec3>()
                * per_ray
        };
        Some(correct_by_hits(f, g_h, gathered))
    }

    fn cost(&self) -> Cost {
        self.cost
    }

    /// `per_hit` slots a near hit, triangles in range, barycentrics inside
    /// the triangle.
    fn validate(&self, shape: &Shape) -> Result<(), String> {
        let (near_hits, triangles) = (shape.near_hits, shape.triangles);
        if self.is_empty() {
            return if self.hits.is_empty() { Ok(()) } else { Err("gather hits without rays a hit".into()) };
        }
        if self.hits.len() != near_hits * self.per_hit as usize {
            return Err(format!("{} gather hits for {near_hits} near hits x {}", self.hits.len(), self.per_hit));
        }
        if let Some(y) = self
            .hits
            .iter()
            .find(|y| *y != &GatherHit::NONE && (y.tri as usize >= triangles || y.u as u32 + y.v as u32 > 65536))
        {
            return Err(format!("gather hit {y:?} of {triangles} triangles"));
        }
        Ok(())
    }
}

/// The `params.rays` gather rays of near hit `h` of vertex `v` (the
/// `rank`-th of its hits on that triangle: the directions hash from the
/// vertex, the triangle and the rank, as [`crate::exchange::near::sky`]'s); `None`
/// for a direction on the horizon.
fn gather_rays(
    scene: &PreparedScene,
    h: &NearHit,
    params: &NearGatherParams,
    seed: u64,
    v: usize,
    rank: usize,
) -> Vec<Option<Ray>> {
    let (origin, normal) = hit_origin(scene, h, RAY_OFFSET);
    let key = Stream::NEAR_GATHER.hit_key(seed, v, h.tri, rank);
    (0..params.rays)
        .map(|j| {
            cosine_direction(fold(key, &[u64::from(j)]), normal).map(|dir| Ray {
                origin,
                dir,
                tmin: 0.0,
                tmax: f32::INFINITY,
                skip: NO_SKIP,
            })
        })
        .collect()
}
