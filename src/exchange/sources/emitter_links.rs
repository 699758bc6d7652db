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
//! normal, [`crate::sampling::stream::Stream::point_seed`], so a vertex a refinement round keeps
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

use super::emitter_geometry::{Emitter, EmitterMesh};
use super::emitter_rays::{finish_vertex, vertex_rays, Scratch, VertexRays};
use crate::csr::{Csr, RowBuilder};
use crate::trace::ray::Ray;
use crate::links::Lineage;
use crate::scene::prep::PreparedScene;
use crate::trace::Tracer;
use glam::Vec3;
use rayon::prelude::*;
use std::borrow::Cow;
use std::time::Instant;

/// Parameters of the emitter links.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterLinkParams {
    /// Shadow rays per vertex toward the emitters, at least 1 (the
    /// `emitter_links` term switches them off: emitters' light then goes
    /// through the vertex links alone). Default 64;
    /// `SolveParams::from_settings` gives the vertex links' rays per vertex
    /// (at least 64), so this noise falls with theirs.
    pub samples: u32,
    /// Largest number of (vertex, emitter triangle) pairs evaluated; above
    /// it the emitters' light travels through the vertex links.
    pub max_pairs: u64,
    /// Origin nudge of crease and border vertices (as in [`crate::links::LinkParams`]).
    pub nudge: f32,
    /// The share of `samples` every vertex traces first (the pilot, at
    /// least `MIN_PILOT` rays): a vertex whose pilot rays all agree (all
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

impl EmitterLinkParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: EmitterLinkParams = Self { samples: 64, max_pairs: 400_000_000, nudge: 1e-3, pilot_share: 0.25 };
}

impl Default for EmitterLinkParams {
    fn default() -> Self {
        Self::DEFAULT
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

/// Vertices per batch of shadow rays (bounds memory).
const CHUNK_VERTICES: usize = 8192;

impl EmitterLinks {
    /// No emitter links for `n` vertices (nothing emits, or the
    /// `emitter_links` term is off): every vertex's row empty, none covered.
    pub fn none(n: usize) -> EmitterLinks {
        EmitterLinks { rows: Csr::empty_rows(n), covered: vec![false; n], ..Default::default() }
    }

    /// The emitter links of `scene` traced with `tracer`; empty when nothing emits.
    pub fn compute(
        scene: &PreparedScene,
        tracer: &dyn Tracer,
        params: &EmitterLinkParams,
        seed: u64,
    ) -> crate::Result<Self> {
        let start = Instant::now();
        let n = scene.vertex_count();
        let (emitters, group_vertex) = emitters_of(scene);
        let mut out = EmitterLinks::none(n);
        if emitters.is_empty() {
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
        out.set_groups(scene, &emitters, group_vertex);
        let all: Vec<usize> = (0..n).collect();
        let found = out.trace_vertices(scene, &emitters, &all, tracer, params, seed)?;
        let mut rows = RowBuilder::new();
        for row in found {
            rows.extend(row);
            rows.end_row();
        }
        out.rows = rows.finish();
        out.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(out)
    }

    /// The emitter links of `scene`, a split of `old_scene` (a refinement
    /// round) whose links `old` were traced with the same `params` and
    /// `seed`, by `lineage`. A kept vertex whose one-ring no split touched
    /// ([`Lineage::whole`]: the same position, normal, incident triangles,
    /// so the same ray offset) and whose ray origin is the same keeps its
    /// row; the others trace.
    /// The result equals [`EmitterLinks::compute`] on `scene` bit for bit:
    /// a kept vertex draws the samples it drew (its seed is its position's
    /// and normal's), toward the same emitter triangles, and a split leaves
    /// every surface where it was, so its shadow rays meet what they met
    /// (`tests/refine.rs` compares every round). Where the emitters
    /// changed (an emitter triangle split), everything is traced anew.
    /// Returns the links and the number of vertices that kept their rows.
    pub fn after_split(
        old: &EmitterLinks,
        old_scene: &PreparedScene,
        scene: &PreparedScene,
        lineage: &Lineage,
        tracer: &dyn Tracer,
        params: &EmitterLinkParams,
        seed: u64,
    ) -> crate::Result<(Self, u64)> {
        let start = Instant::now();
        let n = scene.vertex_count();
        let (emitters, group_vertex) = emitters_of(scene);
        let (before, _) = emitters_of(old_scene);
        let same = old.is_active()
            && old.fallback.is_none()
            && lineage.kept.len() == n
            && n as u64 * emitters.len() as u64 <= params.max_pairs
            && group_vertex.len() == old.group_vertex.len()
            && emitters.len() == before.len()
            && emitters.iter().zip(&before).all(|(a, b)| a.corners == b.corners && a.group == b.group);
        if !same {
            return Ok((Self::compute(scene, tracer, params, seed)?, 0));
        }
        let mut out = EmitterLinks { covered: vec![false; n], ..Default::default() };
        out.set_groups(scene, &emitters, group_vertex);
        let carried = lineage.carried(old_scene, scene, params.nudge);
        let rest: Vec<usize> = (0..n).filter(|&w| carried[w].is_none()).collect();
        let mut traced = out.trace_vertices(scene, &emitters, &rest, tracer, params, seed)?.into_iter();
        let mut rows = RowBuilder::new();
        for c in &carried {
            match c {
                Some(v) => rows.extend(old.rows.row(*v).iter().copied()),
                None => rows.extend(traced.next().expect("a row per traced vertex")),
            }
            rows.end_row();
        }
        out.rows = rows.finish();
        out.ms = start.elapsed().as_secs_f64() * 1e3;
        Ok((out, (n - rest.len()) as u64))
    }

    /// The groups of `emitters` (each group's vertex `group_vertex`), every
    /// vertex's group and whether its emission is covered.
    fn set_groups(&mut self, scene: &PreparedScene, emitters: &[Emitter], group_vertex: Vec<u32>) {
        self.group_vertex = group_vertex;
        self.vertex_group = vec![NO_GROUP; scene.vertex_count()];
        for e in emitters {
            for &v in &scene.triangles[e.triangle as usize] {
                self.vertex_group[v as usize] = e.group;
            }
        }
        for t in &scene.triangles {
            if scene.emission[t[0] as usize] != Vec3::ZERO {
                for &v in t {
                    self.covered[v as usize] = true;
                }
            }
        }
    }

    /// The `(group, F_vg)` entries of `vertices` (in their order), traced
    /// by chunks: a pilot at every vertex, all samples where it disagrees.
    /// Counts the shadow rays, the penumbra and the tracer's time in `self`.
    fn trace_vertices(
        &mut self,
        scene: &PreparedScene,
        emitters: &[Emitter],
        vertices: &[usize],
        tracer: &dyn Tracer,
        params: &EmitterLinkParams,
        seed: u64,
    ) -> crate::Result<Vec<Vec<(u32, f32)>>> {
        let mesh = EmitterMesh::new(scene, emitters);
        let groups = self.group_vertex.len();
        let pass = |vertices: &[usize], samples: u32| -> crate::Result<(Vec<VertexRays>, Vec<bool>, f64)> {
            let per_vertex: Vec<VertexRays> = vertices
                .par_iter()
                .map_init(Scratch::default, |s, &v| {
                    vertex_rays(scene, emitters, &mesh, groups, v, params.nudge, samples, seed, s)
                })
                .collect();
            let rays: Vec<Ray> = per_vertex.iter().flat_map(|r| r.rays.iter().copied()).collect();
            let traced = Instant::now();
            let visible = tracer.visible(&rays)?;
            Ok((per_vertex, visible, traced.elapsed().as_secs_f64() * 1e3))
        };
        let pilot = params.pilot();
        let mut out = Vec::with_capacity(vertices.len());
        for chunk in vertices.chunks(CHUNK_VERTICES) {
            let (per_vertex, visible, ms) = pass(chunk, pilot.unwrap_or(params.samples))?;
            self.trace_ms += ms;
            self.shadow_rays += visible.len() as u64;
            // Per vertex its factors, or `None` while its pilot disagrees.
            let mut found: Vec<Option<Vec<(u32, f32)>>> = Vec::with_capacity(chunk.len());
            let mut at = 0usize;
            for r in &per_vertex {
                let vis = &visible[at..at + r.rays.len()];
                at += r.rays.len();
                let agree = vis.iter().all(|&x| x == vis[0]);
                self.penumbra.1 += u64::from(!vis.is_empty());
                found.push((pilot.is_none() || agree).then(|| finish_vertex(vis, r)));
            }
            let penumbra: Vec<usize> = (0..chunk.len()).filter(|&i| found[i].is_none()).collect();
            self.penumbra.0 += penumbra.len() as u64;
            if !penumbra.is_empty() {
                let again: Vec<usize> = penumbra.iter().map(|&i| chunk[i]).collect();
                let (per_vertex, visible, ms) = pass(&again, params.samples)?;
                self.trace_ms += ms;
                self.shadow_rays += visible.len() as u64;
                let mut at = 0usize;
                for (r, &i) in per_vertex.iter().zip(&penumbra) {
                    let vis = &visible[at..at + r.rays.len()];
                    at += r.rays.len();
                    found[i] = Some(finish_vertex(vis, r));
                }
            }
            out.extend(found.into_iter().map(|row| row.expect("every vertex decided")));
        }
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
pub(crate) fn emitters_of(scene: &PreparedScene) -> (Vec<Emitter>, Vec<u32>) {
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
            out.push(Emitter::new(t.map(|i| scene.positions[i as usize]), group as u32, tri));
        }
    }
    (out, group_vertex)
}
