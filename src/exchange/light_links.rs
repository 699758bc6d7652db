//! Light links: for each light and vertex, the geometry term `G` at the
//! vertex (point light: `cos_v / r^2`, 1/m^2; directional: `cos_v`) times
//! the visibility `V_avg` averaged over oversampling points on the vertex's
//! one-ring, so `E_d(v) = sum_l I_l * G * V_avg`. Storing `G * V_avg` per
//! light means a change of intensity needs no rays; a moved light redoes
//! only its own column ([`LightLinks::update_with`]). A preview
//! ([`LightLinks::preview_with`]) traces new columns from the vertices
//! alone, about 1/13 of the rays, for a quick first answer while a light is
//! dragged.
//!
//! Oversampling (deviation-free reading of the paper's 1:4 subdivision): the
//! points are the vertex itself, the midpoint of every edge at the vertex,
//! and for every adjacent triangle the centroid of its corner sub-triangle
//! at the vertex, `(4 v + a + b) / 6`. All lie on triangles incident to the
//! vertex, which the shadow rays skip; shadow rays start `eps * l` along the
//! ray (l: mean edge length at the vertex) and stop the same distance short
//! of a point light.
//!
//! A point light closer than `min_distance * l` to a vertex is treated as
//! that far away (documented clamp: keeps `1/r^2` finite for a light on a
//! vertex; relative to the mesh so the answer does not depend on the
//! scene's scale). A light exactly on a vertex lies in its tangent plane
//! (`cos = 0`) and lights that vertex not at all; one just above it gives
//! at most `I / (min_distance * l)^2`.

use crate::kdtree::traverse::Ray;
use crate::links::shoot::ray_origin;
use crate::scene::motion::Motion;
use crate::scene::{prep::PreparedScene, Light};
use crate::trace::Tracer;
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Parameters of light-link computation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightLinkParams {
    /// Shadow-ray start and end offset, as a fraction of the mean edge length at the vertex.
    pub eps: f32,
    /// Oversample visibility on the one-ring (false: the vertex alone).
    pub oversample: bool,
    /// Smallest light distance used in `1/r^2`, as a fraction of the mean edge length at the vertex.
    pub min_distance: f32,
    /// Origin nudge of crease and border vertices (as in [`crate::links::LinkParams`]).
    pub nudge: f32,
}

impl Default for LightLinkParams {
    fn default() -> Self {
        Self { eps: 1e-4, oversample: true, min_distance: 1e-3, nudge: 1e-3 }
    }
}

/// `G * V_avg` per light and vertex, plus counters.
#[derive(Clone, Debug, Default)]
pub struct LightLinks {
    /// `factors[l][v]`: 1/m^2 for point lights, unitless for directional.
    pub factors: Vec<Vec<f32>>,
    /// The lights the columns were computed for (their positions or
    /// directions matter; intensities do not enter the factors).
    pub lights: Vec<Light>,
    /// The parameters and vertex positions the columns were computed with;
    /// an update that finds either changed recomputes every column.
    pub params: Option<LightLinkParams>,
    pub positions: Vec<Vec3>,
    /// Per column: a preview, traced from the vertex alone (no one-ring
    /// oversampling; [`LightLinks::preview_with`]), which the next full
    /// update replaces.
    pub coarse: Vec<bool>,
    /// Shadow rays traced by the last computation or update.
    pub shadow_rays: u64,
    /// Time of the last computation or update.
    pub ms: f64,
}

/// True if two lights give the same light-link column: same kind and the
/// same position (point) or direction (directional), whatever their power.
pub fn same_column(a: &Light, b: &Light) -> bool {
    match (a, b) {
        (Light::Point { position: p, .. }, Light::Point { position: q, .. }) => p == q,
        (Light::Directional { direction: d, .. }, Light::Directional { direction: e, .. }) => d == e,
        _ => false,
    }
}

/// The oversampling points of vertex `v` (the first is the vertex's own origin).
pub fn sample_points(scene: &PreparedScene, v: usize, params: &LightLinkParams, out: &mut Vec<Vec3>) {
    out.clear();
    let p = scene.positions[v];
    out.push(ray_origin(scene, v, params.nudge));
    if !params.oversample {
        return;
    }
    for &u in scene.rings.row(v) {
        out.push(0.5 * (p + scene.positions[u as usize]));
    }
    for &t in scene.vertex_triangles.row(v) {
        let tri = scene.triangles[t as usize];
        let others: Vec3 = tri.iter().filter(|&&i| i as usize != v).map(|&i| scene.positions[i as usize]).sum();
        out.push((4.0 * p + others) / 6.0);
    }
}

/// Geometry term of `light` at a point with normal `n`; a point light
/// closer than `min_distance` (metres) counts as that far away.
pub fn geometry(light: &Light, p: Vec3, n: Vec3, min_distance: f32) -> f32 {
    match *light {
        Light::Point { position, .. } => {
            let d = position - p;
            let r2 = d.length_squared().max(min_distance * min_distance);
            let cos = n.dot(d) / r2.sqrt();
            cos.max(0.0) / r2
        }
        Light::Directional { direction, .. } => n.dot(-direction.normalize()).max(0.0),
    }
}

/// Vertices per chunk of shadow rays handed to a [`ShadowTracer`] (bounds memory).
const CHUNK_VERTICES: usize = 16384;

impl LightLinks {
    /// Computes the factors of every light with a CPU tracer (which cannot fail).
    pub fn compute(scene: &PreparedScene, tracer: &dyn Tracer, params: &LightLinkParams) -> LightLinks {
        Self::compute_with(scene, tracer, params).expect("a CPU tracer cannot fail")
    }

    /// Computes the factors of every light with `tracer`.
    pub fn compute_with(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
    ) -> crate::Result<LightLinks> {
        let mut out = LightLinks::default();
        out.update_with(scene, tracer, params)?;
        Ok(out)
    }

    /// Brings the columns up to date with `scene.lights`: a light whose
    /// position (or direction) matches one already computed keeps that
    /// column, with no rays (a changed intensity, a light added or removed
    /// elsewhere in the list); only the others are traced. Different
    /// `params` or moved vertices void every column. Returns the shadow
    /// rays traced. The mesh's topology must be the one the columns were
    /// computed on (a solver builds new light links with a new mesh).
    pub fn update_with(
        &mut self,
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
    ) -> crate::Result<u64> {
        self.update_columns(scene, tracer, params, false)
    }

    /// A quick preview of [`LightLinks::update_with`]: lights that need new
    /// columns are traced from their vertices alone, without the one-ring
    /// oversampling (about 1/13 of the shadow rays on a triangle mesh), and
    /// those columns are marked [`LightLinks::coarse`]; the next full
    /// update retraces them. Columns kept from before stay as they were.
    /// Returns the shadow rays traced.
    pub fn preview_with(
        &mut self,
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
    ) -> crate::Result<u64> {
        self.update_columns(scene, tracer, params, true)
    }

    fn update_columns(
        &mut self,
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
        preview: bool,
    ) -> crate::Result<u64> {
        let start = Instant::now();
        // Built aside and swapped in at the end, so a failed trace leaves
        // the columns as they were.
        let valid = self.params == Some(*params) && self.positions == scene.positions;
        // A full update keeps only full columns; a preview keeps any.
        let mut used: Vec<bool> = (0..self.lights.len()).map(|i| !valid || (self.coarse[i] && !preview)).collect();
        let coarse_params = LightLinkParams { oversample: false, ..*params };
        let (mut factors, mut coarse) = (Vec::with_capacity(scene.lights.len()), Vec::new());
        let mut traced = 0;
        for light in &scene.lights {
            let kept = (0..self.lights.len()).find(|&i| !used[i] && same_column(&self.lights[i], light));
            let (column, is_coarse) = match kept {
                Some(i) => {
                    used[i] = true;
                    (self.factors[i].clone(), self.coarse[i])
                }
                None => {
                    let p = if preview { &coarse_params } else { params };
                    let (f, rays) = Self::compute_light(scene, tracer, light, p)?;
                    traced += rays;
                    (f, preview)
                }
            };
            factors.push(column);
            coarse.push(is_coarse);
        }
        self.factors = factors;
        self.coarse = coarse;
        self.lights = scene.lights.clone();
        if !valid {
            self.params = Some(*params);
            self.positions = scene.positions.clone();
        }
        self.shadow_rays = traced;
        self.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(traced)
    }

    /// One light's column: `(G * V_avg per vertex, shadow rays traced)`.
    pub fn compute_light(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        light: &Light,
        params: &LightLinkParams,
    ) -> crate::Result<(Vec<f32>, u64)> {
        let all: Vec<u32> = (0..scene.vertex_count() as u32).collect();
        Self::compute_light_at(scene, tracer, light, params, &all)
    }

    /// One light's factors at `vertices` only (in that order), and the shadow rays traced.
    pub fn compute_light_at(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        light: &Light,
        params: &LightLinkParams,
        vertices: &[u32],
    ) -> crate::Result<(Vec<f32>, u64)> {
        let mut factors = Vec::with_capacity(vertices.len());
        let mut traced = 0u64;
        for chunk in vertices.chunks(CHUNK_VERTICES) {
            // Per vertex: geometry term, sample count, points visible without a
            // ray, and its shadow rays (appended to one flat list).
            let per_vertex: Vec<(f32, u32, u32, Vec<Ray>)> = chunk
                .par_iter()
                .map_init(Vec::new, |pts, &v| shadow_rays(scene, light, params, v as usize, pts))
                .collect();
            let rays: Vec<Ray> = per_vertex.iter().flat_map(|p| p.3.iter().copied()).collect();
            let visible = tracer.visible(&rays)?;
            traced += rays.len() as u64;
            let mut at = 0;
            for (g, count, free, rays) in &per_vertex {
                let seen = visible[at..at + rays.len()].iter().filter(|&&x| x).count() as u32;
                at += rays.len();
                factors.push(if *g > 0.0 { g * (free + seen) as f32 / *count as f32 } else { 0.0 });
            }
        }
        Ok((factors, traced))
    }

    /// Brings the columns up to date after a deformation (`motion`, from
    /// the positions the columns were computed with to `scene`'s): a
    /// column of a light that kept its place is recomputed only at remade
    /// vertices and at vertices whose shadow segments meet a moved mesh's
    /// box (before or after the move); other columns (new or moved lights,
    /// previews, other parameters) are computed in full. Returns the
    /// (vertex, light) entries recomputed.
    pub fn update_deformed(
        &mut self,
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
        motion: &Motion,
    ) -> crate::Result<u64> {
        let start = Instant::now();
        let valid = self.params == Some(*params) && self.positions.len() == scene.vertex_count();
        let n = scene.vertex_count();
        let mut used = vec![!valid; self.lights.len()];
        let (mut factors, mut traced, mut entries) = (Vec::with_capacity(scene.lights.len()), 0, 0u64);
        for light in &scene.lights {
            let kept = (0..self.lights.len()).find(|&i| !used[i] && !self.coarse[i] && same_column(&self.lights[i], light));
            let column = match kept {
                Some(i) => {
                    used[i] = true;
                    let mut column = std::mem::take(&mut self.factors[i]);
                    let redo: Vec<u32> = (0..n as u32)
                        .into_par_iter()
                        .filter(|&v| motion.remade[v as usize] || shadow_meets(scene, light, params, v as usize, motion))
                        .collect();
                    let (f, rays) = Self::compute_light_at(scene, tracer, light, params, &redo)?;
                    for (&v, f) in redo.iter().zip(f) {
                        column[v as usize] = f;
                    }
                    traced += rays;
                    entries += redo.len() as u64;
                    column
                }
                None => {
                    let (f, rays) = Self::compute_light(scene, tracer, light, params)?;
                    traced += rays;
                    entries += n as u64;
                    f
                }
            };
            factors.push(column);
        }
        self.coarse = vec![false; factors.len()];
        self.factors = factors;
        self.lights = scene.lights.clone();
        self.params = Some(*params);
        self.positions = scene.positions.clone();
        self.shadow_rays = traced;
        self.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(entries)
    }

    /// The preview of [`LightLinks::update_deformed`]: columns of lights
    /// that kept their place are recomputed at `remade` vertices only and
    /// from the vertices alone (no one-ring oversampling); other columns
    /// in full, also without oversampling. All columns are then marked
    /// [`LightLinks::coarse`]. Returns the shadow rays traced.
    pub fn preview_deformed(
        &mut self,
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
        remade: &[u32],
    ) -> crate::Result<u64> {
        let start = Instant::now();
        let coarse_params = LightLinkParams { oversample: false, ..*params };
        let mut used = vec![self.positions.len() != scene.vertex_count(); self.lights.len()];
        let (mut factors, mut traced) = (Vec::with_capacity(scene.lights.len()), 0);
        for light in &scene.lights {
            let kept = (0..self.lights.len()).find(|&i| !used[i] && same_column(&self.lights[i], light));
            let column = match kept {
                Some(i) => {
                    used[i] = true;
                    let mut column = std::mem::take(&mut self.factors[i]);
                    let (f, rays) = Self::compute_light_at(scene, tracer, light, &coarse_params, remade)?;
                    for (&v, f) in remade.iter().zip(f) {
                        column[v as usize] = f;
                    }
                    traced += rays;
                    column
                }
                None => {
                    let (f, rays) = Self::compute_light(scene, tracer, light, &coarse_params)?;
                    traced += rays;
                    f
                }
            };
            factors.push(column);
        }
        self.coarse = vec![true; factors.len()];
        self.factors = factors;
        self.lights = scene.lights.clone();
        self.shadow_rays = traced;
        self.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(traced)
    }

    /// Direct irradiance per vertex, W/m^2: `sum_l I_l * factor_l(v)`.
    pub fn direct(&self, lights: &[Light], n: usize) -> Vec<Vec3> {
        let mut e = vec![Vec3::ZERO; n];
        for (light, f) in lights.iter().zip(&self.factors) {
            let power = match *light {
                Light::Point { intensity, .. } => intensity,
                Light::Directional { irradiance, .. } => irradiance,
            };
            for (e, &g) in e.iter_mut().zip(f) {
                *e += power * g;
            }
        }
        e
    }
}

/// Vertex `v`'s shadow rays toward `light`: `(G, sample count, samples
/// visible without a ray, rays)`; no rays where `G = 0`.
fn shadow_rays(
    scene: &PreparedScene,
    light: &Light,
    params: &LightLinkParams,
    v: usize,
    pts: &mut Vec<Vec3>,
) -> (f32, u32, u32, Vec<Ray>) {
    let min_d = params.min_distance * scene.mean_edge_length(v);
    let g = geometry(light, scene.positions[v], scene.normals[v], min_d.max(f32::MIN_POSITIVE.sqrt()));
    if g <= 0.0 {
        return (0.0, 1, 0, Vec::new());
    }
    sample_points(scene, v, params, pts);
    let eps = params.eps * scene.mean_edge_length(v).max(f32::MIN_POSITIVE);
    let mut free = 0u32;
    let mut rays = Vec::with_capacity(pts.len());
    for &s in pts.iter() {
        let (dir, dist) = match *light {
            Light::Point { position, .. } => {
                let d = position - s;
                let len = d.length();
                (d / len.max(f32::MIN_POSITIVE), len)
            }
            Light::Directional { direction, .. } => (-direction.normalize(), f32::INFINITY),
        };
        if dist <= 2.0 * eps || !dir.is_finite() {
            // The light sits on the surface at this point: nothing can be in between.
            free += 1;
            continue;
        }
        rays.push(Ray { origin: s, dir, tmin: eps, tmax: dist - eps, skip: v as u32 });
    }
    (g, pts.len() as u32, free, rays)
}

/// True if one of vertex `v`'s shadow segments toward `light` meets a box
/// of `motion` (so its visibility may have changed).
fn shadow_meets(scene: &PreparedScene, light: &Light, params: &LightLinkParams, v: usize, motion: &Motion) -> bool {
    let mut pts = Vec::new();
    let (_, _, _, rays) = shadow_rays(scene, light, params, v, &mut pts);
    rays.iter().any(|r| {
        let inv = r.dir.recip();
        motion.boxes.iter().any(|b| b.meets_segment(r.origin, inv, r.tmin, r.tmax))
    })
}
