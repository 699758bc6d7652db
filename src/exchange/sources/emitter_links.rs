//! Emitter links: the direct light of emissive surfaces at every vertex by
//! next-event estimation (docs/DESIGN.md §4), so that a small emitter is
//! not sampled only by the few link rays that happen to meet it.
//!
//! For a vertex at `p` with normal `n` and an emissive triangle `t`
//! (Lambertian, exitance `M_t` in W/m^2, radiance `M_t / pi`, from its
//! front only: a vertex behind its plane gets none, as a link ray that
//! meets its back brings none):
//!
//! ```text
//! E_t = M_t * F_t * V_t
//! F_t = 1/pi * integral over t ∩ {n·(y - p) >= 0} of cos(theta) dw      (unitless)
//!     = 1/(2 pi) * | sum_k gamma_k * n·c_k |                            (Lambert's formula)
//! ```
//!
//! `F_t` is exact: the triangle is clipped to the vertex's upper half
//! space, `gamma_k` is the angle its edge `k` subtends at `p` and `c_k` the
//! unit normal of the plane through `p` and that edge. `V_t`, the share of
//! the unoccluded integrand that is visible, is estimated by shadow rays
//! from the vertex's ray origin to points drawn uniformly on the clipped
//! triangle, each weighted by the integrand `cos_p |cos_y| / r^2`:
//! `V_t = sum V w / sum w` (a ratio estimate: exactly 1 for a triangle in
//! full view and 0 for a hidden one, whatever the sample positions).
//!
//! The `samples` rays of a vertex are spread over its emitter triangles by
//! systematic sampling of `F_t` (one seeded offset per vertex): triangle
//! `t` gets `floor` or `ceil` of `N F_t / F_sum` rays, and is met at all
//! with probability `pi_t = min(1, N F_t / F_sum)`, so a vertex never
//! traces more than `N + 1` rays, however many triangles emit. Per emitter
//! group `g` (below), with `F_g = sum over its triangles of F_t` known
//! exactly, the visible share is the ratio of the met triangles'
//! Horvitz-Thompson sums, `F_vg = F_g * sum (F_t / pi_t) V_t / sum (F_t / pi_t)`
//! (a group no ray met takes the vertex's share over all groups): exact
//! for an emitter in full view or fully hidden, and consistent (its bias
//! falls like `1/N`).
//!
//! Adaptive: every vertex first traces a pilot, a quarter of its samples
//! ([`EmitterLinkParams::pilot_share`]); where all the pilot's rays agree
//! (every point reached, or none) the ratio estimate above is already 1 or
//! 0 for every group and more rays would only confirm it, so the vertex
//! keeps it; a vertex in penumbra traces its full `samples` anew. Both
//! passes draw from the vertex's own seed (keyed by its position and
//! normal, [`Stream::point_seed`], so a vertex a refinement round keeps
//! draws what it drew before), so the answer is deterministic and
//! independent of batches and threads.
//!
//! Stored per vertex: `F_vg` for each emitter group `g` (the triangles of one mesh with one emission
//! when the links were built), so `E_em(v) = sum_g F_vg M_g` with the
//! groups' current exitance: changing an emitter's exitance needs no rays.
//!
//! Deviation from issue 17's first design (emitters' light through the
//! vertex links only): at 256 rays a vertex of `window` sees the lamp shade
//! with about 2 of its rays, and that noise held the total error at 7%
//! against the reference path tracer. Now the emitters' direct light is
//! this estimate and their vertices leave `M_e / pi` out of the first
//! radiosity (it would be counted twice); their reflected light still
//! travels through links. A mesh that starts emitting after the links were
//! built has no emitter group: its light travels through the vertex links
//! ([`EmitterLinks::carried_emission`]) until the next build. `E_em` is
//! part of the reported and exported `E_i` (emitters' light arrives after
//! leaving a surface, as in the reference path tracer).
//!
//! A triangle with the vertex as a corner lies in a plane through the
//! vertex and subtends nothing; on a curved emitter the vertex's own
//! triangles tilt a little above its tangent plane, and the thin band of
//! directions under them (which the vertex links record as self links)
//! gets the vertex's own emission times the band's share, by Lambert's
//! formula on the band ([`crate::solver::Solver::e_emitter`]). Without it
//! the emissive furnace (2562-vertex sphere) read `E` 0.17% low and the
//! inside of `window`'s lamp shade 0.3-0.6% low; with it the furnace is
//! exact to rounding (`tests/emission.rs`).
//!
//! Cost: one evaluation of Lambert's formula per vertex and emitter
//! triangle above its horizon (edge and corner terms shared between
//! triangles, `emitter_geometry`), and at most `samples + 1`
//! shadow rays per vertex. Above
//! [`EmitterLinkParams::max_pairs`] vertex-triangle pairs there are no
//! emitter links and every emitter's light travels through the vertex
//! links (documented fallback; [`EmitterLinks::fallback`] says why).

use super::emitter_geometry::{form_factor, polygon_point, Emitter, EmitterMesh, FormFactorScratch};
use crate::csr::{Csr, RowBuilder};
use crate::kdtree::traverse::Ray;
use crate::links::shoot::ray_origin;
use crate::sampling::stream::Stream;
use crate::scene::prep::PreparedScene;
use crate::trace::{Tracer, RAY_OFFSET};
use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::borrow::Cow;
use std::time::Instant;

/// Parameters of the emitter links.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterLinkParams {
    /// Shadow rays per vertex toward the emitters (0: no emitter links,
    /// emitters' light through the vertex links alone). Default 64;
    /// `SolveParams::from_settings` gives the vertex links' rays per vertex
    /// (at least 64), so this noise falls with theirs.
    pub samples: u32,
    /// Largest number of (vertex, emitter triangle) pairs evaluated; above
    /// it the emitters' light travels through the vertex links.
    pub max_pairs: u64,
    /// Origin nudge of crease and border vertices (as in [`crate::links::LinkParams`]).
    pub nudge: f32,
    /// The share of `samples` every vertex traces first (the pilot, at
    /// least [`MIN_PILOT`] rays): a vertex whose pilot rays all agree (all
    /// reach their emitter points, or none does) keeps the pilot's answer
    /// (every group in full view, or hidden); the others, in penumbra,
    /// trace all `samples`. 1 traces all `samples` at every vertex. The
    /// pilot misses an occluder that hides a share `s` of the emitters with
    /// probability about `(1 - s)^pilot` (for `s` = 10%: 0.1% at the
    /// default 64 pilot rays of 256 samples, 19% at the marking rounds' 16),
    /// so penumbra narrower than that may be read as full view or full
    /// shadow; in rooms most vertices see their emitters whole or not at
    /// all (Šibenik: 73% of those above an emitter's horizon;
    /// docs/REAL_SCENES.md) and trace a quarter of the rays.
    pub pilot_share: f32,
}

impl Default for EmitterLinkParams {
    fn default() -> Self {
        Self { samples: 64, max_pairs: 400_000_000, nudge: 1e-3, pilot_share: 0.25 }
    }
}

/// Fewest pilot rays a vertex decides on (fewer: every vertex traces all
/// its samples).
pub const MIN_PILOT: u32 = 16;

impl EmitterLinkParams {
    /// The pilot's rays a vertex, or `None` when every vertex traces all
    /// `samples` at once.
    pub fn pilot(&self) -> Option<u32> {
        let pilot = (self.samples as f64 * self.pilot_share.clamp(0.0, 1.0) as f64).ceil() as u32;
        (pilot >= MIN_PILOT && pilot < self.samples).then_some(pilot)
    }
}

/// Per-vertex emitter factors `F_vg` (see the module doc), in CSR form.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EmitterLinks {
    /// Per group, a vertex whose current emission is the group's exitance.
    pub group_vertex: Vec<u32>,
    /// Per vertex: its emission is carried by these links (it belongs to a
    /// group), so it is left out of the first radiosity.
    pub covered: Vec<bool>,
    /// Per vertex: the group of the emitter triangles it is a corner of
    /// when the links were built, [`NO_GROUP`] for others (empty when
    /// inactive).
    pub vertex_group: Vec<u32>,
    /// Per vertex, `(group, F_vg)` entries (`F_vg` unitless, finite, >= 0).
    pub rows: Csr<(u32, f32)>,
    /// Shadow rays traced toward the emitters.
    pub shadow_rays: u64,
    /// Vertices that traced all their samples after a pilot that did not
    /// agree ([`EmitterLinkParams::pilot_share`]), and vertices that had
    /// emitters above their horizon.
    pub penumbra: (u64, u64),
    /// Time of the computation, ms, and the part of it the tracer took
    /// to answer the shadow rays (the rest: form factors and sampling).
    pub ms: f64,
    /// The tracer's part of `ms`, ms.
    pub trace_ms: f64,
    /// Why there are no emitter links although some surface emits.
    pub fallback: Option<String>,
}

/// [`EmitterLinks::vertex_group`] of a vertex outside every group.
pub const NO_GROUP: u32 = u32::MAX;

/// A triangle a vertex sends rays to, and what its rays found.
#[derive(Clone, Copy, Debug)]
struct Pick {
    group: u32,
    /// `F_t / pi_t`.
    scale: f32,
    first_ray: u32,
    rays: u32,
}

/// One vertex's shadow rays, their weights, the triangles they go to and
/// the exact unshaded factor of every group it sees.
#[derive(Clone, Debug, Default)]
struct VertexRays {
    rays: Vec<Ray>,
    weights: Vec<f32>,
    picks: Vec<Pick>,
    /// `(group, F_g)` for the groups with `F_g > 0`.
    unshaded: Vec<(u32, f64)>,
}

/// Vertices per batch of shadow rays (bounds memory).
const CHUNK_VERTICES: usize = 8192;

impl EmitterLinks {
    /// The emitter links of `scene` traced with `tracer`; empty when nothing emits.
    pub fn compute(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &EmitterLinkParams,
        seed: u64,
    ) -> crate::Result<Self> {
        let start = Instant::now();
        let n = scene.vertex_count();
        let (emitters, group_vertex) = emitters(scene);
        let mut out = EmitterLinks { rows: Csr::empty_rows(n), covered: vec![false; n], ..Default::default() };
        if emitters.is_empty() || params.samples == 0 {
            return Ok(out);
        }
        let pairs = n as u64 * emitters.len() as u64;
        if pairs > params.max_pairs {
            out.fallback = Some(format!(
                "{n} vertices x {} emitter triangles = {pairs} pairs, above the limit of {}: emitters' light \
                 travels through the vertex links",
                emitters.len(),
                params.max_pairs
            ));
            return Ok(out);
        }
        out.group_vertex = group_vertex;
        out.vertex_group = vec![NO_GROUP; n];
        for e in &emitters {
            for &v in &scene.triangles[e.triangle as usize] {
                out.vertex_group[v as usize] = e.group;
            }
        }
        for t in &scene.triangles {
            if scene.emission[t[0] as usize] != Vec3::ZERO {
                for &v in t {
                    out.covered[v as usize] = true;
                }
            }
        }
        let mesh = EmitterMesh::new(scene, &emitters);
        let mut rows = RowBuilder::new();
        for first in (0..n).step_by(CHUNK_VERTICES) {
            let end = (first + CHUNK_VERTICES).min(n);
            let groups = out.group_vertex.len();
            let pass = |vertices: &[usize], samples: u32| -> crate::Result<(Vec<VertexRays>, Vec<bool>, f64)> {
                let per_vertex: Vec<VertexRays> = vertices
                    .par_iter()
                    .map_init(Scratch::default, |s, &v| {
                        vertex_rays(scene, &emitters, &mesh, groups, v, params, samples, seed, s)
                    })
                    .collect();
                let rays: Vec<Ray> = per_vertex.iter().flat_map(|r| r.rays.iter().copied()).collect();
                let traced = Instant::now();
                let visible = tracer.visible(&rays)?;
                Ok((per_vertex, visible, traced.elapsed().as_secs_f64() * 1e3))
            };
            let all: Vec<usize> = (first..end).collect();
            let pilot = params.pilot();
            let (per_vertex, visible, ms) = pass(&all, pilot.unwrap_or(params.samples))?;
            out.trace_ms += ms;
            out.shadow_rays += visible.len() as u64;
            // Per vertex its factors, or `None` while its pilot disagrees.
            let mut found: Vec<Option<Vec<(u32, f32)>>> = Vec::with_capacity(all.len());
            let mut at = 0usize;
            for r in &per_vertex {
                let vis = &visible[at..at + r.rays.len()];
                at += r.rays.len();
                let agree = vis.iter().all(|&x| x == vis[0]);
                out.penumbra.1 += u64::from(!vis.is_empty());
                found.push((pilot.is_none() || agree).then(|| finish_vertex(vis, r)));
            }
            let penumbra: Vec<usize> = all.iter().copied().filter(|&v| found[v - first].is_none()).collect();
            out.penumbra.0 += penumbra.len() as u64;
            if !penumbra.is_empty() {
                let (per_vertex, visible, ms) = pass(&penumbra, params.samples)?;
                out.trace_ms += ms;
                out.shadow_rays += visible.len() as u64;
                let mut at = 0usize;
                for (r, &v) in per_vertex.iter().zip(&penumbra) {
                    let vis = &visible[at..at + r.rays.len()];
                    at += r.rays.len();
                    found[v - first] = Some(finish_vertex(vis, r));
                }
            }
            for row in found {
                rows.extend(row.expect("every vertex decided"));
                rows.end_row();
            }
        }
        out.rows = rows.finish();
        out.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(out)
    }

    /// Vertex `v`'s `(group, F_vg)` entries.
    pub fn of(&self, v: usize) -> impl Iterator<Item = (u32, f32)> + '_ {
        self.rows.row(v).iter().copied()
    }

    /// True if some vertex has an emitter factor.
    pub fn is_active(&self) -> bool {
        !self.group_vertex.is_empty()
    }

    /// Direct irradiance from the emitters at every vertex, W/m^2:
    /// `E_em(v) = sum_g F_vg M_g`, `M_g` the current `emission` of the group's vertex.
    pub fn irradiance(&self, emission: &[Vec3], n: usize) -> Vec<Vec3> {
        if !self.is_active() {
            return vec![Vec3::ZERO; n];
        }
        let m: Vec<Vec3> = self.group_vertex.iter().map(|&v| emission[v as usize]).collect();
        (0..n).into_par_iter().map(|v| self.rows.row(v).iter().map(|&(g, f)| m[g as usize] * f).sum()).collect()
    }

    /// The emission the vertex links must carry: `emission` with the
    /// vertices of emitter groups set to zero (their direct light is [`Self::irradiance`]).
    pub fn carried_emission<'a>(&self, emission: &'a [Vec3]) -> Cow<'a, [Vec3]> {
        if !self.is_active() {
            return Cow::Borrowed(emission);
        }
        Cow::Owned(emission.iter().zip(&self.covered).map(|(e, &c)| if c { Vec3::ZERO } else { *e }).collect())
    }

    /// Checks the structure against a scene of `n` vertices: CSR offsets,
    /// group ids, finite non-negative factors.
    pub fn validate(&self, n: usize) -> Result<(), String> {
        if self.rows.rows() != n || self.covered.len() != n {
            return Err(format!("{} rows and {} covered flags for {n} vertices", self.rows.rows(), self.covered.len()));
        }
        let groups = self.group_vertex.len();
        self.rows.validate(n, |_, &(g, f)| {
            if g as usize >= groups || !(f.is_finite() && f >= 0.0) {
                return Err(format!("entry (group {g} of {groups}, factor {f})"));
            }
            Ok(())
        })?;
        if let Some(v) = self.group_vertex.iter().find(|&&v| v as usize >= n) {
            return Err(format!("group vertex {v} of {n}"));
        }
        if !(self.vertex_group.is_empty() || self.vertex_group.len() == n) {
            return Err(format!("{} vertex groups for {n} vertices", self.vertex_group.len()));
        }
        if let Some(g) = self.vertex_group.iter().find(|&&g| g != NO_GROUP && g as usize >= self.group_vertex.len()) {
            return Err(format!("vertex group {g} of {}", self.group_vertex.len()));
        }
        Ok(())
    }
}

/// Every emissive triangle with its group, and each group's vertex.
pub(crate) fn emitters(scene: &PreparedScene) -> (Vec<Emitter>, Vec<u32>) {
    let mut keys: Vec<(usize, [u32; 3])> = Vec::new();
    let mut group_vertex = Vec::new();
    let mut out = Vec::new();
    if scene.emission.iter().all(|e| *e == Vec3::ZERO) {
        return (out, group_vertex);
    }
    for (mi, m) in scene.meshes.iter().enumerate() {
        for tri in m.triangles.clone() {
            let t = scene.triangles[tri as usize];
            let e = scene.emission[t[0] as usize];
            if e == Vec3::ZERO {
                continue;
            }
            let key = (mi, e.to_array().map(f32::to_bits));
            let group = match keys.iter().position(|k| *k == key) {
                Some(g) => g,
                None => {
                    keys.push(key);
                    group_vertex.push(t[0]);
                    keys.len() - 1
                }
            };
            out.push(Emitter { corners: t.map(|i| scene.positions[i as usize]), group: group as u32, triangle: tri });
        }
    }
    (out, group_vertex)
}

/// Whether emitter `e`'s front (counter-clockwise side) faces the point `p`.
pub(crate) fn faces(e: &Emitter, p: Vec3) -> bool {
    let [a, b, c] = e.corners.map(|x| x.as_dvec3());
    (b - a).cross(c - a).dot(p.as_dvec3() - a) > 0.0
}

/// Per-thread buffers of [`vertex_rays`].
#[derive(Default)]
struct Scratch {
    form: FormFactorScratch,
    /// `F_t` per emitter triangle at the current vertex.
    f: Vec<f64>,
}

/// Vertex `v`'s `samples` shadow rays toward the emitters (of `groups`
/// groups; `mesh` is made of `emitters`).
#[allow(clippy::too_many_arguments)]
fn vertex_rays(
    scene: &PreparedScene,
    emitters: &[Emitter],
    mesh: &EmitterMesh,
    groups: usize,
    v: usize,
    params: &EmitterLinkParams,
    samples: u32,
    seed: u64,
    scratch: &mut Scratch,
) -> VertexRays {
    let (p, n) = (scene.positions[v], scene.normals[v]);
    mesh.form_factors(emitters, p, n, &mut scratch.form, &mut scratch.f);
    // Emitters are one-sided like every surface: a vertex behind an
    // emitter's plane (or in it) gets none of its light.
    for (e, f) in emitters.iter().zip(scratch.f.iter_mut()) {
        if *f > 0.0 && !faces(e, p) {
            *f = 0.0;
        }
    }
    let f = &scratch.f;
    // `F_sum` and each group's `F_g` summed in emitter order; zeros are
    // left out (adding +0 changes no sum), and the group at hand is
    // summed in a register.
    let (mut f_sum, mut f_group) = (0f64, vec![0f64; groups]);
    let mut at: Option<(u32, f64)> = None;
    for (e, &ft) in emitters.iter().zip(f) {
        if ft > 0.0 {
            f_sum += ft;
            let sum = match at {
                Some((g, ref mut sum)) if g == e.group => sum,
                _ => {
                    if let Some((g, sum)) = at {
                        f_group[g as usize] = sum;
                    }
                    &mut at.insert((e.group, f_group[e.group as usize])).1
                }
            };
            *sum += ft;
        }
    }
    if let Some((g, sum)) = at {
        f_group[g as usize] = sum;
    }
    let mut out = VertexRays::default();
    if !(f_sum > 0.0) {
        return out;
    }
    out.unshaded = f_group.iter().enumerate().filter(|(_, &x)| x > 0.0).map(|(g, &x)| (g as u32, x)).collect();
    let VertexRays { rays, weights, picks, .. } = &mut out;
    let mut rng = rand_pcg::Pcg32::seed_from_u64(Stream::EMITTER_LINKS.point_seed(seed, p, n));
    let xi: f64 = rng.random();
    let offset = Vec2::new(rng.random(), rng.random());
    let total = samples as f64;
    let origin = ray_origin(scene, v, params.nudge);
    let eps = RAY_OFFSET * scene.mean_edge_length(v).max(f32::MIN_POSITIVE);
    // Triangle t covers [lo, hi) of the `total` samples; its `lo` is the
    // `hi` of the triangle before it, so its rounding is carried over.
    let mut below = 0.0;
    let mut lo_up = (below / f_sum * total - xi).ceil();
    for (e, &ft) in emitters.iter().zip(f) {
        if ft <= 0.0 {
            continue;
        }
        let hi = (below + ft) / f_sum * total;
        below += ft;
        let hi_up = (hi - xi).ceil();
        let count = (hi_up - lo_up).max(0.0) as u32;
        lo_up = hi_up;
        if count == 0 {
            continue;
        }
        let (_, poly, m) = form_factor(p, n, &e.corners);
        let pi_t = (total * ft / f_sum).min(1.0);
        picks.push(Pick { group: e.group, scale: (ft / pi_t) as f32, first_ray: rays.len() as u32, rays: 0 });
        let pick = picks.last_mut().expect("pushed");
        let en = (e.corners[1] - e.corners[0]).cross(e.corners[2] - e.corners[0]).normalize_or_zero();
        for j in 0..count {
            // R2 low-discrepancy points, rotated per vertex: stratified on the triangle.
            let u = (offset + Vec2::new(0.754_877_7, 0.569_840_3) * (j + 1) as f32).fract();
            let y = (p.as_dvec3() + polygon_point(&poly[..m], u)).as_vec3();
            let d = y - p;
            let r2 = d.length_squared();
            let w = if r2 > 0.0 { n.dot(d).max(0.0) * en.dot(d).abs() / (r2 * r2) } else { 0.0 };
            let to = y - origin;
            let dist = to.length();
            let dir = to / dist.max(f32::MIN_POSITIVE);
            pick.rays += 1;
            weights.push(w);
            if dist <= 2.0 * eps || !dir.is_finite() {
                // The point touches the origin: nothing can lie in between.
                rays.push(Ray { origin, dir: n, tmin: 0.0, tmax: 0.0, skip: v as u32 });
                continue;
            }
            rays.push(Ray::shadow(origin, dir, dist, eps, eps, v as u32));
        }
    }
    out
}

/// `F_vg` of one vertex from its rays' visibility: `(group, factor)` pairs.
fn finish_vertex(visible: &[bool], r: &VertexRays) -> Vec<(u32, f32)> {
    // Per group: sum of F_t / pi_t times the visible share, and of F_t / pi_t.
    let mut sums: Vec<(u32, f64, f64)> = Vec::new();
    for p in &r.picks {
        let span = p.first_ray as usize..(p.first_ray + p.rays) as usize;
        let (mut seen, mut all, mut hits) = (0f64, 0f64, 0u32);
        for (&vis, &w) in visible[span.clone()].iter().zip(&r.weights[span]) {
            all += w as f64;
            if vis {
                seen += w as f64;
                hits += 1;
            }
        }
        let share = if all > 0.0 { seen / all } else { hits as f64 / p.rays.max(1) as f64 };
        let scale = p.scale as f64;
        match sums.iter_mut().find(|e| e.0 == p.group) {
            Some(e) => {
                e.1 += scale * share;
                e.2 += scale;
            }
            None => sums.push((p.group, scale * share, scale)),
        }
    }
    let (num, den) = sums.iter().fold((0.0, 0.0), |a, e| (a.0 + e.1, a.1 + e.2));
    let overall = if den > 0.0 { num / den } else { 0.0 };
    r.unshaded
        .iter()
        .filter_map(|&(g, f_g)| {
            let share = sums.iter().find(|e| e.0 == g).map_or(overall, |e| e.1 / e.2);
            let f = (f_g * share) as f32;
            (f > 0.0).then_some((g, f))
        })
        .collect()
}
