//! Exact emitter light at near hits: the emitters' counterpart of
//! [`crate::exchange::near::light`]. A link ray of vertex `x` that meets a triangle
//! close by ([`crate::links::near`]) brings, in its first bounce, the
//! emitters' direct light interpolated from the triangle's corners,
//! `sum_c beta_c rho_c E_em(c)`; where an object stands close to a large
//! triangle the corners lie out in the light while the hit point is in the
//! object's shadow, or the other way round (`window`: the wall behind the
//! cabinet's top edge, lit by the lamp above the gap and dark inside it,
//! within one 25 cm triangle). Here the hit point's own emitter light is
//! estimated and replaces the interpolated one:
//!
//! ```text
//! D_em(x) = 1/n * sum over near hits k of [ rho(h_k) E_em(h_k) - sum_c beta_c rho_c E_em(c) ]
//! E_em(h) = sum_g M_g f_g(h),  f_g(h) = 1/m * sum over rays j to g's triangles of V_j f_j / p_j
//! ```
//!
//! A budget of `m` shadow rays a hit ([`NearEmitterParams::samples`]) is
//! spread over the emissive triangles by a many-light choice in two
//! levels: the triangles lie in spatial clusters of 32, a cluster is drawn
//! by a bound on its unoccluded light at the hit (`A / max(d^2, r^2)`:
//! area over squared distance, capped at the cluster's radius; 0 wholly
//! below the hit's horizon), systematically over the `m` rays, then a
//! triangle of it by the same bound (0 where the hit lies behind its
//! plane), with probability `p_j`; a scene's cost does not grow with its
//! count of emitters. `f_j` is what the ray brings unoccluded: close to
//! its triangle (within 4 radii), the triangle's exact factor `F_t`
//! (Lambert's formula, as the emitter links') with the ray to a uniform point of
//! the part above the horizon; further away, `A_t cos_h cos_e / (pi r^2)`
//! at a uniform point (`r = |y - h|`, m; `cos_e` at the emitter's front
//! only). `V_j` is a shadow ray from the hit point.
//!
//! Deviation (bounded, not unbiased, close by): the one point's visibility
//! stands for the whole triangle's, as in the emitter links' ratio. The
//! estimate it replaced drew points uniformly on each group's area with
//! `cos cos / r^2`, unbiased but of unbounded variance where a hit lies
//! beside an emitter: on Šibenik (the rose window's tracery beside its
//! panes) single hits read hundreds of times their neighbours' light and
//! showed as pink splotches (`docs/REAL_SCENES.md`). Now each ray brings at
//! most `F_t / (m p_j)`, which the bound keeps near the hit's total.
//!
//! Per hit this is an estimate whose noise averages over the vertex's
//! near hits. `D_em = sum_g M_g C_xg` is kept as one coefficient per
//! vertex and group (RGB: it holds the albedos), so an emission edit
//! traces nothing; it is added to `E_i` and to the bounces' source like
//! the point lights' near-field correction. Measured on `window` and
//! Šibenik: see [`NearEmitterParams::samples`].

use super::{hit_albedo, hit_frame, trace_by_vertex, Bounce, Cost, Fields, NearTerm, Shape};
use crate::csr::{Csr, RowBuilder};
use crate::exchange::sources::emitter_geometry::{form_factor, polygon_point, Emitter};
use crate::exchange::sources::emitter_links::{emitters_of, EmitterLinks};
use crate::trace::ray::{NO_SKIP, Ray};
use crate::links::near::triangle_ranks;
use crate::links::{NearHit, NearHits};
use crate::sampling::stream::{fold, splitmix64, unit, Stream};
use crate::scene::prep::PreparedScene;
use crate::trace::{Tracer, RAY_OFFSET};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// How the emitters' light at near hits is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NearEmitterParams {
    /// Shadow rays per near hit, spread over the emissive triangles by
    /// the many-light choice (module doc); at least 1 (the `near_emitters` term switches the part off). Measured (Xeon, 2
    /// cores) against the estimate this one replaced (uniform area
    /// points, 4 a hit). `window` (`linkgi error window`, total relative
    /// RMSE against 16384 paths, auto bounces, 64 / 256 / 1024 rays): 4.47 /
    /// 3.61 / 3.30% before; 4.48 / 3.63 / 3.32% with 4 rays; 4.54 / 3.65 /
    /// 3.32% with 2. Šibenik at 320x240 against a 4096-path reference (mean
    /// luminance ratio, 8x8-block error): 1.009, 6.55% before (splotches);
    /// 0.976, 5.98% with 4 rays (24.3 s); 0.977, 5.98% with 2 (21.1 s);
    /// the term off, 0.971, 6.17%. Two rays a hit: where both are unoccluded
    /// each brings light, where the old points often fell below the
    /// horizon and were dropped.
    pub samples: u32,
}

impl NearEmitterParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: NearEmitterParams = Self { samples: 2 };
}

impl Default for NearEmitterParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Per vertex and emitter group the coefficient `C_xg` of `D_em(x) = sum_g M_g C_xg`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NearEmitters {
    /// Per vertex, `(group, C_xg)` with groups ascending; `C_xg` unitless
    /// per channel (W/m^2 of irradiance per W/m^2 of exitance), of either
    /// sign (empty: none anywhere).
    pub rows: Csr<(u32, Vec3)>,
    /// Rays, time and memory of the last trace.
    pub cost: Cost,
}

/// One emissive triangle as the near hits sample it.
struct Tri {
    emitter: Emitter,
    /// Area, m^2.
    area: f32,
    /// Centroid and the radius of a sphere about it holding the corners, m.
    centre: Vec3,
    radius: f32,
}

/// At most [`CLUSTER`] emissive triangles close together (`tris[first..end]`),
/// with their total area (m^2) and a sphere holding them (m).
struct Cluster {
    first: u32,
    end: u32,
    area: f32,
    centre: Vec3,
    radius: f32,
}

/// Emissive triangles per cluster.
const CLUSTER: usize = 32;

/// The emitters in spatial clusters: the two levels of the many-light choice.
struct Lights {
    tris: Vec<Tri>,
    clusters: Vec<Cluster>,
}

impl Lights {
    /// Clusters of `emitters` by recursive median splits along the longest
    /// axis of their centroids' box (deterministic: ties keep input order).
    fn new(emitters: &[Emitter]) -> Lights {
        let mut tris: Vec<Tri> = emitters
            .iter()
            .map(|e| {
                let c = e.corners;
                let centre = (c[0] + c[1] + c[2]) / 3.0;
                let radius = c.iter().map(|p| p.distance(centre)).fold(0.0, f32::max);
                let area = (c[1] - c[0]).cross(c[2] - c[0]).length() / 2.0;
                Tri { emitter: *e, area, centre, radius }
            })
            .filter(|t| t.area > 0.0 && t.area.is_finite())
            .collect();
        let mut clusters = Vec::new();
        let mut stack = vec![(0usize, tris.len())];
        while let Some((lo, hi)) = stack.pop() {
            if hi - lo <= CLUSTER {
                if hi > lo {
                    clusters.push(Cluster::of(&tris, lo, hi));
                }
                continue;
            }
            let span = &mut tris[lo..hi];
            let (min, max) =
                span.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), t| (a.min(t.centre), b.max(t.centre)));
            let axis = (max - min).max_position();
            let mid = span.len() / 2;
            span.sort_by(|a, b| a.centre[axis].total_cmp(&b.centre[axis]));
            stack.push((lo + mid, hi));
            stack.push((lo, lo + mid));
        }
        Lights { tris, clusters }
    }
}

impl Cluster {
    fn of(tris: &[Tri], lo: usize, hi: usize) -> Cluster {
        let span = &tris[lo..hi];
        let (min, max) = span.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), t| {
            (a.min(t.centre - Vec3::splat(t.radius)), b.max(t.centre + Vec3::splat(t.radius)))
        });
        let centre = (min + max) * 0.5;
        let radius = span.iter().map(|t| t.centre.distance(centre) + t.radius).fold(0.0, f32::max);
        let area = span.iter().map(|t| t.area).sum();
        Cluster { first: lo as u32, end: hi as u32, area, centre, radius }
    }
}

/// The importance bound of emitters of total area `area` (m^2) within a
/// sphere (`centre`, `radius`) at a point `p` with normal `n`: `area /
/// max(d^2, radius^2)` (`d` the distance to the centre), an upper estimate
/// of their unoccluded factor up to the cosines and `pi`; 0 where the
/// sphere lies wholly below `p`'s horizon, where no point of it can light `p`.
fn bound(area: f32, centre: Vec3, radius: f32, p: Vec3, n: Vec3) -> f32 {
    let to = centre - p;
    if n.dot(to) < -radius * (1.0 + 1e-4) - 1e-6 {
        return 0.0;
    }
    let v = area / to.length_squared().max(radius * radius).max(f32::MIN_POSITIVE);
    if v.is_finite() {
        v
    } else {
        f32::MAX
    }
}

/// Index `i` with `cdf[i - 1] <= u * total < cdf[i]` of a running sum `cdf`
/// (the last positive entry for `u` rounding past the end).
fn pick(cdf: &[f32], u: f32) -> usize {
    let total = *cdf.last().expect("non-empty");
    let i = cdf.partition_point(|&c| c <= u * total).min(cdf.len() - 1);
    // Skip a zero-width entry the rounding may land on.
    (0..=i).rev().find(|&k| cdf[k] > if k == 0 { 0.0 } else { cdf[k - 1] }).unwrap_or(i)
}

/// Per shadow ray of one near hit, its group and what it adds when it is
/// unoccluded: `f / (m p_t)`.
type HitValues = Vec<(u32, f32)>;

/// Per-vertex buffers of [`point_samples`]: the running sums of the
/// clusters' bounds and of one cluster's triangles' bounds.
#[derive(Default)]
struct Scratch {
    cdf: Vec<f32>,
    inner: Vec<f32>,
}

impl NearEmitters {
    /// The coefficients of every vertex with near hits in `near`, with the
    /// emitter groups of `links` (none when it has none), traced with `tracer`.
    pub fn compute(
        scene: &PreparedScene,
        near: &NearHits,
        links: &EmitterLinks,
        tracer: &dyn Tracer,
        params: &NearEmitterParams,
        seed: u64,
        rays_per_vertex: u32,
    ) -> crate::Result<NearEmitters> {
        let start = Instant::now();
        let n = scene.vertex_count();
        if near.is_empty() || !links.is_active() {
            return Ok(NearEmitters::default());
        }
        let (tris, _) = emitters_of(scene);
        let lights = Lights::new(&tris);
        let inv = 1.0 / rays_per_vertex.max(1) as f32;
        let mut rows = RowBuilder::new();
        let samples = |v: usize, hits: &[NearHit]| {
            let ranks = triangle_ranks(hits);
            let (mut scratch, mut rays) = (Scratch::default(), Vec::new());
            let per_hit: Vec<HitValues> = (0..hits.len())
                .map(|i| {
                    let (p, normal, l) = hit_frame(scene, &hits[i]);
                    let key = Stream::NEAR_EMITTERS.hit_key(seed, v, hits[i].tri, ranks[i] as usize);
                    let m = params.samples;
                    point_samples(&lights, p, normal, RAY_OFFSET * l, m, key, &mut scratch, &mut rays)
                })
                .collect();
            (per_hit, rays)
        };
        let rays = trace_by_vertex(near, n, tracer, samples, |v, per_hit: Vec<HitValues>, visible: &[bool]| {
            let mut row: Vec<(u32, Vec3)> = Vec::new();
            let mut add = |g: u32, c: Vec3| match row.iter_mut().find(|e| e.0 == g) {
                Some(e) => e.1 += c,
                None => row.push((g, c)),
            };
            let mut at = 0usize;
            for (h, s) in near.of(v).iter().zip(&per_hit) {
                let tri = scene.triangles[h.tri as usize];
                let beta = [1.0 - h.u - h.v, h.u, h.v];
                let rho = hit_albedo(scene, h) * h.weight;
                for (&(g, value), &seen) in s.iter().zip(&visible[at..at + s.len()]) {
                    if seen {
                        add(g, rho * (value * inv));
                    }
                }
                at += s.len();
                // Minus what the corners bring (their emitter links' factors).
                for c in 0..3 {
                    let cv = tri[c] as usize;
                    for (g, f) in links.of(cv) {
                        add(g, -scene.albedo[cv] * (beta[c] * f * inv * h.weight));
                    }
                }
            }
            row.sort_by_key(|e| e.0);
            rows.extend(row);
            rows.end_row();
        })?;
        let rows = rows.finish();
        let bytes = rows.bytes();
        Ok(NearEmitters { rows, cost: Cost { rays, ms: start.elapsed().as_secs_f64() * 1e3, bytes } })
    }
}

impl NearTerm for NearEmitters {
    fn name(&self) -> &'static str {
        "emitters"
    }

    fn bounce(&self) -> Bounce {
        Bounce::First
    }

    /// True when no vertex has a coefficient.
    fn is_empty(&self) -> bool {
        self.rows.items.is_empty()
    }

    /// `D_em` of every vertex, W/m^2, with the fields' current exitance per
    /// vertex and each group's vertex ([`EmitterLinks::group_vertex`]).
    fn correction(&self, f: &Fields) -> Option<Vec<Vec3>> {
        if self.is_empty() {
            return None;
        }
        let m: Vec<Vec3> = f.group_vertex.iter().map(|&v| f.emission[v as usize]).collect();
        Some(
            (0..f.scene.vertex_count())
                .into_par_iter()
                .map(|v| self.rows.row(v).iter().map(|&(g, c)| m[g as usize] * c).sum())
                .collect(),
        )
    }

    fn cost(&self) -> Cost {
        self.cost
    }

    /// CSR rows over the vertices, groups in range and ascending per
    /// vertex, finite coefficients.
    fn validate(&self, shape: &Shape) -> Result<(), String> {
        self.rows.validate(shape.vertices, |_, &(g, c)| {
            if g as usize >= shape.groups || !c.is_finite() {
                return Err(format!("group {g} of {}, coefficient {c}", shape.groups));
            }
            Ok(())
        })?;
        for v in 0..self.rows.rows() {
            if self.rows.row(v).windows(2).any(|w| w[0].0 >= w[1].0) {
                return Err(format!("vertex {v}: groups out of order"));
            }
        }
        Ok(())
    }
}

/// The shadow rays of a near hit at `p` with unit normal `normal`,
/// appended to `rays`, and per ray its group and what it adds when
/// unoccluded. The draws hash from `key` (the hit's: its vertex, triangle
/// and rank, as [`crate::exchange::near::sky`]'s, so a near hit more or
/// less elsewhere, where the CPU and GPU tracers differ, keeps this hit's
/// draws). A budget of `m` rays, each to a triangle `t` drawn in two
/// levels ([`bound`]: a cluster by systematic sampling over the rays, then
/// a triangle of it) with probability `p_t`; an unoccluded ray adds `f /
/// (m p_t)` to `t`'s group, `f` and the ray's end point as
/// [`triangle_sample`] gives them. The rays start `eps` (m) off the
/// surface (see [`crate::exchange::near::hit_origin`] for why not also
/// into the triangle).
#[allow(clippy::too_many_arguments)]
fn point_samples(
    lights: &Lights,
    p: Vec3,
    normal: Vec3,
    eps: f32,
    m: u32,
    key: u64,
    scratch: &mut Scratch,
    rays: &mut Vec<Ray>,
) -> HitValues {
    let origin = p + normal * eps;
    let mut out = HitValues::new();
    let Scratch { cdf, inner } = scratch;
    cdf.clear();
    let mut sum = 0f32;
    for c in &lights.clusters {
        sum += bound(c.area, c.centre, c.radius, p, normal);
        cdf.push(sum);
    }
    if m == 0 || !(sum > 0.0 && sum.is_finite()) {
        return out;
    }
    let xi = unit(fold(key, &[0]));
    let width = |cdf: &[f32], i: usize| cdf[i] - if i == 0 { 0.0 } else { cdf[i - 1] };
    let mut inner_of = usize::MAX;
    for j in 0..m {
        // The `m` cluster draws stratify [0, 1) (systematic sampling), so
        // they come in cluster order and a cluster's triangle bounds are
        // summed once a hit.
        let ci = pick(cdf, ((j as f32 + xi) / m as f32).min(1.0 - f32::EPSILON));
        let c = &lights.clusters[ci];
        let tris = &lights.tris[c.first as usize..c.end as usize];
        if inner_of != ci {
            inner_of = ci;
            inner.clear();
            let mut isum = 0f32;
            for t in tris {
                // Emitters light their front only: none from behind its plane.
                isum += if t.emitter.faces(p) { bound(t.area, t.centre, t.radius, p, normal) } else { 0.0 };
                inner.push(isum);
            }
        }
        let isum = *inner.last().expect("a cluster has triangles");
        if !(isum > 0.0 && isum.is_finite()) {
            continue;
        }
        let hash = fold(key, &[1 + u64::from(j)]);
        let ti = pick(inner, unit(hash));
        let p_t = (width(cdf, ci) / sum) as f64 * (width(inner, ti) / isum) as f64;
        let t = &tris[ti];
        let h2 = splitmix64(hash);
        let u = Vec2::new(unit(h2), unit(splitmix64(h2)));
        let Some((y, f)) = triangle_sample(t, p, normal, u) else { continue };
        let value = (f / (m as f64 * p_t)) as f32;
        if !(value > 0.0 && value.is_finite()) {
            continue;
        }
        let d = y - origin;
        let dist = d.length();
        let dir = d / dist.max(f32::MIN_POSITIVE);
        let ray = Ray::shadow_checked(origin, dir, dist, eps, 0.0, NO_SKIP);
        rays.push(ray.unwrap_or_else(|| Ray::touching(origin, normal, NO_SKIP)));
        out.push((t.emitter.group, value));
    }
    out
}

/// A hit at `p` (unit normal `n`) closer to a triangle than [`NEAR`]
/// times its radius takes the triangle's exact factor.
const NEAR: f32 = 4.0;

/// A point `y` of triangle `t` for `u` in `[0, 1)^2` and what a ray to it
/// brings when unoccluded, `f` (unitless; `None`: nothing). Close to the
/// hit ([`NEAR`]), `f = F_t` exact ([`form_factor`]) and `y` is uniform on
/// the part above the horizon: bounded however close the hit lies (the
/// visibility of one point stands for the triangle's, as the emitter
/// links' ratio does). Further away, `y` is uniform on `t` and `f = A_t
/// cos_h cos_e / (pi r^2)`: unbiased, and bounded there (`r > (NEAR - 1)
/// radius`) without the arc tangents of the exact factor.
fn triangle_sample(t: &Tri, p: Vec3, n: Vec3, u: Vec2) -> Option<(Vec3, f64)> {
    if p.distance_squared(t.centre) < (NEAR * t.radius).powi(2) {
        let (f, poly, corners) = form_factor(p, n, &t.emitter.corners);
        if !(f > 0.0) || corners < 3 {
            return None;
        }
        return Some(((p.as_dvec3() + polygon_point(&poly[..corners], u)).as_vec3(), f));
    }
    let c = t.emitter.corners;
    let (mut a, mut b) = (u.x, u.y);
    if a + b > 1.0 {
        (a, b) = (1.0 - a, 1.0 - b);
    }
    let y = c[0] + (c[1] - c[0]) * a + (c[2] - c[0]) * b;
    let en = (c[1] - c[0]).cross(c[2] - c[0]).normalize_or_zero();
    let d = y - p;
    let r2 = d.length_squared();
    let f = (n.dot(d).max(0.0) * (-en.dot(d)).max(0.0) / (r2 * r2)) as f64 * t.area as f64 / std::f64::consts::PI;
    (f > 0.0 && f.is_finite()).then_some((y, f))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A window of `k x k` square panes (two triangles each, side `s`, m)
    /// in the plane z = 0 facing +z, group 0.
    fn panes(k: usize, s: f32) -> Vec<Emitter> {
        let mut out = Vec::new();
        for i in 0..k {
            for j in 0..k {
                let o = Vec3::new(i as f32 * s * 1.2, j as f32 * s * 1.2, 0.0);
                let [a, b, c, d] = [o, o + Vec3::X * s, o + Vec3::new(s, s, 0.0), o + Vec3::Y * s];
                for corners in [[a, b, c], [a, c, d]] {
                    out.push(Emitter::new(corners, 0, out.len() as u32));
                }
            }
        }
        out
    }

    /// Mean and largest total a hit's rays bring unoccluded over `n` keys.
    fn estimate(lights: &Lights, p: Vec3, normal: Vec3, n: u64) -> (f64, f64) {
        let (mut sum, mut max) = (0f64, 0f64);
        for key in 0..n {
            let (mut scratch, mut rays) = (Scratch::default(), Vec::new());
            let s = point_samples(lights, p, normal, 1e-5, 2, splitmix64(key), &mut scratch, &mut rays);
            assert_eq!(rays.len(), s.len());
            let total: f64 = s.iter().map(|&(_, v)| v as f64).sum();
            sum += total;
            max = max.max(total);
        }
        (sum / n as f64, max)
    }

    /// The unoccluded estimate averages to the exact factor summed over the
    /// panes, at points far away, near and right beside a pane, and no
    /// single hit reads many times the mean (the old uniform-area estimate
    /// read hundreds of times it beside a pane).
    #[test]
    fn bounded_and_unbiased_unoccluded() {
        let emitters = panes(8, 0.1);
        let lights = Lights::new(&emitters);
        assert_eq!(lights.tris.len(), emitters.len());
        assert!(lights.clusters.len() >= 4);
        let cases = [
            // far above the window, looking down at it
            (Vec3::new(0.5, 0.5, 3.0), Vec3::NEG_Z),
            // a wall at a slant, near
            (Vec3::new(-0.2, 0.4, 0.3), Vec3::new(1.0, 0.0, -1.0).normalize()),
            // tracery between two panes, 1 mm above the plane, facing across
            (Vec3::new(0.11, 0.05, 1e-3), Vec3::X),
        ];
        for (p, n) in cases {
            let exact: f64 = emitters
                .iter()
                .filter(|e| {
                    (e.corners[1] - e.corners[0]).cross(e.corners[2] - e.corners[0]).dot(p - e.corners[0]) > 0.0
                })
                .map(|e| form_factor(p, n, &e.corners).0)
                .sum();
            let (mean, max) = estimate(&lights, p, n, 20_000);
            assert!(exact > 1e-4, "{p}: exact {exact}");
            assert!((mean / exact - 1.0).abs() < 0.03, "{p}: mean {mean} against exact {exact}");
            assert!(max < 12.0 * exact, "{p}: a hit read {max}, {}x the exact {exact}", max / exact);
        }
    }

    /// Behind the window (its back faces the point) and below the point's
    /// horizon nothing is drawn.
    #[test]
    fn nothing_from_behind_or_below() {
        let lights = Lights::new(&panes(4, 0.1));
        let (mean, _) = estimate(&lights, Vec3::new(0.2, 0.2, -1.0), Vec3::Z, 200);
        assert_eq!(mean, 0.0);
        let (mean, _) = estimate(&lights, Vec3::new(0.2, 0.2, 1.0), Vec3::Z, 200);
        assert_eq!(mean, 0.0);
    }
}
