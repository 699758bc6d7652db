//! CPU ray shooting (rayon): every vertex traces the direction set in its
//! rotated frame from its origin; hits stream into merged link groups batch
//! by batch, so raw hits for the whole scene are never held at once.
//!
//! Origins (docs/DESIGN.md §3): a vertex inside a smooth surface shoots from its
//! own position and skips its incident triangles. A crease or border vertex
//! shoots from a point moved `nudge * l` (l: mean incident edge length)
//! toward its own one-ring along the surface and the same distance off it
//! along the normal, so rays aimed at the face group on the other side of
//! the crease land on it instead of slipping through at `t = 0`. A buried
//! vertex (inside another part of the model) shoots from a point of its
//! own faces out in the open ([`super::buried`]).
//!
//! Rays under the surface: the vertex normal is an average, so on a concave
//! (or saddle) vertex a grazing direction can lie above the tangent plane
//! yet below one of the incident triangles. Such a ray would pass through
//! that (skipped) triangle at `t = 0` and leave the surface, escaping a
//! closed scene. It is recorded instead as a hit at the vertex itself (a
//! self link): a grazing ray in a concave region meets the surface right
//! next to its origin, where the radiosity is the vertex's own.

use super::assemble::{CsrBuilder, GroupRun};
use super::merge::RayHits;
use super::merge::{HitRecord, HIT_BACK};
use super::Links;
use crate::trace::ray::Hit;
use crate::sampling::{vertex_frame, vertex_rotations_and_sets, world_direction, DirectionSet};
use crate::scene::prep::PreparedScene;
use crate::trace::{CpuTracer, OriginRays, Tracer};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::time::Instant;

/// Parameters of link generation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LinkParams {
    /// Rays per vertex, `k*k`.
    pub rays_per_vertex: u32,
    /// Seed of the direction set and the rotations.
    pub seed: u64,
    /// Origin offset of crease and border vertices, as a fraction of their mean edge length.
    pub nudge: f32,
    /// Vertices per streamed batch (bounds the memory of raw hits).
    pub batch_vertices: usize,
    /// Which rays are recorded as near hits (`super::near`).
    pub near: super::near::NearParams,
}

impl LinkParams {
    /// The defaults (each field's doc gives its effect and trade-off);
    /// `const`, so presets built from it are `const fn`.
    pub const DEFAULT: LinkParams = Self {
        rays_per_vertex: 256,
        seed: 1,
        nudge: 1e-3,
        batch_vertices: 8192,
        near: super::near::NearParams::DEFAULT,
    };
}

impl Default for LinkParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// One incident triangle seen from a vertex: its unit normal, its two
/// edges leaving the vertex (counter-clockwise), its id and the vertex's
/// corner in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wedge {
    /// The triangle's unit normal.
    pub normal: Vec3,
    /// The triangle's first edge leaving the vertex (counter-clockwise order).
    pub edge_a: Vec3,
    /// The triangle's second edge leaving the vertex.
    pub edge_b: Vec3,
    /// The triangle's id.
    pub tri: u32,
    /// The vertex's corner in the triangle (0, 1 or 2).
    pub corner: u32,
}

impl Wedge {
    /// True if `d` leaves the vertex into the back of this triangle.
    #[inline]
    pub fn dives_under(&self, d: Vec3) -> bool {
        let dn = d.dot(self.normal);
        if dn >= 0.0 {
            return false;
        }
        let dp = d - self.normal * dn;
        self.edge_a.cross(dp).dot(self.normal) >= 0.0 && dp.cross(self.edge_b).dot(self.normal) >= 0.0
    }

    /// The wedge of triangle `t` at its corner `v`.
    pub fn of(scene: &PreparedScene, v: usize, t: u32) -> Wedge {
        let tri = scene.triangles[t as usize];
        let corner = tri.iter().position(|&i| i as usize == v).expect("incident") as u32;
        let p = |k: u32| scene.positions[tri[((corner + k) % 3) as usize] as usize];
        let (edge_a, edge_b) = (p(1) - p(0), p(2) - p(0));
        let normal = edge_a.cross(edge_b).normalize_or_zero();
        Wedge { normal, edge_a, edge_b, tri: t, corner }
    }

    /// The cosine-weighted share (unitless, of the hemisphere about unit
    /// `n`) of the directions that dive under this wedge
    /// ([`Wedge::dives_under`]): the spherical triangle `(a, b, -normal)`
    /// (`a`, `b` the edge directions), clipped to `n . d >= 0`, by
    /// Lambert's formula `1/(2 pi) |sum_k gamma_k n . c_k|` (as
    /// [`crate::exchange::sources::emitter_links`]). In f64: the share is small
    /// beside the terms that cancel in the sum.
    pub fn dive_share(&self, n: Vec3) -> f32 {
        let (a, b, t) = (self.edge_a.as_dvec3(), self.edge_b.as_dvec3(), self.normal.as_dvec3());
        let n = n.as_dvec3();
        if a.length_squared() == 0.0 || b.length_squared() == 0.0 || t.length_squared() == 0.0 {
            return 0.0;
        }
        // Sutherland-Hodgman against the plane n . d = 0 (a corner within
        // 1e-9 of it counts as under: a flat vertex's band is empty, not
        // rounding); an arc P -> Q meets it at normalize(|n.Q| P + |n.P| Q).
        let poly = [a.normalize(), b.normalize(), -t];
        let above = |s: f64| s > 1e-9;
        let mut clipped: Vec<DVec3> = Vec::with_capacity(4);
        for k in 0..3 {
            let (p, q) = (poly[k], poly[(k + 1) % 3]);
            let (sp, sq) = (n.dot(p), n.dot(q));
            if above(sp) {
                clipped.push(p);
            }
            if above(sp) != above(sq) {
                clipped.push((p * sq.abs() + q * sp.abs()).normalize());
            }
        }
        if clipped.len() < 3 {
            return 0.0;
        }
        let mut sum = 0.0;
        for k in 0..clipped.len() {
            let (p, q) = (clipped[k], clipped[(k + 1) % clipped.len()]);
            let c = p.cross(q);
            let len = c.length();
            if len > 0.0 {
                sum += p.dot(q).clamp(-1.0, 1.0).acos() * n.dot(c / len);
            }
        }
        (sum.abs() / (2.0 * std::f64::consts::PI)) as f32
    }

    /// The hit record of a ray that dives under this wedge: the vertex's corner, `t = 0`.
    pub fn self_hit(&self) -> HitRecord {
        let (u, v) = match self.corner {
            0 => (0.0, 0.0),
            1 => (1.0, 0.0),
            _ => (0.0, 1.0),
        };
        HitRecord { tri: self.tri, u, v, t: 0.0 }
    }
}

/// Everything a shooter (CPU or GPU) needs per vertex: origin, rotated
/// frame, incident-triangle wedges, and the shared local direction set.
#[derive(Clone, Debug)]
pub struct RaySetup {
    /// Ray origin of each vertex, metres ([`ray_origin`]).
    pub origins: Vec<Vec3>,
    /// Rotation about the normal, radians.
    pub rotations: Vec<f32>,
    /// Which of the direction sets each vertex shoots ([`crate::sampling::vertex_rotations_and_sets`]).
    pub sets: Vec<u32>,
    /// Unit normal of each vertex.
    pub normals: Vec<Vec3>,
    /// Wedges of vertex `v`: `wedges[wedge_offsets[v]..wedge_offsets[v+1]]`.
    pub wedge_offsets: Vec<u32>,
    /// The incident-triangle wedges of all vertices, vertex after vertex.
    pub wedges: Vec<Wedge>,
    /// The shared local direction set (cosine-distributed, `k * k` rays).
    pub directions: DirectionSet,
}

impl RaySetup {
    /// The setup of every vertex of `scene`: ray origins, wedges, rotations and the direction set of `params`.
    pub fn new(scene: &PreparedScene, params: &LinkParams) -> RaySetup {
        let k = (params.rays_per_vertex as f64).sqrt().round() as u32;
        let origins = (0..scene.vertex_count()).map(|v| ray_origin(scene, v, params.nudge)).collect();
        let mut wedges = Vec::with_capacity(scene.vertex_triangles.items.len());
        for v in 0..scene.vertex_count() {
            wedges.extend(scene.vertex_triangles.row(v).iter().map(|&t| Wedge::of(scene, v, t)));
        }
        let (rotations, sets) = vertex_rotations_and_sets(&scene.colours, params.seed);
        RaySetup {
            origins,
            rotations,
            sets,
            normals: scene.normals.clone(),
            wedge_offsets: scene.vertex_triangles.offsets.clone(),
            wedges,
            directions: DirectionSet::new(k, params.seed),
        }
    }

    /// Wedges of vertex `v`.
    #[inline]
    pub fn wedges(&self, v: usize) -> &[Wedge] {
        &self.wedges[self.wedge_offsets[v] as usize..self.wedge_offsets[v + 1] as usize]
    }

    /// World directions of all rays of vertex `v`, in ray order (the frame
    /// is computed once).
    #[inline]
    pub fn world_directions(&self, v: usize) -> impl Iterator<Item = Vec3> + '_ {
        let (frame, local) = self.local_directions(v);
        local.iter().map(move |d| world_direction(frame, *d))
    }

    /// Vertex `v`'s frame (tangent, bitangent, normal) and its rays'
    /// directions in that frame, in ray order
    /// ([`crate::sampling::world_direction`] turns one into the world's).
    #[inline]
    pub fn local_directions(&self, v: usize) -> ((Vec3, Vec3, Vec3), &[Vec3]) {
        (vertex_frame(self.normals[v], self.rotations[v]), self.directions.set(self.sets[v]))
    }

    /// Traces all rays of vertex `v` with `tracer` into `out` (one record per ray).
    #[cfg(any(test, feature = "internals"))]
    pub fn trace_vertex(&self, tracer: &dyn CpuTracer, v: usize, out: &mut Vec<HitRecord>) {
        self.trace_vertex_with(tracer, v, &mut TraceScratch::default(), out)
    }

    /// [`RaySetup::trace_vertex`] reusing `scratch` between calls. Rays
    /// that dive under an incident triangle become self hits without
    /// tracing; the others go to the tracer together
    /// ([`CpuTracer::intersect_origin`]), which may share work between rays
    /// of one origin.
    pub fn trace_vertex_with(
        &self,
        tracer: &dyn CpuTracer,
        v: usize,
        scratch: &mut TraceScratch,
        out: &mut Vec<HitRecord>,
    ) {
        out.clear();
        scratch.dirs.clear();
        let wedges = self.wedges(v);
        for dir in self.world_directions(v) {
            if let Some(w) = wedges.iter().find(|w| w.dives_under(dir)) {
                out.push(w.self_hit());
            } else {
                out.push(HitRecord { tri: TO_TRACE, ..Default::default() });
                scratch.dirs.push(dir);
            }
        }
        let dirs = std::mem::take(&mut scratch.dirs);
        self.trace_dirs(tracer, v, &dirs, scratch, out);
        scratch.dirs = dirs;
    }

    /// Traces `dirs` from vertex `v`'s origin together
    /// ([`CpuTracer::intersect_origin`]) into the records of `out` marked
    /// [`TO_TRACE`], in order (one direction each).
    pub(super) fn trace_dirs(
        &self,
        tracer: &dyn CpuTracer,
        v: usize,
        dirs: &[Vec3],
        scratch: &mut TraceScratch,
        out: &mut [HitRecord],
    ) {
        scratch.hits.clear();
        scratch.hits.resize(dirs.len(), None);
        tracer.intersect_origin(self.origins[v], v as u32, dirs, &mut scratch.hits);
        let mut traced = scratch.hits.iter();
        for rec in out.iter_mut().filter(|r| r.tri == TO_TRACE) {
            *rec = HitRecord::of(traced.next().copied().flatten());
        }
    }

    /// The rays of `vertices` as one batch ([`Tracer::origin_rays`]).
    pub fn origin_rays(&self, vertices: &[u32]) -> OriginRays {
        let at = |v: &u32| *v as usize;
        OriginRays {
            origins: vertices.iter().map(|v| self.origins[at(v)]).collect(),
            skip: vertices.to_vec(),
            frames: vertices.iter().map(|v| vertex_frame(self.normals[at(v)], self.rotations[at(v)])).collect(),
            sets: vertices.iter().map(|v| self.sets[at(v)]).collect(),
            directions: self.directions.dirs.clone(),
            per_origin: self.directions.len(),
        }
    }

    /// The hit records of every ray of `vertices`, traced by `tracer` as
    /// one batch ([`Tracer::origin_rays`]), vertex after vertex: those of
    /// [`RaySetup::trace_vertex`] (rays that dive under an incident
    /// triangle are its self hits, [`RaySetup::self_hits`]).
    pub fn trace_vertices(&self, tracer: &dyn Tracer, vertices: &[u32]) -> crate::Result<Vec<HitRecord>> {
        let hits = tracer.origin_rays(&self.origin_rays(vertices))?;
        let mut out: Vec<HitRecord> = hits.into_iter().map(HitRecord::of).collect();
        let n = self.directions.len().max(1);
        out.par_chunks_mut(n).zip(vertices.par_iter()).for_each(|(recs, &v)| self.self_hits(v as usize, recs));
        Ok(out)
    }

    /// Replaces the records of vertex `v`'s rays (`hits`, in ray order)
    /// that dive under an incident triangle by its self hits, as
    /// [`RaySetup::trace_vertex`] decides before tracing: a tracer that
    /// traced them anyway (the GPU) gives the same records.
    pub fn self_hits(&self, v: usize, hits: &mut [HitRecord]) {
        let wedges = self.wedges(v);
        for (h, d) in hits.iter_mut().zip(self.world_directions(v)) {
            if let Some(w) = wedges.iter().find(|w| w.dives_under(d)) {
                *h = w.self_hit();
            }
        }
    }
}

/// Marks a record still to be traced (never a triangle id: ids stay below `HIT_BACK`).
pub(super) const TO_TRACE: u32 = HIT_BACK - 1;

/// Buffers [`RaySetup::trace_vertex_with`] reuses from vertex to vertex.
#[derive(Clone, Debug, Default)]
pub struct TraceScratch {
    dirs: Vec<Vec3>,
    hits: Vec<Option<Hit>>,
}

/// The cosine-weighted share of vertex `v`'s hemisphere (about its
/// normal) whose directions dive under one of its own triangles: the band
/// its self links cover (see the module doc), summed over its wedges
/// ([`Wedge::dive_share`]; 0 on flat and convex vertices).
pub fn dive_share(scene: &PreparedScene, v: usize) -> f32 {
    let n = scene.normals[v];
    scene.vertex_triangles.row(v).iter().map(|&t| Wedge::of(scene, v, t).dive_share(n)).sum()
}

/// The ray origin of vertex `v` (see the module doc): a buried vertex's
/// point in the open ([`super::buried`]), else [`plain_origin`].
pub fn ray_origin(scene: &PreparedScene, v: usize, nudge: f32) -> Vec3 {
    match scene.moved_origins.binary_search_by_key(&(v as u32), |e| e.0) {
        Ok(i) => scene.moved_origins[i].1,
        Err(_) => plain_origin(scene, v, nudge),
    }
}

/// The ray origin of vertex `v` at its position: the position itself, or
/// nudged into its faces and off them at a crease or border (module doc).
pub fn plain_origin(scene: &PreparedScene, v: usize, nudge: f32) -> Vec3 {
    let p = scene.positions[v];
    if !scene.boundary[v] {
        return p;
    }
    let n = scene.normals[v];
    let ring = scene.rings.row(v);
    let l = scene.mean_edge_length(v);
    let toward: Vec3 = ring.iter().map(|&u| (scene.positions[u as usize] - p).normalize_or_zero()).sum();
    let inward = (toward - n * toward.dot(n)).normalize_or_zero();
    // At least a few ulps of the coordinates, so the offset survives rounding.
    let d = (nudge * l).max(p.abs().max_element() * 8.0 * f32::EPSILON);
    p + (inward + n) * d
}

/// What a link build keeps beside the links.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Recording {
    /// The near hits ([`super::near`]; the solve's `near` term).
    pub near: bool,
    /// Every ray's hit id ([`RayHits`]): the state of selective updates
    /// ([`super::selective`]) and of refinement ([`super::reassign`]).
    pub ray_hits: bool,
}

/// Shoots every vertex's rays with a CPU tracer and builds the merged links
/// with their near hits. `progress(done, total)` is called after each batch.
#[cfg(any(test, feature = "internals"))]
pub fn shoot_links(
    scene: &PreparedScene,
    tracer: &dyn CpuTracer,
    params: &LinkParams,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Links {
    shoot_links_recording(scene, tracer, params, Recording { near: true, ray_hits: false }, progress).0
}

/// [`shoot_links`], keeping the near hits and every ray's hit id as `keep` says.
pub fn shoot_links_recording(
    scene: &PreparedScene,
    tracer: &dyn CpuTracer,
    params: &LinkParams,
    keep: Recording,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> (Links, Option<RayHits>) {
    let setup = RaySetup::new(scene, params);
    links_from_records(scene, &setup, params, keep, progress, &|v, scratch, hits| {
        setup.trace_vertex_with(tracer, v, scratch, hits)
    })
}

/// The merged links of every vertex of `scene` from its rays' hit records,
/// which `fill(v, scratch, out)` writes into `out` (one per ray of
/// `setup`, in ray order): the one merge every link build goes through
/// (tracing, or re-assigning hits after refinement), so records that are
/// equal give links that are equal. `progress(done, total)` is called
/// after each batch of `params.batch_vertices`.
pub(super) fn links_from_records(
    scene: &PreparedScene,
    setup: &RaySetup,
    params: &LinkParams,
    keep: Recording,
    progress: &(dyn Fn(usize, usize) + Sync),
    fill: &(dyn Fn(usize, &mut TraceScratch, &mut Vec<HitRecord>) + Sync),
) -> (Links, Option<RayHits>) {
    let record = keep.ray_hits;
    let start = Instant::now();
    let n = scene.vertex_count();
    let rays = setup.directions.len();
    let weight_per_ray = std::f64::consts::PI / rays as f64;
    let mut csr = CsrBuilder::new(n);
    let mut ids = Vec::with_capacity(if record { n * rays } else { 0 });
    let near = keep.near.then(|| super::near::NearRule::new(scene, rays as u32, params)).flatten();
    const CHUNK: usize = 32;
    for batch_start in (0..n).step_by(params.batch_vertices.max(1)) {
        let batch_end = (batch_start + params.batch_vertices.max(1)).min(n);
        let chunks: Vec<(GroupRun, Vec<u32>)> = (batch_start..batch_end)
            .step_by(CHUNK)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|c0| {
                let mut hits = Vec::with_capacity(rays);
                let mut scratch = TraceScratch::default();
                let run = if record { GroupRun::recording(c0) } else { GroupRun::new(c0) };
                let mut run = run.with_near(near.clone());
                let mut chunk_ids = Vec::new();
                for v in c0..(c0 + CHUNK).min(batch_end) {
                    fill(v, &mut scratch, &mut hits);
                    debug_assert_eq!(hits.len(), rays);
                    if record {
                        chunk_ids.extend(hits.iter().map(|h| h.tri));
                    }
                    run.push_vertex(&hits, &scene.triangles, weight_per_ray);
                }
                (run, chunk_ids)
            })
            .collect();
        // Into the CSR arrays batch by batch: only one batch's runs are held beside them.
        for (c, chunk_ids) in chunks {
            csr.push(c).expect("chunks come in vertex order");
            ids.extend(chunk_ids);
        }
        progress(batch_end, n);
    }
    let sums = csr.take_sums();
    let links = csr.finish(n, start.elapsed().as_secs_f64() * 1e3).expect("the runs cover every vertex once");
    (links, record.then_some(RayHits { rays_per_vertex: rays, ids, sums }))
}
