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
//! `E_src` is the lights' bounce source ([`crate::exchange::sources::light_links::LightLinks::bounce_source`]);
//! the sky's and the emitters' light at the hits have their own
//! corrections ([`crate::exchange::near::sky`], [`crate::exchange::near::emitters`]). `G_l V_l` is
//! stored per light and near hit (a column, like the light links'), so a
//! new intensity traces nothing and a moved light traces only its column.
//!
//! `D` is first-bounce irradiance at `x` (W/m^2, negative where the links
//! brought light that is not there): it is added to `E_i` and, like the
//! emitters' direct light, to the source of the bounces, so its reflections
//! travel on through the links. Measured against the reference
//! (`cargo test --release --test measured -- --ignored near_field_lowers_tearoom_error`,
//! `--off near` without; auto bounces, total relative RMSE,
//! noise removed): tearoom (16384 paths) 5.5/3.5/3.1% at 64/256/1024 rays
//! without, 5.0/2.6/2.0% with; cornell (65536 paths) 4.7/2.4/1.07% without,
//! 4.7/2.3/0.94% with.
//!
//! Hit points: `h = sum_c beta_c p_c` on the flat triangle, normal its
//! geometric normal (the side the ray came from: near hits are front
//! hits); shadow rays start `eps * l` off the surface (l: the triangle's
//! longest edge) and stop as short of a point light, as the light links do.

use super::{correct_by_hits, hit_frame, Bounce, Cost, Fields, NearChange, NearTerm, Shape, BATCH_HITS};
use crate::exchange::sources::light_links::{geometry, same_column, toward, LightLinkParams};
use crate::trace::ray::{NO_SKIP, Ray};
use crate::links::{NearHit, NearHits};
use crate::scene::{prep::PreparedScene, Light};
use crate::trace::{Tracer, RAY_OFFSET};
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
    /// Shadow rays and time of the last computation or update.
    pub cost: Cost,
}

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
                Some(i) if old_columns[i].len() == near.rows.items.len() => std::mem::take(&mut old_columns[i]),
                _ => {
                    let (c, r) = column(scene, near, light, tracer, params)?;
                    rays += r;
                    c
                }
            };
            self.columns.push(column);
            self.lights.push(*light);
        }
        self.cost = self.cost_of(rays, start);
        Ok(())
    }

    /// True if every light of `lights` has its column.
    pub fn covers(&self, lights: &[Light]) -> bool {
        lights.len() == self.lights.len() && lights.iter().zip(&self.lights).all(|(a, b)| same_column(a, b))
    }

    /// The cost of a trace of `rays` rays started at `start`.
    fn cost_of(&self, rays: u64, start: Instant) -> Cost {
        let bytes = self.columns.iter().map(|c| std::mem::size_of_val(c.as_slice()) as u64).sum();
        Cost { rays, ms: start.elapsed().as_secs_f64() * 1e3, bytes }
    }
}

impl NearTerm for NearLight {
    fn name(&self) -> &'static str {
        "lights"
    }

    fn bounce(&self) -> Bounce {
        Bounce::First
    }

    fn is_empty(&self) -> bool {
        self.columns.iter().all(Vec::is_empty)
    }

    /// The correction `D` of the module doc at every vertex, W/m^2, for
    /// the fields' lights (whose columns must be traced: [`NearLight::covers`])
    /// and their bounce source `e_lights`. `None` without near hits, and
    /// while some light's column is stale (a light preview): then the
    /// links' interpolated first bounce stands.
    fn correction(&self, f: &Fields) -> Option<Vec<Vec3>> {
        if f.near.is_empty() || !self.covers(f.lights) {
            return None;
        }
        let powers: Vec<Vec3> = f.lights.iter().map(Light::power).collect();
        let at_hit = |k: usize| -> Vec3 { powers.iter().zip(&self.columns).map(|(p, col)| *p * col[k]).sum() };
        Some(correct_by_hits(f, f.e_lights, at_hit))
    }

    fn cost(&self) -> Cost {
        self.cost
    }

    /// One column per light, a value per near hit, finite and non-negative.
    fn validate(&self, shape: &Shape) -> Result<(), String> {
        if self.columns.len() != self.lights.len() {
            return Err(format!("{} columns for {} lights", self.columns.len(), self.lights.len()));
        }
        for (l, c) in self.columns.iter().enumerate() {
            if c.len() != shape.near_hits {
                return Err(format!("light {l}: {} values for {} near hits", c.len(), shape.near_hits));
            }
            if let Some(x) = c.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                return Err(format!("light {l}: value {x}"));
            }
        }
        Ok(())
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
    column_at(scene, &near.rows.items, light, tracer, params)
}

/// The geometry term of `light` at near hit `h` and its shadow ray (none
/// where `G = 0` or where the light sits on the surface).
fn shadow_ray(scene: &PreparedScene, h: &NearHit, light: &Light, params: &LightLinkParams) -> (f32, Option<Ray>) {
    let (p, normal, l) = hit_frame(scene, h);
    let g = geometry(light, p, normal, (params.min_distance * l).max(f32::MIN_POSITIVE.sqrt()));
    if !(g > 0.0) {
        return (0.0, None);
    }
    let eps = RAY_OFFSET * l;
    let o = p + normal * eps;
    let (dir, dist) = toward(light, o);
    // `None`: the light sits on the surface here, nothing in between.
    (g, Ray::shadow_checked(o, dir, dist, eps, 0.0, NO_SKIP))
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
    for chunk in hits.chunks(BATCH_HITS as usize) {
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
    /// The columns after a deformation, from `self` over the near hits
    /// `change.before`: hits whose vertex was redone or that lie on a moved
    /// triangle, and those whose shadow segment meets a box of the motion,
    /// are traced; the others keep their value (nothing on their segment
    /// moved). The columns equal a fresh [`NearLight::compute`]. Returns
    /// the hits traced per light.
    pub fn update_deformed(
        &mut self,
        scene: &PreparedScene,
        change: &NearChange,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
    ) -> crate::Result<u64> {
        let start = Instant::now();
        let after = change.after;
        if !self.covers(&scene.lights) || !change.aligned() {
            *self = NearLight::compute(scene, after, tracer, params)?;
            return Ok(after.rows.items.len() as u64);
        }
        let n = after.rows.offsets.len().saturating_sub(1);
        let mut rays = 0u64;
        let mut recomputed = 0u64;
        for (l, light) in scene.lights.iter().enumerate() {
            // Per new hit: Some(old value) to keep, None to trace.
            let old = &self.columns[l];
            let kept: Vec<Option<f32>> = (0..n)
                .into_par_iter()
                .flat_map_iter(|v| {
                    after
                        .of(v)
                        .iter()
                        .enumerate()
                        .map(move |(i, h)| {
                            let k = change.kept_at(v, i, h)?;
                            let (_, ray) = shadow_ray(scene, h, light, params);
                            (!ray.is_some_and(|r| change.segment_moved(&r, r.tmax))).then(|| old[k])
                        })
                        .collect::<Vec<_>>()
                })
                .collect();
            let todo: Vec<NearHit> =
                kept.iter().zip(&after.rows.items).filter(|(k, _)| k.is_none()).map(|(_, h)| *h).collect();
            let (fresh, r) = column_at(scene, &todo, light, tracer, params)?;
            rays += r;
            recomputed += todo.len() as u64;
            let mut fresh = fresh.into_iter();
            self.columns[l] =
                kept.into_iter().map(|k| k.unwrap_or_else(|| fresh.next().expect("one per hit"))).collect();
        }
        self.cost = self.cost_of(rays, start);
        Ok(recomputed)
    }
}
