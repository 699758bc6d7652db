//! Light links: for each light and vertex, the geometry term `G` at the
//! vertex (point light: `cos_v / r^2`, 1/m^2; directional: `cos_v`) times
//! a visibility, stored per light so that a change of intensity needs no
//! rays and a moved light redoes only its own column
//! ([`LightLinks::update_with`]). Two columns per light:
//!
//! - [`LightLinks::point`]: `G * V` with `V` traced from the vertex itself
//!   (its own ray origin). `E_d(v) = sum_l I_l * G * V` is the exact direct
//!   irradiance at the vertex, up to float rounding: this is the `E_d`
//!   reported and exported ([`LightLinks::direct`]).
//! - [`LightLinks::factors`]: `G * V_avg`, the visibility averaged over
//!   oversampling points on the one-ring (below) when
//!   [`LightLinkParams::oversample`] is set, else equal to `point`. It is
//!   the same rays: the first oversampling point is the vertex's origin.
//!
//! The bounces start from one of the two ([`BounceSource`],
//! [`LightLinks::bounce_source`]). The one-ring average stands for the
//! radiosity around the vertex, which the links interpolate across its
//! triangles; the point value is exact at the vertex. Measured: relative
//! RMSE of unsmoothed `E_i` (auto bounces, hidden-vertex correction of
//! [`crate::exchange::bounce::hidden`]) against the reference path tracer, reference noise
//! removed (Cornell box: 65536 paths per vertex, tearoom: 16384):
//!
//! | rays | cornell, ring | cornell, point | tearoom, ring | tearoom, point |
//! |---|---|---|---|---|
//! | 64 | 0.1627 | 0.1628 | 0.1107 | 0.1097 |
//! | 256 | 0.0638 | 0.0638 | 0.0573 | 0.0561 |
//! | 1024 | 0.0197 | 0.0197 | 0.0462 | 0.0445 |
//!
//! The point value is as good or better on both scenes, so it is the
//! default source and oversampling is off by default (13x fewer shadow
//! rays on a triangle mesh). Without the hidden-vertex correction the ring
//! was marginally ahead (1024 rays: cornell 0.0312 against 0.0316, tearoom
//! 0.0447 against 0.0457): its advantage was the hidden vertices under
//! objects, whose partial one-ring visibility stood in for the lit floor
//! beside them, which the correction now does better. Where a shadow edge
//! passes exactly through vertices (a coarse mesh grazed by its own
//! occluder's edge), the ring still represents the triangles around them
//! better. The reported `E_d` is the point value either way: against the
//! reference it is off by 0.0000 (cornell) and 0.0018 (tearoom: a few
//! vertices whose shadow ray grazes an edge between the two solvers'
//! slightly different origins), where the one-ring average was off by
//! 0.0286 and 0.1685.
//!
//! A preview ([`LightLinks::preview_with`]) traces new columns from the
//! vertices alone for a quick first answer while a light is dragged: with
//! oversampling on, about 1/13 of the rays; its point values, and so its
//! `E_d`, are those of the full update, bit for bit.
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

use crate::trace::ray::Ray;
use crate::links::shoot::ray_origin;
use crate::links::Lineage;
use crate::scene::motion::Motion;
use crate::scene::{prep::PreparedScene, Light};
use crate::trace::{Tracer, RAY_OFFSET};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// Parameters of light-link computation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightLinkParams {
    /// Oversample visibility on the one-ring for `LightLinks::factors`
    /// (false, the default: the vertex alone, and `factors` equal `point`).
    pub oversample: bool,
    /// Smallest light distance used in `1/r^2`, as a fraction of the mean edge length at the vertex.
    pub min_distance: f32,
    /// Origin nudge of crease and border vertices (as in [`crate::links::LinkParams`]).
    pub nudge: f32,
    /// The direct irradiance the bounces start from (see the module doc for the measurements).
    pub bounce_source: BounceSource,
}

impl LightLinkParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: LightLinkParams =
        Self { oversample: false, min_distance: 1e-3, nudge: 1e-3, bounce_source: BounceSource::Point };
}

impl Default for LightLinkParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Which direct irradiance the bounces start from (`B_0 = rho/pi * E`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BounceSource {
    /// The one-ring oversampled `G * V_avg` (`LightLinks::factors`;
    /// needs [`LightLinkParams::oversample`] to differ from `Point`).
    Ring,
    /// The exact point value `G * V(vertex)` (`LightLinks::point`).
    #[default]
    Point,
}

/// One light's factors at some vertices, and the shadow rays they took.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Column {
    /// `G * V_avg` over the one-ring oversampling points.
    pub ring: Vec<f32>,
    /// `G * V` of the vertex's own origin (exact point value).
    pub point: Vec<f32>,
    /// Shadow rays traced for the column.
    pub rays: u64,
}

/// `G * V_avg` and `G * V` per light and vertex, plus counters.
#[derive(Clone, Debug, Default)]
pub struct LightLinks {
    /// `factors[l][v]` = `G * V_avg` (one-ring oversampled): 1/m^2 for
    /// point lights, unitless for directional.
    pub factors: Vec<Vec<f32>>,
    /// `point[l][v]` = `G * V` with visibility from the vertex itself, same
    /// units: `I_l * point[l][v]` is the exact direct irradiance at the vertex.
    pub point: Vec<Vec<f32>>,
    /// The lights the columns were computed for (their positions or
    /// directions matter; intensities do not enter the factors).
    pub lights: Vec<Light>,
    /// The parameters and vertex positions the columns were computed with;
    /// an update that finds either changed recomputes every column.
    pub params: Option<LightLinkParams>,
    /// Vertex positions the columns were computed at, metres.
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

/// The unit direction from point `from` toward `light` and the distance
/// to it (metres; infinite for a directional light).
pub fn toward(light: &Light, from: Vec3) -> (Vec3, f32) {
    match *light {
        Light::Point { position, .. } => {
            let d = position - from;
            let len = d.length();
            (d / len.max(f32::MIN_POSITIVE), len)
        }
        Light::Directional { direction, .. } => (-direction.normalize(), f32::INFINITY),
    }
}

/// Vertices per chunk of shadow rays handed to a [`ShadowTracer`] (bounds memory).
const CHUNK_VERTICES: usize = 16384;

impl LightLinks {
    /// Computes the factors of every light with a CPU tracer (which cannot fail).
    #[cfg(any(test, feature = "internals"))]
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
        let (mut factors, mut point, mut coarse) = (Vec::with_capacity(scene.lights.len()), Vec::new(), Vec::new());
        let mut traced = 0;
        for light in &scene.lights {
            let kept = (0..self.lights.len()).find(|&i| !used[i] && same_column(&self.lights[i], light));
            let (column, is_coarse) = match kept {
                Some(i) => {
                    used[i] = true;
                    (Column { ring: self.factors[i].clone(), point: self.point[i].clone(), rays: 0 }, self.coarse[i])
                }
                None => {
                    let p = if preview { &coarse_params } else { params };
                    let c = Self::compute_light(scene, tracer, light, p)?;
                    traced += c.rays;
                    // Without oversampling a preview column is already the full one.
                    (c, preview && params.oversample)
                }
            };
            factors.push(column.ring);
            point.push(column.point);
            coarse.push(is_coarse);
        }
        self.factors = factors;
        self.point = point;
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

    /// One light's column at every vertex.
    pub fn compute_light(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        light: &Light,
        params: &LightLinkParams,
    ) -> crate::Result<Column> {
        let all: Vec<u32> = (0..scene.vertex_count() as u32).collect();
        Self::compute_light_at(scene, tracer, light, params, &all)
    }

    /// One light's column at `vertices` only (in that order). The point
    /// value comes from the same rays: the first oversampling point is the
    /// vertex's own origin.
    pub fn compute_light_at(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        light: &Light,
        params: &LightLinkParams,
        vertices: &[u32],
    ) -> crate::Result<Column> {
        let mut out =
            Column { ring: Vec::with_capacity(vertices.len()), point: Vec::with_capacity(vertices.len()), rays: 0 };
        for chunk in vertices.chunks(CHUNK_VERTICES) {
            // Per vertex: its shadow rays (appended to one flat list) and how to count them.
            let per_vertex: Vec<VertexRays> = chunk
                .par_iter()
                .map_init(Vec::new, |pts, &v| shadow_rays(scene, light, params, v as usize, pts))
                .collect();
            let rays: Vec<Ray> = per_vertex.iter().flat_map(|p| p.rays.iter().copied()).collect();
            let visible = tracer.visible(&rays)?;
            out.rays += rays.len() as u64;
            let mut at = 0;
            for p in &per_vertex {
                let seen = &visible[at..at + p.rays.len()];
                at += p.rays.len();
                if p.g > 0.0 {
                    let count = seen.iter().filter(|&&x| x).count() as u32;
                    out.ring.push(p.g * (p.free + count) as f32 / p.samples as f32);
                    // The vertex's own point: free, or the first ray.
                    out.point.push(if p.first_free || seen[0] { p.g } else { 0.0 });
                } else {
                    out.ring.push(0.0);
                    out.point.push(0.0);
                }
            }
        }
        Ok(out)
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
        let n = scene.vertex_count();
        let valid = self.params == Some(*params) && self.positions.len() == n;
        let coarse = self.coarse.clone();
        let redo = |light: &Light| -> Vec<u32> {
            (0..n as u32)
                .into_par_iter()
                .map_init(Vec::new, |pts, v| {
                    (motion.remade[v as usize] || shadow_meets(scene, light, params, v as usize, motion, pts))
                        .then_some(v)
                })
                .flatten()
                .collect()
        };
        let (columns, traced, entries) =
            self.patched_columns(scene, tracer, params, &|i| valid && !coarse[i], &redo)?;
        self.coarse = vec![false; columns.len()];
        self.set_columns(columns);
        self.lights = scene.lights.clone();
        self.params = Some(*params);
        self.positions = scene.positions.clone();
        self.shadow_rays = traced;
        self.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(entries)
    }

    /// The light links of `scene`, a split of `before` (a refinement
    /// round) whose light links `old` were computed with the same
    /// `params`, by `lineage`: every column is kept at the kept vertices
    /// whose one-ring no split touched ([`Lineage::whole`]) and whose ray
    /// origin is the same (a vertex's entry reads only its own position,
    /// normal, origin and one-ring, and the surfaces, which a split leaves
    /// where they were), and computed at the others. Equal to a fresh
    /// [`LightLinks::compute_with`] (`tests/refine.rs`). Returns the links
    /// and the (vertex, light) entries computed.
    pub fn after_split(
        old: &LightLinks,
        before: &PreparedScene,
        scene: &PreparedScene,
        lineage: &Lineage,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
    ) -> crate::Result<(LightLinks, u64)> {
        let start = Instant::now();
        let n = scene.vertex_count();
        let valid = old.params == Some(*params)
            && old.positions.len() == before.vertex_count()
            && lineage.kept.len() == n
            && !old.coarse.contains(&true);
        if !valid {
            let links = LightLinks::compute_with(scene, tracer, params)?;
            return Ok((links, (n * scene.lights.len()) as u64));
        }
        let carried = lineage.carried(before, scene, params.nudge);
        let remap = |column: &Vec<f32>| -> Vec<f32> { carried.iter().map(|c| c.map_or(0.0, |v| column[v])).collect() };
        let mut out = LightLinks {
            factors: old.factors.iter().map(remap).collect(),
            point: old.point.iter().map(remap).collect(),
            lights: old.lights.clone(),
            params: old.params,
            positions: scene.positions.clone(),
            coarse: old.coarse.clone(),
            shadow_rays: 0,
            ms: 0.0,
        };
        let redo: Vec<u32> = (0..n as u32).filter(|&w| carried[w as usize].is_none()).collect();
        let (columns, traced, entries) = out.patched_columns(scene, tracer, params, &|_| true, &|_| redo.clone())?;
        out.coarse = vec![false; columns.len()];
        out.set_columns(columns);
        out.lights = scene.lights.clone();
        out.shadow_rays = traced;
        out.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok((out, entries))
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
        let valid = self.positions.len() == scene.vertex_count();
        let (columns, traced, _) =
            self.patched_columns(scene, tracer, &coarse_params, &|_| valid, &|_: &Light| remade.to_vec())?;
        // Without oversampling the preview's columns are the full ones.
        self.coarse = vec![params.oversample; columns.len()];
        self.set_columns(columns);
        self.lights = scene.lights.clone();
        self.shadow_rays = traced;
        self.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(traced)
    }

    /// Columns for `scene.lights` with `params`: a light at the place of
    /// an old column that `keep(i)` allows keeps that column, recomputed
    /// only at the vertices `redo(light)` lists; other lights get full
    /// columns. Returns the columns, the shadow rays traced and the
    /// (vertex, light) entries recomputed.
    fn patched_columns(
        &mut self,
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &LightLinkParams,
        keep: &dyn Fn(usize) -> bool,
        redo: &dyn Fn(&Light) -> Vec<u32>,
    ) -> crate::Result<(Vec<Column>, u64, u64)> {
        let mut used: Vec<bool> = (0..self.lights.len()).map(|i| !keep(i)).collect();
        let (mut columns, mut traced, mut entries) = (Vec::with_capacity(scene.lights.len()), 0, 0u64);
        for light in &scene.lights {
            let kept = (0..self.lights.len()).find(|&i| !used[i] && same_column(&self.lights[i], light));
            let column = match kept {
                Some(i) => {
                    used[i] = true;
                    let mut column = self.take_column(i);
                    let vertices = redo(light);
                    let c = Self::compute_light_at(scene, tracer, light, params, &vertices)?;
                    column.patch(&vertices, c);
                    entries += vertices.len() as u64;
                    column
                }
                None => {
                    entries += scene.vertex_count() as u64;
                    Self::compute_light(scene, tracer, light, params)?
                }
            };
            traced += column.rays;
            columns.push(column);
        }
        Ok((columns, traced, entries))
    }

    /// Column `i` taken out (its ray count 0).
    fn take_column(&mut self, i: usize) -> Column {
        Column { ring: std::mem::take(&mut self.factors[i]), point: std::mem::take(&mut self.point[i]), rays: 0 }
    }

    fn set_columns(&mut self, columns: Vec<Column>) {
        (self.factors, self.point) = columns.into_iter().map(|c| (c.ring, c.point)).unzip();
    }

    /// Exact direct irradiance at every vertex, W/m^2:
    /// `sum_l I_l * point_l(v)` (what is reported and exported as `E_d`).
    pub fn direct(&self, lights: &[Light], n: usize) -> Vec<Vec3> {
        weighted(lights, &self.point, n)
    }

    /// The one-ring oversampled direct irradiance, W/m^2: `sum_l I_l * factor_l(v)`.
    pub fn direct_ring(&self, lights: &[Light], n: usize) -> Vec<Vec3> {
        weighted(lights, &self.factors, n)
    }

    /// The direct irradiance the bounces start from, W/m^2 (the
    /// parameters' [`BounceSource`]; previews have only point values).
    pub fn bounce_source(&self, lights: &[Light], n: usize) -> Vec<Vec3> {
        match self.params.map(|p| p.bounce_source).unwrap_or_default() {
            BounceSource::Ring => self.direct_ring(lights, n),
            BounceSource::Point => self.direct(lights, n),
        }
    }
}

impl Column {
    /// Writes `c`, computed at `vertices`, into this full column; adds its rays.
    fn patch(&mut self, vertices: &[u32], c: Column) {
        for ((&v, r), p) in vertices.iter().zip(c.ring).zip(c.point) {
            self.ring[v as usize] = r;
            self.point[v as usize] = p;
        }
        self.rays += c.rays;
    }
}

/// `sum_l power_l * columns[l][v]` per vertex.
fn weighted(lights: &[Light], columns: &[Vec<f32>], n: usize) -> Vec<Vec3> {
    let mut e = vec![Vec3::ZERO; n];
    for (light, f) in lights.iter().zip(columns) {
        let power = light.power();
        for (e, &g) in e.iter_mut().zip(f) {
            *e += power * g;
        }
    }
    e
}

/// Vertex `v`'s shadow rays toward `light` and how to count them.
struct VertexRays {
    /// Geometry term at the vertex (1/m^2 or unitless); 0: no rays.
    g: f32,
    /// Oversampling points.
    samples: u32,
    /// Points visible without a ray (the light sits on the surface there).
    free: u32,
    /// The first point (the vertex's own origin) is one of them; else `rays[0]` is its ray.
    first_free: bool,
    rays: Vec<Ray>,
}

/// Vertex `v`'s shadow rays toward `light`; no rays where `G = 0`.
fn shadow_rays(
    scene: &PreparedScene,
    light: &Light,
    params: &LightLinkParams,
    v: usize,
    pts: &mut Vec<Vec3>,
) -> VertexRays {
    let min_d = params.min_distance * scene.mean_edge_length(v);
    let g = geometry(light, scene.positions[v], scene.normals[v], min_d.max(f32::MIN_POSITIVE.sqrt()));
    if g <= 0.0 {
        return VertexRays { g: 0.0, samples: 1, free: 0, first_free: false, rays: Vec::new() };
    }
    sample_points(scene, v, params, pts);
    let eps = RAY_OFFSET * scene.mean_edge_length(v).max(f32::MIN_POSITIVE);
    let mut free = 0u32;
    let mut first_free = false;
    let mut rays = Vec::with_capacity(pts.len());
    for (i, &s) in pts.iter().enumerate() {
        let (dir, dist) = toward(light, s);
        match Ray::shadow_checked(s, dir, dist, eps, eps, v as u32) {
            Some(ray) => rays.push(ray),
            None => {
                // The light sits on the surface at this point: nothing can be in between.
                free += 1;
                first_free |= i == 0;
            }
        }
    }
    VertexRays { g, samples: pts.len() as u32, free, first_free, rays }
}

/// True if one of vertex `v`'s shadow segments toward `light` meets a box
/// of `motion` (so its visibility may have changed).
fn shadow_meets(
    scene: &PreparedScene,
    light: &Light,
    params: &LightLinkParams,
    v: usize,
    motion: &Motion,
    pts: &mut Vec<Vec3>,
) -> bool {
    shadow_rays(scene, light, params, v, pts).rays.iter().any(|r| {
        let inv = r.dir.recip();
        motion.boxes.iter().any(|b| b.meets_segment(r.origin, inv, r.tmin, r.tmax))
    })
}
