//! Links of a refined mesh from the rays shot before the split (issue 31,
//! error-driven rounds, [`crate::solver::adaptive`]): new vertices shoot
//! their rays; a kept vertex's ray that hit a split triangle is
//! re-assigned to the piece holding its hit point, with no retrace.
//!
//! Why it is exact: the split pieces of a triangle lie in its plane and
//! cover it, and nothing else in the scene changed, so a ray of a vertex
//! whose origin and direction did not change meets what it met before, on
//! the piece that holds the old hit point. The piece is found by the one
//! watertight triangle test every tracer uses
//! ([`crate::trace::ray::intersect`]) on the old triangle's pieces
//! (the nearest, the first in piece order on an exact tie), which gives
//! the tracer's `(u, v, t)` bit for bit; the records then go through the
//! one merge every link build uses (`links::shoot::links_from_records`),
//! so the links, near hits and sky visibility are a full shoot's.
//!
//! A vertex is *kept* ([`Lineage::new`]) when it is an old vertex at the
//! same position (an input position split into several solver vertices,
//! at a crease or a material border, matches each old one to the new one
//! with the nearest normal: Šibenik, 89% crease and border vertices,
//! carried 43% of its second round's rays when only one of them matched,
//! 82% now), not buried ([`super::buried`]: its origin moved by a
//! probe of its faces), with the same ray origin to the bit (inside a smooth
//! surface the origin is the position; crease and border vertices are
//! nudged by their one-ring, which a split next to them changes, so they
//! are kept where their ring was not split), its normal moved by
//! less than [`KEPT_NORMAL`] (the pieces at a vertex span the angles of
//! its old triangles in the same planes, so its angle-weighted normal is
//! the same up to rounding), and it does not touch a split triangle of
//! another surface (within [`TOUCH`] of the scene's diagonal: a floor
//! vertex on the base line of a box standing on it meets the box's wall
//! at `t = 0`, where the watertight test's edge and corner rules decide,
//! and a split moves corners and edges there). A kept vertex keeps its old normal bit for bit
//! and its colour ([`crate::sampling::colours_keeping`]), so its frame and
//! its directions are the old ones; the others are coloured around them.
//!
//! Per ray of a kept vertex: the dive test ([`super::Wedge::dives_under`])
//! is redone on its new triangles (a self hit is never traced); a miss
//! stays a miss; a hit on triangle `T` is tested against `T`'s pieces.
//! Traced again are only rays whose old record cannot be carried: an old
//! self hit that no longer dives (a grazing ray whose piece's plane rounds
//! differently), and a hit that no piece meets (a hit point within
//! rounding of `T`'s border, which midpoints rounded to f32 can leave to
//! the neighbour's pieces). Rounding can also let a ray that missed `T`
//! by an ulp meet a piece, or an exact tie on a shared edge be resolved
//! otherwise by the tracer; `tests/refine.rs` counts such records (none
//! on its scenes) against a fresh shoot.

use super::merge::{RayHits, HIT_BACK, HIT_MISS};
use super::selective::recorded;
use super::shoot::{links_from_records, ray_origin, RaySetup, Recording, TraceScratch, TO_TRACE};
use super::{HitRecord, LinkParams, Links};
use crate::csr::Csr;
use crate::scene::prep::{PreparedScene, NO_VERTEX};
use crate::trace::CpuTracer;
use glam::Vec3;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Largest change of a vertex's normal (unit vectors' difference) for it
/// to keep its rays: rounding moves an angle-weighted normal by about
/// 1e-7 when its triangles are split.
pub const KEPT_NORMAL: f32 = 1e-5;

/// How a refined scene's solver vertices and triangles come from the
/// scene it was refined from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Lineage {
    /// Per new solver vertex: the old solver vertex whose rays it keeps,
    /// or [`NO_VERTEX`] (it traces all its rays).
    pub kept: Vec<u32>,
    /// Row `T` (an old solver triangle): the new solver triangles that
    /// cover it (one, itself renumbered, where it was not split).
    pub pieces: Csr,
    /// Per new solver vertex: it keeps an old vertex whose incident
    /// triangles it has, corner for corner (no split touched its one-ring),
    /// so every ray it shoots starts from the same origin past the same
    /// wedges and offset (the light links, the emitter links and the sky's refined cells
    /// keep its rows: `EmitterLinks::after_split`, `SkyRefinement::after_split`).
    pub whole: Vec<bool>,
}

/// Figures of one re-assignment.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReassignStats {
    /// New vertices that kept their old rays.
    pub kept_vertices: u64,
    /// Rays of kept vertices whose hits were carried (re-assigned or kept) without tracing.
    pub rays_carried: u64,
    /// Rays traced: all rays of the other vertices, and kept vertices' rays that could not be carried.
    pub rays_traced: u64,
    /// Time of the re-assignment, ms.
    pub ms: f64,
}

impl Lineage {
    /// The lineage of `scene`, prepared from the refinement of the scene
    /// `old` was prepared from, with `parents[mesh][j]` the input triangle
    /// of the old mesh that the new input triangle `j` is a piece of
    /// ([`crate::scene::refine::split_world_edges`]) and `nudge` the links'
    /// ([`super::LinkParams::nudge`]). Kept vertices take
    /// their old normal and colour in `scene`; the others are coloured
    /// around them (module doc).
    pub fn new(old: &PreparedScene, scene: &mut PreparedScene, parents: &[Vec<u32>], nudge: f32) -> Lineage {
        let n = scene.vertex_count();
        let fresh_normals = scene.normals.clone();
        let mut kept = vec![NO_VERTEX; n];
        let mut colour = vec![None; n];
        let mut pairs = Vec::with_capacity(scene.triangles.len());
        for ((om, nm), parent) in old.meshes.iter().zip(&scene.meshes).zip(parents) {
            // An input position may have several solver vertices (a crease
            // splits it by normal): each old one is matched to the new one
            // of its position whose normal is nearest.
            let mut of_input: HashMap<u32, Vec<u32>> = HashMap::new();
            for (k, &i) in nm.vertex_input.iter().enumerate() {
                of_input.entry(i).or_default().push(nm.vertices.start + k as u32);
            }
            for (i, v) in om.vertices.clone().enumerate() {
                let candidates = of_input.get(&om.vertex_input[i]).map_or(&[][..], |c| c.as_slice());
                let nearest = candidates
                    .iter()
                    .filter(|&&w| colour[w as usize].is_none())
                    .map(|&w| (old.normals[v as usize].distance_squared(scene.normals[w as usize]), w))
                    .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                let Some((_, w)) = nearest else { continue };
                let (v, w) = (v as usize, w as usize);
                colour[w] = Some(old.colours[v]);
                let buried =
                    |s: &PreparedScene, x: usize| s.moved_origins.binary_search_by_key(&(x as u32), |e| e.0).is_ok();
                if old.boundary[v] == scene.boundary[w]
                    && !buried(old, v)
                    && !buried(scene, w)
                    && old.positions[v] == scene.positions[w]
                    && (old.normals[v] - scene.normals[w]).length() < KEPT_NORMAL
                {
                    scene.normals[w] = old.normals[v];
                    // A crease or border vertex's origin is nudged by its
                    // one-ring: kept where that ring was not split (the
                    // same origin to the bit).
                    let same = !old.boundary[v] || ray_origin(old, v, nudge) == ray_origin(scene, w, nudge);
                    if same {
                        kept[w] = v as u32;
                    } else {
                        scene.normals[w] = fresh_normals[w];
                    }
                }
            }
            // Old solver triangle -> old input triangle -> its pieces -> new solver triangles.
            let mut new_of_input = vec![NO_VERTEX; parent.len()];
            for (k, &j) in nm.triangle_input.iter().enumerate() {
                new_of_input[j as usize] = nm.triangles.start + k as u32;
            }
            let mut old_of_input =
                vec![NO_VERTEX; om.triangle_input.iter().map(|&i| i as usize + 1).max().unwrap_or(0)];
            for (k, &i) in om.triangle_input.iter().enumerate() {
                old_of_input[i as usize] = om.triangles.start + k as u32;
            }
            for (j, &p) in parent.iter().enumerate() {
                let (t_old, t_new) = (old_of_input.get(p as usize).copied().unwrap_or(NO_VERTEX), new_of_input[j]);
                if t_old != NO_VERTEX && t_new != NO_VERTEX {
                    pairs.push((t_old, t_new));
                }
            }
        }
        scene.colours = crate::sampling::colours_keeping(&scene.rings, &colour);
        let pieces = Csr::from_pairs(old.triangles.len(), &pairs);
        // A vertex that touches a split triangle (another mesh standing on
        // it, a floor vertex on a wall's base) meets it at t = 0, where the
        // watertight test's edge rules decide: the split moves corners and
        // edges there, so its rays are traced again.
        let split: Vec<u32> = (0..old.triangles.len() as u32).filter(|&t| pieces.row(t as usize).len() > 1).collect();
        let touching = Touching::new(old, &split);
        for (w, k) in kept.iter_mut().enumerate() {
            if *k != NO_VERTEX && touching.touches(old, *k) {
                *k = NO_VERTEX;
                scene.normals[w] = fresh_normals[w];
            }
        }
        let whole =
            kept.iter().enumerate().map(|(w, &v)| v != NO_VERTEX && same_ring(old, v as usize, scene, w)).collect();
        Lineage { kept, pieces, whole }
    }

    /// New vertices that keep their rays.
    pub fn kept_count(&self) -> usize {
        self.kept.iter().filter(|&&v| v != NO_VERTEX).count()
    }

    /// Per new vertex of `scene` (a split of `before`): the old vertex whose
    /// per-vertex rows a traced part may keep, where it is kept with a
    /// one-ring no split touched ([`Lineage::whole`]) and its ray origin
    /// with the part's `nudge` is the same to the bit; `None` where the
    /// part traces it anew.
    pub fn carried(&self, before: &PreparedScene, scene: &PreparedScene, nudge: f32) -> Vec<Option<usize>> {
        (0..scene.vertex_count())
            .map(|w| {
                let v = self.kept[w] as usize;
                (self.whole.get(w) == Some(&true) && ray_origin(before, v, nudge) == ray_origin(scene, w, nudge))
                    .then_some(v)
            })
            .collect()
    }
}

/// Whether vertex `v` of `old` and `w` of `new` have the same incident
/// triangles (as corner positions, bit for bit, in any order).
fn same_ring(old: &PreparedScene, v: usize, new: &PreparedScene, w: usize) -> bool {
    let corners = |s: &PreparedScene, x: usize| {
        let mut t: Vec<[[u32; 3]; 3]> = s
            .vertex_triangles
            .row(x)
            .iter()
            .map(|&t| s.triangles[t as usize].map(|c| s.positions[c as usize].to_array().map(f32::to_bits)))
            .collect();
        t.sort_unstable();
        t
    };
    old.vertex_triangles.row(v).len() == new.vertex_triangles.row(w).len() && corners(old, v) == corners(new, w)
}

/// The split triangles of a refinement, in a hash grid, to find the
/// vertices that touch them (within [`TOUCH`] of the scene's size).
struct Touching {
    cell: f32,
    eps: f32,
    grid: HashMap<[i32; 3], Vec<u32>>,
}

/// How close (a share of the bounding box's diagonal) a vertex must be to
/// a split triangle to count as touching it: far above rounding, far
/// below any edge a refinement makes.
pub const TOUCH: f32 = 1e-5;

impl Touching {
    /// `split`: old triangle ids of `old`.
    fn new(old: &PreparedScene, split: &[u32]) -> Touching {
        let (lo, hi) = old.bounds();
        let eps = TOUCH * (hi - lo).length();
        let corners = |t: u32| old.triangles[t as usize].map(|i| old.positions[i as usize]);
        let extent = |t: u32| {
            let [a, b, c] = corners(t);
            (a.max(b).max(c) - a.min(b).min(c)).max_element()
        };
        let cell = split.iter().map(|&t| extent(t)).fold(eps, f32::max) + 2.0 * eps;
        let mut grid: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
        for &t in split {
            let [a, b, c] = corners(t);
            let (l, h) = (Self::key(a.min(b).min(c) - eps, cell), Self::key(a.max(b).max(c) + eps, cell));
            for x in l[0]..=h[0] {
                for y in l[1]..=h[1] {
                    for z in l[2]..=h[2] {
                        grid.entry([x, y, z]).or_default().push(t);
                    }
                }
            }
        }
        Touching { cell, eps, grid }
    }

    fn key(p: Vec3, cell: f32) -> [i32; 3] {
        (p / cell).floor().as_ivec3().to_array()
    }

    /// Whether old vertex `v` lies within `eps` of a split triangle it is not a corner of.
    fn touches(&self, old: &PreparedScene, v: u32) -> bool {
        let p = old.positions[v as usize];
        let Some(tris) = self.grid.get(&Self::key(p, self.cell)) else { return false };
        tris.iter().any(|&t| {
            let tri = old.triangles[t as usize];
            !tri.contains(&v) && near_triangle(p, tri.map(|i| old.positions[i as usize]), self.eps)
        })
    }
}

/// Whether `p` lies within about `eps` of triangle `[a, b, c]`
/// (conservative: its plane within `eps`, inside its edges widened by `eps`).
fn near_triangle(p: Vec3, [a, b, c]: [Vec3; 3], eps: f32) -> bool {
    let Some(n) = (b - a).cross(c - a).try_normalize() else { return false };
    let d = (p - a).dot(n);
    if d.abs() > eps {
        return false;
    }
    let q = p - n * d;
    [(a, b), (b, c), (c, a)].iter().all(|&(x, y)| (y - x).cross(q - x).dot(n) >= -eps * (y - x).length())
}

/// The links of `scene` (refined from `old`, whose links were shot with
/// `params` and recorded every ray's hit id in `hits`), with `lineage`
/// from [`Lineage::new`]: kept vertices' hits carried over, the other rays
/// traced with `tracer` (built over `scene`). Returns the links, the new
/// ray state, and the figures. `progress(done, total)` after each batch.
pub fn reassign_links(
    old: &PreparedScene,
    hits: &RayHits,
    scene: &PreparedScene,
    lineage: &Lineage,
    tracer: &dyn CpuTracer,
    params: &LinkParams,
    near: bool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> (Links, RayHits, ReassignStats) {
    let start = Instant::now();
    let setup = RaySetup::new(scene, params);
    let rays = setup.directions.len();
    assert_eq!(hits.rays_per_vertex, rays, "ray state of another ray count");
    assert_eq!(hits.ids.len(), old.vertex_count() * rays, "ray state of another scene");
    let traced = AtomicU64::new(0);
    let fill = |w: usize, scratch: &mut TraceScratch, out: &mut Vec<HitRecord>| {
        let v = lineage.kept[w];
        let n = if v == NO_VERTEX {
            setup.trace_vertex_with(tracer, w, scratch, out);
            rays
        } else {
            carry(old, hits.row(v as usize), v as usize, scene, &setup, lineage, w, tracer, scratch, out)
        };
        traced.fetch_add(n as u64, Ordering::Relaxed);
    };
    let (links, state) = links_from_records(scene, &setup, params, Recording { near, ray_hits: true }, progress, &fill);
    let state = state.expect("recorded");
    let rays_traced = traced.into_inner();
    let total = (scene.vertex_count() * rays) as u64;
    let stats = ReassignStats {
        kept_vertices: lineage.kept_count() as u64,
        rays_carried: total - rays_traced,
        rays_traced,
        ms: start.elapsed().as_secs_f64() * 1e3,
    };
    (links, state, stats)
}

/// The records of kept vertex `w` (old vertex `v`, old hit ids `row`) into
/// `out`; returns how many rays it traced.
#[allow(clippy::too_many_arguments)]
fn carry(
    old: &PreparedScene,
    row: &[u32],
    v: usize,
    scene: &PreparedScene,
    setup: &RaySetup,
    lineage: &Lineage,
    w: usize,
    tracer: &dyn CpuTracer,
    scratch: &mut TraceScratch,
    out: &mut Vec<HitRecord>,
) -> usize {
    out.clear();
    let o = setup.origins[w];
    let wedges = setup.wedges(w);
    let was_self = old.vertex_triangles.row(v);
    let mut retrace = Vec::new();
    for (k, d) in setup.world_directions(w).enumerate() {
        if let Some(wedge) = wedges.iter().find(|x| x.dives_under(d)) {
            out.push(wedge.self_hit());
            continue;
        }
        let id = row[k];
        if id == HIT_MISS {
            out.push(HitRecord { tri: HIT_MISS, u: 0.0, v: 0.0, t: f32::INFINITY });
            continue;
        }
        let tri = id & !HIT_BACK;
        let front = id & HIT_BACK == 0;
        let carried =
            (!was_self.contains(&tri)).then(|| on_pieces(scene, lineage.pieces.row(tri as usize), o, d, front));
        match carried.flatten() {
            Some(r) => out.push(r),
            None => {
                out.push(HitRecord { tri: TO_TRACE, ..Default::default() });
                retrace.push(d);
            }
        }
    }
    if !retrace.is_empty() {
        setup.trace_dirs(tracer, w, &retrace, scratch, out);
    }
    retrace.len()
}

/// The nearest hit of the ray `o + t d` on `pieces` (the first on a tie)
/// with the given facing, as a record (the selective update's re-test of
/// a recorded hit, on each piece); `None` if no piece meets it.
fn on_pieces(scene: &PreparedScene, pieces: &[u32], o: Vec3, d: Vec3, front: bool) -> Option<HitRecord> {
    let flag = if front { 0 } else { HIT_BACK };
    let mut best: Option<HitRecord> = None;
    for &p in pieces {
        if let Some(r) = recorded(scene, &scene.positions, p | flag, o, d) {
            if best.is_none_or(|b| r.t < b.t) {
                best = Some(r);
            }
        }
    }
    best
}
