//! Exact direct light at near hits: the first bounce of the link rays that
//! meet a triangle close by ([`crate::links::near`]) uses the direct
//! irradiance at the hit point itself, traced, instead of the one the
//! links interpolate from the triangle's corners.
//!
//! A link ray `k` of vertex `x` brings `pi/n * L(h_k)` with the radiance at
//! its hit `h_k` interpolated from the corners `c` (barycentrics `beta_c`):
//! in the first bounce `L = sum_c beta_c rho_c / pi * E_src(c)`. For near
//! hits the per-vertex correction
//!
//! ```text
//! D(x) = 1/n * sum over near hits k of [ rho(h_k) E_d(h_k) - sum_c beta_c rho_c E_src(c) ]
//! E_d(h) = sum_l I_l G_l(h) V_l(h)      (rho(h) = sum_c beta_c rho_c)
//! ```
//!
//! replaces the interpolated direct light of those rays by the exact one.
//! `E_src` is the lights' bounce source ([`super::LightLinks::bounce_source`]);
//! the sky's and the emitters' light at the hits have their own
//! corrections ([`super::near_sky`], [`super::near_emitters`]). `G_l V_l` is
//! stored per light and near hit (a column, like the light links'), so a
//! new intensity traces nothing and a moved light traces only its column.
//!
//! `D` is first-bounce irradiance at `x` (W/m^2, negative where the links
//! brought light that is not there): it is added to `E_i` and, like the
//! emitters' direct light, to the source of the bounces, so its reflections
//! travel on through the links. Measured against the reference
//! (`examples/near_field_probe.rs`, auto bounces, total relative RMSE,
//! noise removed): tearoom (16384 paths) 5.5/3.5/3.1% at 64/256/1024 rays
//! without, 5.0/2.6/2.0% with; cornell (65536 paths) 4.7/2.4/1.07% without,
//! 4.7/2.3/0.94% with.
//!
//! Hit points: `h = sum_c beta_c p_c` on the flat triangle, normal its
//! geometric normal (the side the ray came from: near hits are front
//! hits); shadow rays start `eps * l` off the surface (l: the triangle's
//! longest edge) and stop as short of a point light, as the light links do.

use super::light_links::{geometry, same_column, toward, LightLinkParams};
use crate::kdtree::traverse::{Ray, NO_SKIP};
use crate::links::{NearHit, NearHits};
use crate::scene::motion::Motion;
use crate::scene::{prep::PreparedScene, Light};
use crate::trace::Tracer;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// `G_l V_l` at every near hit for every light.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NearLight {
    /// `columns[l][k]`: 1/m^2 for point lights, unitless for directional.
    pub columns: Vec<Vec<f32>>,
    /// The lights the columns were traced for (positions and directions matter).
    pub lights: Vec<Light>,
    /// Shadow rays of the last computation or update.
    pub shadow_rays: u64,
    pub ms: f64,
}

/// Hits per batch of shadow rays (bounds memory).
const CHUNK_HITS: usize = 1 << 16;

impl NearLight {
    /// The columns of every light of `scene` at `near`'s hits.
    pub fn compute(
        scene: &PreparedScene,
        near: &NearHits,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
    ) -> crate::Result<NearLight> {
        let mut out = NearLight::default();
        out.update(scene, near, tracer, params)?;
        Ok(out)
    }

    /// Brings the columns up to date with `scene.lights`: a light at the
    /// position (or direction) of a traced column keeps it, others are traced.
    pub fn update(
        &mut self,
        scene: &PreparedScene,
        near: &NearHits,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
    ) -> crate::Result<()> {
        let start = Instant::now();
        let mut rays = 0u64;
        let mut old_columns = std::mem::take(&mut self.columns);
        let old_lights = std::mem::take(&mut self.lights);
        for light in &scene.lights {
            let kept = old_lights.iter().position(|o| same_column(o, light));
            let column = match kept {
                Some(i) if old_columns[i].len() == near.hits.len() => std::mem::take(&mut old_columns[i]),
                _ => {
                    let (c, r) = column(scene, near, light, tracer, params)?;
                    rays += r;
                    c
                }
            };
            self.columns.push(column);
            self.lights.push(*light);
        }
        self.shadow_rays = rays;
        self.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(())
    }

    /// True if every light of `lights` has its column.
    pub fn covers(&self, lights: &[Light]) -> bool {
        lights.len() == self.lights.len() && lights.iter().zip(&self.lights).all(|(a, b)| same_column(a, b))
    }

    /// The correction `D` of the module doc at every vertex, W/m^2, for
    /// `lights` (whose columns must be traced: [`Self::covers`]) and the
    /// lights' bounce source `e_src`, from near hits of rays shot
    /// `rays_per_vertex` a vertex. Zero without near hits, and zero while
    /// some light's column is stale (a light preview): then the links'
    /// interpolated first bounce stands.
    pub fn correction(
        &self,
        scene: &PreparedScene,
        near: &NearHits,
        lights: &[Light],
        e_src: &[Vec3],
        rays_per_vertex: u32,
    ) -> Vec<Vec3> {
        let n = scene.vertex_count();
        if near.is_empty() || !self.covers(lights) {
            return vec![Vec3::ZERO; n];
        }
        let powers: Vec<Vec3> = lights.iter().map(Light::power).collect();
        let inv = 1.0 / rays_per_vertex.max(1) as f32;
        (0..n)
            .into_par_iter()
            .map(|v| {
                let first = near.offsets[v] as usize;
                let mut d = Vec3::ZERO;
                for (i, h) in near.of(v).iter().enumerate() {
                    let (rho, interpolated) = albedo_and_interpolated(scene, h, e_src);
                    let e_d: Vec3 = powers.iter().zip(&self.columns).map(|(p, col)| *p * col[first + i]).sum();
                    d += rho * e_d - interpolated;
                }
                d * inv
            })
            .collect()
    }
}

/// Light `light`'s column at every near hit, and the shadow rays it took.
fn column(
    scene: &PreparedScene,
    near: &NearHits,
    light: &Light,
    tracer: &dyn Tracer,
    params: &LightLinkParams,
) -> crate::Result<(Vec<f32>, u64)> {
    column_at(scene, &near.hits, light, tracer, params)
}

/// Near hit `h`'s point on its flat triangle, the triangle's unit
/// geometric normal and its longest edge (m, at least `f32::MIN_POSITIVE`):
/// where shadow rays from the hit start ([`super::near_emitters`] too).
pub(crate) fn hit_frame(scene: &PreparedScene, h: &NearHit) -> (Vec3, Vec3, f32) {
    let [a, b, c] = scene.triangles[h.tri as usize].map(|i| scene.positions[i as usize]);
    let p = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
    let normal = (b - a).cross(c - a).normalize_or_zero();
    let l = (b - a).length().max((c - b).length()).max((a - c).length()).max(f32::MIN_POSITIVE);
    (p, normal, l)
}

/// The albedo at near hit `h` (`sum_c beta_c rho_c`, interpolated from its
/// triangle's corners).
pub(crate) fn hit_albedo(scene: &PreparedScene, h: &NearHit) -> Vec3 {
    albedo_and_interpolated(scene, h, &[]).0
}

/// The albedo at near hit `h` and what its corners interpolate of the
/// per-vertex irradiance `x` reflected, `sum_c beta_c rho_c x(c)` (W/m^2;
/// `x` empty: zero): what a link brought of `x`'s reflection at the hit,
/// which the near-hit corrections replace.
pub(crate) fn albedo_and_interpolated(scene: &PreparedScene, h: &NearHit, x: &[Vec3]) -> (Vec3, Vec3) {
    let tri = scene.triangles[h.tri as usize];
    let beta = [1.0 - h.u - h.v, h.u, h.v];
    let (mut rho, mut interpolated) = (Vec3::ZERO, Vec3::ZERO);
    for c in 0..3 {
        let a = scene.albedo[tri[c] as usize] * beta[c];
        rho += a;
        if let Some(xc) = x.get(tri[c] as usize) {
            interpolated += a * *xc;
        }
    }
    (rho, interpolated)
}

/// Where rays from near hit `h` start, and its triangle's unit normal:
/// `eps` times the triangle's longest edge off the surface and as far into
/// the triangle (toward its centroid). A hit on the edge where the floor
/// meets a wall would otherwise start on the wall's plane, where the CPU
/// and GPU triangle tests answer a ray into the wall either way, and a
/// one-sided wall is all that keeps such a ray in the room
/// ([`super::near_sky`], [`super::near_gather`]). The lights' and emitters'
/// shadow rays start off the surface only: the step into the triangle,
/// `eps` times its longest edge, moves where visibility is taken in a
/// contact gap (the plate 5 mm above a floor of two 2 m triangles, in
/// `tests/near_field.rs`: its underside under a point light read 0.472
/// against the reference's 0.440 with the step, 0.463 without; under a
/// glowing panel 0.147 against 0.143, 0.144 without).
pub(crate) fn hit_origin(scene: &PreparedScene, h: &NearHit, eps: f32) -> (Vec3, Vec3) {
    let (p, normal, l) = hit_frame(scene, h);
    let centroid = scene.triangles[h.tri as usize].map(|i| scene.positions[i as usize]).iter().sum::<Vec3>() / 3.0;
    (p + (normal + (centroid - p).normalize_or_zero()) * (eps * l), normal)
}

/// The rank of near hit `i` of `hits` (one vertex's) among those on its
/// triangle: with the vertex and the triangle, what the near hits' samples
/// hash from, so a vertex's hits on other triangles keep their samples
/// where the CPU and GPU tracers give it one near hit more or less.
pub(crate) fn rank_on_triangle(hits: &[NearHit], i: usize) -> usize {
    hits[..i].iter().filter(|o| o.tri == hits[i].tri).count()
}

/// The geometry term of `light` at near hit `h` and its shadow ray (none
/// where `G = 0` or where the light sits on the surface).
fn shadow_ray(scene: &PreparedScene, h: &NearHit, light: &Light, params: &LightLinkParams) -> (f32, Option<Ray>) {
    let (p, normal, l) = hit_frame(scene, h);
    let g = geometry(light, p, normal, (params.min_distance * l).max(f32::MIN_POSITIVE.sqrt()));
    if !(g > 0.0) {
        return (0.0, None);
    }
    let eps = params.eps * l;
    let o = p + normal * eps;
    let (dir, dist) = toward(light, o);
    if dist <= 2.0 * eps || !dir.is_finite() {
        return (g, None); // the light sits on the surface here: nothing in between
    }
    (g, Some(Ray { origin: o, dir, tmin: 0.0, tmax: dist - eps, skip: NO_SKIP }))
}

/// `G V` of `light` at `hits`, and the shadow rays it took.
fn column_at(
    scene: &PreparedScene,
    hits: &[NearHit],
    light: &Light,
    tracer: &dyn Tracer,
    params: &LightLinkParams,
) -> crate::Result<(Vec<f32>, u64)> {
    let mut out = Vec::with_capacity(hits.len());
    let mut traced = 0u64;
    for chunk in hits.chunks(CHUNK_HITS) {
        let rays: Vec<(f32, Option<Ray>)> = chunk.par_iter().map(|h| shadow_ray(scene, h, light, params)).collect();
        let shadow: Vec<Ray> = rays.iter().filter_map(|r| r.1).collect();
        traced += shadow.len() as u64;
        let visible = tracer.visible(&shadow)?;
        let mut vis = visible.into_iter();
        out.extend(rays.iter().map(|(g, r)| match r {
            Some(_) => {
                if vis.next().expect("one answer per ray") {
                    *g
                } else {
                    0.0
                }
            }
            None => *g,
        }));
    }
    Ok((out, traced))
}

impl NearLight {
    /// The columns after a deformation (`motion`), from `old` ones over the
    /// near hits `before`: the hits of vertices flagged in `redone`
    /// (their near hits were found anew), the hits on moved triangles and
    /// those whose shadow segment meets a box of the motion are traced;
    /// the others keep their value (nothing on their segment moved). The
    /// columns equal a fresh [`NearLight::compute`]. Returns the hits traced per light.
    #[allow(clippy::too_many_arguments)]
    pub fn update_deformed(
        &mut self,
        scene: &PreparedScene,
        before: &NearHits,
        after: &NearHits,
        redone: &[bool],
        motion: &Motion,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
    ) -> crate::Result<u64> {
        let start = Instant::now();
        if !self.covers(&scene.lights) || before.offsets.len() != after.offsets.len() {
            *self = NearLight::compute(scene, after, tracer, params)?;
            return Ok(after.hits.len() as u64);
        }
        let n = after.offsets.len().saturating_sub(1);
        let mut rays = 0u64;
        let mut recomputed = 0u64;
        for (l, light) in scene.lights.iter().enumerate() {
            // Per new hit: Some(old value) to keep, None to trace.
            let kept: Vec<Option<f32>> = (0..n)
                .into_par_iter()
                .flat_map_iter(|v| {
                    let (b0, a) = (before.offsets[v] as usize, after.of(v));
                    let old = &self.columns[l];
                    a.iter()
                        .enumerate()
                        .map(move |(i, h)| {
                            if redone[v] || motion.moved_triangle[h.tri as usize] {
                                return None;
                            }
                            let (_, ray) = shadow_ray(scene, h, light, params);
                            let meets = ray.is_some_and(|r| {
                                let inv = r.dir.recip();
                                motion.boxes.iter().any(|b| b.meets_segment(r.origin, inv, r.tmin, r.tmax))
                            });
                            (!meets).then(|| old[b0 + i])
                        })
                        .collect::<Vec<_>>()
                })
                .collect();
            let todo: Vec<NearHit> =
                kept.iter().zip(&after.hits).filter(|(k, _)| k.is_none()).map(|(_, h)| *h).collect();
            let (fresh, r) = column_at(scene, &todo, light, tracer, params)?;
            rays += r;
            recomputed += todo.len() as u64;
            let mut fresh = fresh.into_iter();
            self.columns[l] =
                kept.into_iter().map(|k| k.unwrap_or_else(|| fresh.next().expect("one per hit"))).collect();
        }
        self.shadow_rays = rays;
        self.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(recomputed)
    }
}
