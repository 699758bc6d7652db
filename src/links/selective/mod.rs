//! Selective re-shooting of vertex links after a deformation (docs/DESIGN.md
//! §7): only the rays a deformation can have changed are traced again, and
//! only the link groups whose hits changed are rebuilt. Selective photon
//! tracing (Dmitriev et al. 2002) does this for photon paths; here it is
//! done for vertex links, exactly: the result equals a full re-shoot with
//! the same seed (same hits, so the same merged groups bit for bit).
//!
//! State ([`super::RayHits`]), kept only for scenes with dynamic meshes: the id of
//! every ray's hit (triangle id, `| HIT_BACK` for a back face, or
//! `HIT_MISS`), 4 bytes a ray, and every link's fixed-point sum
//! ([`super::merge`]), 4 bytes a link. Barycentrics and distances are not
//! stored: an old hit is recomputed with one watertight triangle test
//! ([`crate::trace::ray::intersect`], the test every tracer uses) on
//! the triangle where it was (old positions for a moved triangle), so it
//! is bit for bit the traced one.
//!
//! Which rays ([`reshoot`], with a [`Motion`]):
//! - a remade vertex (moved, or next to something that moved) traces all
//!   its rays;
//! - any other vertex keeps its directions, origin and wedges. Its ray can
//!   only change if the old hit lies on a moved triangle, or if a moved
//!   triangle in its new place lies on the segment from the origin to the
//!   old hit (`t` in `[0, t_old]`, to infinity for a miss). A moved
//!   triangle's old place need not be tested: had it been on the segment,
//!   the old hit would be on it. The segment is tested against the box of
//!   the moved triangles first, then against a small BVH over them;
//!   vertices that see the boxes only below their tangent plane are
//!   skipped whole, and of the others only the directions in the cone
//!   that can meet the boxes' union are looked at (one dot product a ray
//!   in the vertex frame; the cone bounds the box's sphere, with a margin
//!   of 1e-4 in cosine). Rays that dive under an incident triangle (self
//!   hits) depend on nothing that moved.
//!
//! A vertex whose re-traced rays all hit what they hit before (same
//! triangle, same barycentrics) keeps its group. The others are patched:
//! the changed rays' old corner weights are subtracted from the group's
//! fixed-point sums and their new ones added (integer sums do not depend on
//! the order of the rays), then the group is requantized to f16
//! ([`super::merge::requantize`]): the group a full merge of all the rays
//! gives, bit for bit. Remade vertices merge all their rays anew.
//!
//! On the GPU path the same rays are traced on the GPU, in two batches,
//! before the same merges and patches (`batch.rs`).

use super::merge::{
    corner_weights, fixed_scale, merge_vertex_sums, requantize, HitRecord, MergeScratch, RayHits, HIT_BACK, HIT_MISS,
};
use super::near::{push_near, NearHit, NearHits, NearRule};
use super::shoot::{RaySetup, TraceScratch};
use super::{LinkParams, Links};
use crate::bvh::{Bvh, BvhBuildParams};
use crate::trace::ray::Ray;
use crate::trace::ray::{RayShear, intersect};
use crate::trace::ray::{Hit, KdTriangle};
use crate::sampling::world_direction;
use crate::scene::motion::Motion;
use crate::scene::prep::PreparedScene;
use crate::sky::visibility::miss_mask;
use crate::trace::{CpuTracer, Tracer};

mod batch;
pub use batch::shoot_groups;
use batch::{batch_records, Batch};
use glam::Vec3;
use half::f16;
use rayon::prelude::*;
use std::time::Instant;

/// Figures of one selective update.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReshootStats {
    /// Rays traced (remade vertices' and static ones').
    pub rays_reshot: u64,
    /// Rays of the vertices that were not remade.
    pub static_rays: u64,
    /// Of those, rays traced again.
    pub static_rays_reshot: u64,
    /// Vertices whose rays were all traced.
    pub remade_vertices: u64,
    /// Link groups rebuilt.
    pub groups_patched: u64,
    /// Time of the update, ms.
    pub ms: f64,
}

/// What one vertex's update produced: its new group and hit counts, and
/// the old hit counts (for the link statistics).
struct Patch {
    targets: Vec<u32>,
    weights: Vec<f16>,
    sums: Vec<u32>,
    /// The vertex's miss mask after the update (None: no ray missed).
    sky: Option<Vec<u64>>,
    /// Its near hits, where the group was merged from all its rays'
    /// records (None: [`near_hits`] finds them).
    near: Option<Vec<NearHit>>,
    new: [u64; 3],
    old: [u64; 3],
}

/// `[front, back, miss]` of hit ids.
fn id_counts(ids: &[u32]) -> [u64; 3] {
    let mut c = [0u64; 3];
    for &id in ids {
        c[if id == HIT_MISS {
            2
        } else if id & HIT_BACK != 0 {
            1
        } else {
            0
        }] += 1;
    }
    c
}

fn triangle(scene: &PreparedScene, positions: &[Vec3], t: u32) -> KdTriangle {
    let [a, b, c] = scene.triangles[t as usize];
    let p = |i: u32| positions[i as usize].to_array();
    KdTriangle { v0: p(a), ia: a, v1: p(b), ib: b, v2: p(c), ic: c }
}

/// The hit record of hit `id` of the ray `o + t d` recomputed on the
/// triangle at `positions`; `None` if the triangle test does not meet it
/// (never for the positions and ray it was traced with).
pub(super) fn recorded(scene: &PreparedScene, positions: &[Vec3], id: u32, o: Vec3, d: Vec3) -> Option<HitRecord> {
    if id == HIT_MISS {
        return Some(HitRecord::of(None));
    }
    let tri = id & !HIT_BACK;
    let (t, u, v, front) = intersect(&triangle(scene, positions, tri), o, &RayShear::new(d), 0.0, f32::INFINITY)?;
    (front == (id & HIT_BACK == 0)).then_some(HitRecord { tri: id, u, v, t })
}

/// A kept hit (on a triangle that did not move) recomputed.
fn kept_record(scene: &PreparedScene, id: u32, o: Vec3, d: Vec3) -> Option<HitRecord> {
    recorded(scene, &scene.positions, id, o, d)
}

/// Slack of the direction cone test ([`Context::cone`]) in cosine: far
/// above the rounding of a direction's frame transform and normalization
/// (about 1e-6).
const CONE_MARGIN: f32 = 1e-4;

/// Everything the per-vertex work shares.
struct Context<'a> {
    scene: &'a PreparedScene,
    /// Positions before the motion.
    old_positions: &'a [Vec3],
    /// The links before the motion and their fixed-point sums.
    links: &'a Links,
    sums: &'a [u32],
    scale: f64,
    motion: &'a Motion,
    tracer: &'a dyn CpuTracer,
    setup: RaySetup,
    probe: Option<Bvh>,
    /// Which hits are near and which a vertex keeps (None: no near hits recorded).
    near_rule: Option<NearRule>,
    union_box: crate::scene::motion::Aabb,
    weight_per_ray: f64,
    /// With a batch tracer: the vertices it re-shot, all their rays.
    batch: Option<Batch>,
}

impl Context<'_> {
    /// True if ray `d` of a kept vertex at `o` must be traced again.
    fn must_retrace(&self, v: usize, id: u32, o: Vec3, d: Vec3, kept: &mut Option<HitRecord>) -> bool {
        if id != HIT_MISS && self.motion.moved_triangle[(id & !HIT_BACK) as usize] {
            return true;
        }
        let Some(probe) = &self.probe else { return false };
        let inv = d.recip();
        if !self.motion.new_box.meets_segment(o, inv, 0.0, f32::INFINITY) {
            return false;
        }
        let t_old = if id == HIT_MISS {
            f32::INFINITY
        } else {
            match kept_record(self.scene, id, o, d) {
                Some(r) => {
                    *kept = Some(r);
                    r.t
                }
                None => return true,
            }
        };
        self.motion.new_box.meets_segment(o, inv, 0.0, t_old)
            && probe.occluded(&Ray { origin: o, dir: d, tmin: 0.0, tmax: t_old, skip: v as u32 })
    }

    /// The cone of directions from `o` that can meet the motion's union
    /// box, in the vertex frame `frame` (tangent, bitangent, normal): its
    /// axis and the least cosine to it, lowered by [`CONE_MARGIN`]; `None`
    /// where `o` is too near the box for a cone. A ray outside it cannot
    /// need a new trace: its old hit was on no moved triangle (those lay
    /// in the box) and its segment meets no box of the motion.
    fn cone(&self, o: Vec3, frame: (Vec3, Vec3, Vec3)) -> Option<(Vec3, f32)> {
        let b = &self.union_box;
        let (center, radius) = ((b.min + b.max) * 0.5, (b.max - b.min).length() * 0.5);
        let to = center - o;
        let dist = to.length();
        if !(dist > 1.01 * radius) {
            return None;
        }
        let u = to / dist;
        let cos = (1.0 - (radius / dist).powi(2)).sqrt() - CONE_MARGIN;
        let (t, bt, n) = frame;
        Some((Vec3::new(t.dot(u), bt.dot(u), n.dot(u)), cos))
    }

    /// Updates vertex `v` whose hit ids are `row`.
    fn vertex(&self, v: usize, row: &mut [u32], scratch: &mut Scratch) -> (Option<Patch>, u64) {
        if let Some(b) = &self.batch {
            // What the batch traced: all rays of a remade vertex, the others' to re-trace.
            if let Some(records) = b.records(v) {
                scratch.records.clear();
                scratch.records.extend_from_slice(records);
                return (Some(self.remerge(v, row, scratch)), row.len() as u64);
            }
            if !b.retraced(v, scratch) {
                return (None, 0);
            }
            let traced = scratch.retrace.len() as u64;
            return self.patch_retraced(v, row, scratch, traced);
        }
        if self.motion.remade[v] {
            self.setup.trace_vertex_with(self.tracer, v, &mut scratch.trace, &mut scratch.records);
            return (Some(self.remerge(v, row, scratch)), row.len() as u64);
        }
        if !self.to_retrace(v, row, scratch) {
            return (None, 0);
        }
        let o = self.setup.origins[v];
        let traced = scratch.retrace.len() as u64;
        scratch.hits.clear();
        scratch.hits.resize(scratch.dirs.len(), None);
        self.tracer.intersect_origin(o, v as u32, &scratch.dirs, &mut scratch.hits);
        self.patch_retraced(v, row, scratch, traced)
    }

    /// Vertex `v`'s group merged from all its rays' records
    /// (`scratch.records`), its hit ids `row` set from them.
    fn remerge(&self, v: usize, row: &mut [u32], scratch: &mut Scratch) -> Patch {
        let old = id_counts(row);
        for (id, r) in row.iter_mut().zip(&scratch.records) {
            *id = r.tri;
        }
        let mut p = self.merge(v, scratch);
        p.old = old;
        p
    }

    /// The rays of a vertex that was not remade that must be traced again
    /// (their ray indices, directions and kept records into `scratch`);
    /// false when there is none.
    fn to_retrace(&self, v: usize, row: &[u32], scratch: &mut Scratch) -> bool {
        let o = self.setup.origins[v];
        if self.union_box.below_plane(o, self.setup.normals[v], self.union_box.rounding_margin()) {
            return false;
        }
        let wedges = self.setup.wedges(v);
        scratch.retrace.clear();
        scratch.dirs.clear();
        scratch.kept.clear();
        let (frame, local) = self.setup.local_directions(v);
        let cone = self.cone(o, frame);
        for (k, local) in local.iter().enumerate() {
            if cone.is_some_and(|(axis, cos)| local.dot(axis) < cos) {
                continue;
            }
            let d = world_direction(frame, *local);
            if wedges.iter().any(|w| w.dives_under(d)) {
                continue;
            }
            let mut kept = None;
            if self.must_retrace(v, row[k], o, d, &mut kept) {
                scratch.retrace.push(k as u32);
                scratch.dirs.push(d);
                scratch.kept.push(kept);
            }
        }
        !scratch.retrace.is_empty()
    }

    /// Vertex `v`'s group patched with its re-traced rays' hits
    /// (`scratch.hits` for `scratch.retrace`); `traced` rays were traced.
    fn patch_retraced(&self, v: usize, row: &mut [u32], scratch: &mut Scratch, traced: u64) -> (Option<Patch>, u64) {
        let o = self.setup.origins[v];
        let old = id_counts(row);
        // The changed rays' corner weights: old ones out, new ones in.
        scratch.deltas.clear();
        let mut changed = false;
        for i in 0..scratch.retrace.len() {
            let (k, d, r) = (scratch.retrace[i] as usize, scratch.dirs[i], HitRecord::of(scratch.hits[i]));
            let old_id = row[k];
            let was = if old_id == HIT_MISS || old_id & HIT_BACK != 0 {
                None
            } else if let Some(w) = scratch.kept[i] {
                Some(w)
            } else {
                let positions = if self.motion.moved_triangle[old_id as usize] {
                    self.old_positions
                } else {
                    &self.scene.positions
                };
                match recorded(self.scene, positions, old_id, o, d) {
                    Some(w) => Some(w),
                    // Not met again: cannot happen for the ray and triangle it was
                    // traced with; rebuild the group from all rays to be safe.
                    None => return (Some(self.rebuild(v, row, scratch)), traced),
                }
            };
            if r.tri == old_id && was.is_none_or(|w| (w.u, w.v) == (r.u, r.v)) {
                continue;
            }
            changed = true;
            if let Some(w) = was {
                let tri = self.scene.triangles[w.tri as usize];
                for (c, x) in tri.iter().zip(corner_weights(w.u, w.v, self.scale)) {
                    scratch.deltas.push((*c, -(x as i64)));
                }
            }
            if r.tri != HIT_MISS && r.tri & HIT_BACK == 0 {
                let tri = self.scene.triangles[r.tri as usize];
                for (c, x) in tri.iter().zip(corner_weights(r.u, r.v, self.scale)) {
                    scratch.deltas.push((*c, x as i64));
                }
            }
            row[k] = r.tri;
        }
        if !changed {
            return (None, traced);
        }
        let mut patch = self.patched(v, scratch);
        patch.old = old;
        patch.new = id_counts(row);
        (Some(patch), traced)
    }

    /// Vertex `v`'s group with `scratch.deltas` applied to its sums, requantized.
    fn patched(&self, v: usize, scratch: &mut Scratch) -> Patch {
        scratch.deltas.sort_unstable_by_key(|&(t, _)| t);
        let r = self.links.offsets[v] as usize..self.links.offsets[v + 1] as usize;
        scratch.targets.clear();
        self.links.targets_into(v, &mut scratch.targets);
        let (targets, sums) = (&scratch.targets, &self.sums[r]);
        let mut p = Patch {
            targets: Vec::with_capacity(targets.len() + 4),
            weights: Vec::new(),
            sums: Vec::with_capacity(targets.len() + 4),
            sky: None,
            near: None,
            new: [0; 3],
            old: [0; 3],
        };
        let (mut i, mut j) = (0, 0);
        let deltas = &scratch.deltas;
        while i < targets.len() || j < deltas.len() {
            let t = match (targets.get(i), deltas.get(j)) {
                (Some(&a), Some(&(b, _))) => a.min(b),
                (Some(&a), None) => a,
                (None, Some(&(b, _))) => b,
                (None, None) => unreachable!(),
            };
            let mut sum = 0i64;
            if targets.get(i) == Some(&t) {
                sum += sums[i] as i64;
                i += 1;
            }
            while deltas.get(j).is_some_and(|&(b, _)| b == t) {
                sum += deltas[j].1;
                j += 1;
            }
            debug_assert!(sum >= 0 && sum <= u32::MAX as i64, "fixed-point sum {sum} of target {t}");
            if sum > 0 {
                p.targets.push(t);
                p.sums.push(sum as u32);
            }
        }
        requantize(p.sums.iter().copied(), self.weight_per_ray, self.scale, &mut p.weights);
        p
    }

    /// Vertex `v`'s group merged from all its rays (its ids in `row`).
    fn rebuild(&self, v: usize, row: &mut [u32], scratch: &mut Scratch) -> Patch {
        let old = id_counts(row);
        self.records(v, row, &mut scratch.records);
        for (id, r) in row.iter_mut().zip(&scratch.records) {
            *id = r.tri;
        }
        let mut p = self.merge(v, scratch);
        p.old = old;
        p
    }

    /// Vertex `v`'s hit records from its hit ids `row`: each kept hit
    /// recomputed with one triangle test on its (current) triangle, a ray
    /// whose triangle it no longer meets traced again.
    fn records(&self, v: usize, row: &[u32], out: &mut Vec<HitRecord>) {
        let o = self.setup.origins[v];
        let wedges = self.setup.wedges(v);
        out.clear();
        for (k, d) in self.setup.world_directions(v).enumerate() {
            out.push(match wedges.iter().find(|w| w.dives_under(d)) {
                Some(w) => w.self_hit(),
                None => kept_record(self.scene, row[k], o, d).unwrap_or_else(|| {
                    HitRecord::of(self.tracer.intersect(&Ray {
                        origin: o,
                        dir: d,
                        tmin: 0.0,
                        tmax: f32::INFINITY,
                        skip: v as u32,
                    }))
                }),
            });
        }
    }

    /// The group of vertex `v` merged from `scratch.records` (all rays, in
    /// order), and its near hits from them.
    fn merge(&self, v: usize, scratch: &mut Scratch) -> Patch {
        let (mut targets, mut weights, mut sums) = (Vec::new(), Vec::new(), Vec::new());
        let c = merge_vertex_sums(
            &scratch.records,
            &self.scene.triangles,
            self.weight_per_ray,
            &mut scratch.merge,
            &mut targets,
            &mut weights,
            Some(&mut sums),
        );
        let near = self.near_rule.as_ref().map(|rule| {
            let mut out = Vec::new();
            push_near(v, &scratch.records, &self.scene.triangles, rule, &mut out);
            out
        });
        let new = [c.front as u64, c.back as u64, c.miss as u64];
        Patch { targets, weights, sums, sky: None, near, new, old: [0; 3] }
    }
}

#[derive(Default)]
struct Scratch {
    trace: TraceScratch,
    records: Vec<HitRecord>,
    retrace: Vec<u32>,
    dirs: Vec<Vec3>,
    /// Old records of the re-traced rays found by the segment test, if any.
    kept: Vec<Option<HitRecord>>,
    /// Fixed-point changes of a group's sums: (target, delta).
    deltas: Vec<(u32, i64)>,
    hits: Vec<Option<Hit>>,
    merge: MergeScratch,
    /// A group's targets, decoded.
    targets: Vec<u32>,
}

/// Updates `links` and `hits` (the state before `motion`, with vertex
/// positions `old_positions`) to `scene` after it, tracing with `tracer`
/// (built over the new positions). `params` must be the ones the links
/// were shot with. Returns the new links, the figures, and per vertex
/// whether its near hits were found anew (empty without near hits).
///
/// With `batch` (a GPU's tracer), the same rays are traced there, in two
/// batches (the remade vertices' ray sets, then every other ray to trace
/// again), before the groups are merged or patched as above: the same
/// result. `tracer` then traces nothing but a ray whose kept record its
/// triangle no longer gives, which the rule above never leaves. An error
/// where the batch tracer fails, with `links` and `hits` as they were.
pub fn reshoot(
    scene: &PreparedScene,
    old_positions: &[Vec3],
    motion: &Motion,
    tracer: &dyn CpuTracer,
    batch: Option<&dyn Tracer>,
    params: &LinkParams,
    links: &Links,
    hits: &mut RayHits,
) -> crate::Result<(Links, ReshootStats, Vec<bool>)> {
    let start = Instant::now();
    let n = scene.vertex_count();
    let setup = RaySetup::new(scene, params);
    let rays = setup.directions.len();
    assert_eq!(hits.rays_per_vertex, rays, "ray state of another ray count");
    assert_eq!(hits.ids.len(), n * rays, "ray state of another scene");
    assert_eq!(hits.sums.len(), links.link_count(), "link sums of other links");
    let RayHits { ids, sums, .. } = hits;
    let probe = (!motion.moved_triangles.is_empty())
        .then(|| Bvh::build(&scene.positions, &motion.moved_triangles, &BvhBuildParams::default()));
    let ctx = Context {
        scene,
        old_positions,
        links,
        sums,
        scale: fixed_scale(rays),
        motion,
        tracer,
        setup,
        probe,
        near_rule: (!links.near.rows.offsets.is_empty()).then(|| NearRule::new(scene, rays as u32, params)).flatten(),
        union_box: motion.union_box(),
        weight_per_ray: std::f64::consts::PI / rays as f64,
        batch: None,
    };
    let mut ctx = ctx;
    if let Some(tracer) = batch {
        ctx.batch = Some(batch_records(&ctx, ids, tracer)?);
    }
    let ctx = ctx;
    const CHUNK: usize = 16;
    let results: Vec<(Vec<Option<Patch>>, u64, u64)> = ids
        .par_chunks_mut(rays * CHUNK)
        .enumerate()
        .map_init(Scratch::default, |scratch, (c, rows)| {
            let mut patches = Vec::with_capacity(CHUNK);
            let (mut remade_rays, mut static_rays) = (0, 0);
            for (i, row) in rows.chunks_mut(rays).enumerate() {
                let v = c * CHUNK + i;
                let (mut p, traced) = ctx.vertex(v, row, scratch);
                if let Some(p) = &mut p {
                    // Its sky visibility from all its rays, as a full shoot records it.
                    p.sky = miss_mask(row.iter().map(|&id| id == HIT_MISS), rays);
                }
                if motion.remade[v] {
                    remade_rays += traced;
                } else {
                    static_rays += traced;
                }
                patches.push(p);
            }
            (patches, remade_rays, static_rays)
        })
        .collect();
    let mut stats = ReshootStats { remade_vertices: motion.remade_count as u64, ..Default::default() };
    let mut out = Links { offsets: Vec::with_capacity(n + 1), ..Default::default() };
    out.offsets.push(0);
    let mut link_stats = links.stats;
    let extra: usize = results.iter().flat_map(|r| r.0.iter().flatten()).map(|p| p.targets.len()).sum();
    out.weights.reserve(links.link_count() + extra);
    out.packed.bytes.reserve(links.packed.bytes.len() + extra);
    out.packed.starts.reserve(n + 1);
    let mut new_sums = Vec::with_capacity(links.link_count() + extra);
    let mut sky = links.sky.clone();
    let mut patched = vec![false; n];
    let mut near_found: Vec<Option<Vec<NearHit>>> = vec![None; n];
    // Unchanged rows are copied a run at a time.
    let copy_run = |out: &mut Links, new_sums: &mut Vec<u32>, run: std::ops::Range<usize>| {
        if run.is_empty() {
            return;
        }
        let (a, b) = (links.offsets[run.start] as usize, links.offsets[run.end] as usize);
        let base = out.weights.len() as u32;
        out.packed.push_rows_of(&links.packed, run.clone());
        out.weights.extend_from_slice(&links.weights[a..b]);
        new_sums.extend_from_slice(&sums[a..b]);
        out.offsets.extend(links.offsets[run.start + 1..run.end + 1].iter().map(|&o| o - a as u32 + base));
    };
    let mut v = 0;
    let mut run = 0;
    for (patches, remade_rays, static_rays) in results {
        stats.rays_reshot += remade_rays + static_rays;
        stats.static_rays_reshot += static_rays;
        for p in patches {
            if let Some(p) = p {
                copy_run(&mut out, &mut new_sums, run..v);
                run = v + 1;
                out.packed.push_group(&p.targets);
                out.weights.extend_from_slice(&p.weights);
                new_sums.extend_from_slice(&p.sums);
                let s = &mut link_stats;
                s.front_hits = s.front_hits + p.new[0] - p.old[0];
                s.back_hits = s.back_hits + p.new[1] - p.old[1];
                s.misses = s.misses + p.new[2] - p.old[2];
                stats.groups_patched += 1;
                patched[v] = true;
                near_found[v] = p.near;
                sky.set(v, n, rays, p.sky.as_deref());
                out.offsets.push(out.weights.len() as u32);
            }
            v += 1;
        }
    }
    copy_run(&mut out, &mut new_sums, run..v);
    stats.static_rays = (n - motion.remade_count) as u64 * rays as u64;
    link_stats.raw_links = 3 * link_stats.front_hits;
    link_stats.raw_bytes = link_stats.raw_links * super::assemble::RAW_LINK_BYTES;
    out.stats = link_stats;
    out.packed.finish();
    out.set_sizes();
    sky.compact();
    out.sky = sky;
    let (near, near_redone) = near_hits(&ctx, links, ids, &patched, near_found);
    out.near = near;
    *sums = new_sums;
    stats.ms = start.elapsed().as_secs_f64() * 1e3;
    out.stats.shoot_ms = stats.ms;
    Ok((out, stats, near_redone))
}

/// The near hits after an update ([`super::near`]): those of patched
/// vertices and of vertices with a near hit on a moved triangle redone
/// (`found` where the group's merge found them, else from their hit ids
/// `ids`), the others kept; and which were redone.
fn near_hits(
    ctx: &Context,
    links: &Links,
    ids: &[u32],
    patched: &[bool],
    found: Vec<Option<Vec<NearHit>>>,
) -> (NearHits, Vec<bool>) {
    let scene = ctx.scene;
    let rays = ctx.setup.directions.len();
    let Some(rule) = &ctx.near_rule else {
        return (NearHits::default(), Vec::new());
    };
    let moved = &ctx.motion.moved_triangle;
    let redone: Vec<Option<Vec<NearHit>>> = found
        .into_par_iter()
        .enumerate()
        .map_init(Vec::new, |records, (v, found)| {
            if found.is_some() {
                return found;
            }
            if !patched[v] && !links.near.of(v).iter().any(|h| moved[h.tri as usize]) {
                return None;
            }
            ctx.records(v, &ids[v * rays..(v + 1) * rays], records);
            let mut out = Vec::new();
            push_near(v, records, &scene.triangles, rule, &mut out);
            Some(out)
        })
        .collect();
    let mut rows = crate::csr::RowBuilder::new();
    for (v, r) in redone.iter().enumerate() {
        rows.extend(r.as_deref().unwrap_or(links.near.of(v)).iter().copied());
        rows.end_row();
    }
    (NearHits { rows: rows.finish() }, redone.iter().map(Option::is_some).collect())
}
