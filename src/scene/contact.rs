//! A-priori splits where geometry stands in a coarse triangle: the second
//! half of the a-priori step ([`super::refine::apriori`]), so a ground
//! plane under a building is cut where the walls stand and stays coarse
//! far away (issue 43).
//!
//! The uniform half cuts every coarse mesh's edges to the target length
//! `L`, a share of the scene's bounding-box diagonal. Where a large plane
//! carries the rest of the scene (a 220 m ground under a 10 m room), `L`
//! comes from the plane: its triangles cross the room's walls, and the
//! floor inside reads light interpolated from corners out under the sky,
//! which no error-driven round can see (every corner agrees, and they stop
//! at `L / 4`). Here a triangle `T` of a coarse mesh, longest edge `l`, is
//! split (its longest edge, at the midpoint) while
//!
//! `l > s * h`,  `h = max over U standing in T of (U's highest point above T's plane)`,
//!
//! with `s` = [`CONTACT_TRIGGER`] (4) for a triangle not yet cut and
//! [`CONTACT_SHARE`] (1/2) for the pieces of one that was, so a triangle
//! is cut only where it is large next to what stands in it, and then to
//! half its height. `U` is a triangle of the scene as loaded (the uniform
//! step cuts a wall into slivers whose feet rise a few centimetres) that
//! stands in `T`: it rises over [`CONTACT_LEAST`] of `L` above `T`'s front
//! side and meets `T`'s plane strictly inside `T` (farther than
//! `eps = 1e-4 l` from its edges): walls standing on the ground, legs on a
//! floor, a column through a slab. Geometry meeting `T` only along its
//! boundary (a wall where a floor ends, a mesh's own neighbours), lying in
//! its plane or a few millimetres over it (a rug, a decal) and geometry
//! behind `T` do not count, so an ordinary room's floor is not cut.
//!
//! Passes split the marked triangles' longest edges (conforming, as the
//! error-driven rounds split, [`super::refine::split_world_edges`]) until
//! nothing is marked, nothing is longer than [`CONTACT_FLOOR`] of `L`, the
//! budget is spent or [`MAX_CONTACT_PASSES`] have run; each pass examines
//! only the pieces of the triangles the last one split (what stands in the
//! others is unchanged). Pieces away from what stands are not marked
//! again, so the cut is graded: fine where the walls stand, coarse far
//! away. Candidates `U` come from a box query on a BVH of the scene's
//! world triangles ([`crate::bvh::Bvh::overlapping`]).
//!
//! Measured (docs/REAL_SCENES.md): the classroom-like scene on a 220 m
//! ground goes from 1.78x the path tracer's mean luminance and 493% block
//! error to 0.91 and 15%; McGuire's box is not cut; Šibenik and Sponza get
//! 5-7% more vertices (their floors around steps and bases) and take 4-5%
//! longer. Units: metres. Deviation from an exact clip: `T` is split at
//! edge midpoints, so a wall still crosses a triangle of up to half its
//! height.

use super::edges::{world_edge, WorldEdge};
use super::SceneDesc;
use crate::bvh::{Bvh, BvhBuildParams};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashSet;

/// A triangle is split while its longest edge exceeds this share of the
/// height of what stands in it (walls of 3 m: to 1.5 m edges; desk legs of
/// 0.7 m: to 0.35 m). Larger: fewer splits, more light carried across the
/// foot of what stands; the error-driven rounds refine from there.
pub const CONTACT_SHARE: f32 = 0.5;

/// A triangle not yet cut starts to be only where its longest edge exceeds
/// this many times the height of what stands in it ("large next to it":
/// a 25 m ground triangle under 3 m walls); its pieces then go on to
/// [`CONTACT_SHARE`]. Measured: 1/2 (no trigger) cuts Šibenik's floors
/// around every step and base (9,729 edges against 5,945; its error-driven
/// rounds then stop a round early, 0.950 of the path tracer's luminance
/// against 0.961); 6 leaves the classroom-like scene's ground under its
/// 17-25 m triangles (0.88 of the luminance against 0.91).
pub const CONTACT_TRIGGER: f32 = 4.0;

/// Geometry rising less than this share of the a-priori target length
/// above a triangle does not count as standing in it (a decal or tile
/// lying a few millimetres over a floor).
pub const CONTACT_LEAST: f32 = 1.0 / 64.0;

/// No edge is split below this share of the a-priori target length, so a
/// thin thing standing in a plane (a sheet, a screw) does not cut it to
/// nothing.
pub const CONTACT_FLOOR: f32 = 1.0 / 16.0;

/// Most passes (each halves the longest edge of the marked triangles).
pub const MAX_CONTACT_PASSES: u32 = 24;

/// What the contact splits did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContactStats {
    /// Edges split, over all passes.
    pub edges: usize,
    /// Passes that split something.
    pub passes: u32,
    /// Whether the budget stopped them with triangles still marked.
    pub stopped_by_budget: bool,
}

/// The scene's triangles in world space: positions (mesh after mesh,
/// unwelded), triangles, and for each its mesh and whether it may be split.
struct World {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Per world triangle: its mesh and index there.
    owner: Vec<(u32, u32)>,
    splittable: Vec<bool>,
}

impl World {
    fn of(scene: &SceneDesc, coarse: &[bool]) -> World {
        let mut w = World { positions: Vec::new(), triangles: Vec::new(), owner: Vec::new(), splittable: Vec::new() };
        for (mi, (m, &is_coarse)) in scene.meshes.iter().zip(coarse).enumerate() {
            let t = m.transform.matrix();
            let base = w.positions.len() as u32;
            w.positions.extend(m.positions.iter().map(|p| t.transform_point3(*p)));
            let n = m.positions.len() as u32;
            for (ti, tri) in m.triangles.iter().enumerate() {
                let ok =
                    tri.iter().all(|&i| i < n) && tri.iter().all(|&i| w.positions[(base + i) as usize].is_finite());
                let [a, b, c] = if ok { tri.map(|i| w.positions[(base + i) as usize]) } else { [Vec3::ZERO; 3] };
                if !ok || (b - a).cross(c - a).length_squared() <= 0.0 {
                    continue; // preparation reports or drops these
                }
                w.triangles.push(tri.map(|i| base + i));
                w.owner.push((mi as u32, ti as u32));
                w.splittable.push(is_coarse && !m.dynamic);
            }
        }
        w
    }

    fn corners(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }
}

/// The height above `t`'s plane of what stands strictly inside `t` (0 if
/// nothing does), `t = [a, b, c]` with longest edge `l`.
fn standing_height(input: &World, bvh: &Bvh, [a, b, c]: [Vec3; 3], l: f32, least: f32) -> f32 {
    let n = (b - a).cross(c - a).normalize();
    let eps = 1e-4 * l;
    // Inward normals of the edges (in the plane, towards the opposite corner).
    let edges = [(a, b), (b, c), (c, a)].map(|(p, q)| (p, n.cross(q - p).normalize()));
    let inside = |p0: Vec3, p1: Vec3| {
        // Clip the segment p0..p1 to the triangle shrunk by eps.
        let (mut t0, mut t1) = (0.0f32, 1.0f32);
        for (p, m) in edges {
            let (s0, s1) = (m.dot(p0 - p) - eps, m.dot(p1 - p) - eps);
            match (s0 > 0.0, s1 > 0.0) {
                (true, true) => {}
                (false, false) => return false,
                (true, false) => t1 = t1.min(s0 / (s0 - s1)),
                (false, true) => t0 = t0.max(s0 / (s0 - s1)),
            }
        }
        t0 < t1
    };
    let pad = Vec3::splat(eps);
    let mut h = 0.0f32;
    bvh.overlapping(a.min(b).min(c) - pad, a.max(b).max(c) + pad, |u| {
        let us = input.corners(u as usize);
        let d = us.map(|p| n.dot(p - a));
        let top = d[0].max(d[1]).max(d[2]);
        if top <= least.max(eps).max(h) || d[0].min(d[1]).min(d[2]) > eps {
            return; // nothing above the front side (or no higher than found), or afloat
        }
        // Where U meets the plane: its corners on it and its edges' crossings.
        let mut pts = [Vec3::ZERO; 6];
        let mut k = 0;
        for i in 0..3 {
            let j = (i + 1) % 3;
            if d[i].abs() <= eps {
                pts[k] = us[i];
                k += 1;
            }
            if (d[i] < -eps && d[j] > eps) || (d[i] > eps && d[j] < -eps) {
                pts[k] = us[i] + (us[j] - us[i]) * (d[i] / (d[i] - d[j]));
                k += 1;
            }
        }
        // The points lie on one line (U's plane meets T's): its extremes.
        let (mut p0, mut p1, mut far) = (pts[0], pts[0], 0.0f32);
        for i in 0..k {
            for j in i + 1..k {
                let dd = pts[i].distance_squared(pts[j]);
                if dd > far {
                    (p0, p1, far) = (pts[i], pts[j], dd);
                }
            }
        }
        if k > 0 && inside(p0, p1) {
            h = h.max(top);
        }
    });
    h
}

/// The longest edge of `t` as `(length, world edge)`.
fn longest_edge([a, b, c]: [Vec3; 3]) -> (f32, WorldEdge) {
    [(a, b), (b, c), (c, a)]
        .into_iter()
        .map(|(p, q)| (p.distance(q), world_edge(p, q)))
        .fold((-1.0, world_edge(a, b)), |m, e| if e.0 > m.0 { e } else { m })
}

/// The conforming split pass of world-keyed edges: the scene and, per
/// mesh, each new triangle's parent ([`super::refine::split_world_edges`]).
pub type SplitPass = dyn Fn(&SceneDesc, &HashSet<WorldEdge>) -> (SceneDesc, Vec<Vec<u32>>);

/// `scene` (`input` after the uniform a-priori step to `target` metres)
/// with the triangles of its `coarse` meshes in which geometry of `input`
/// stands split by `split_world_edges` (see the module doc), adding at
/// most `room` positions.
pub fn split(
    input: &SceneDesc,
    scene: &SceneDesc,
    coarse: &[bool],
    target: f32,
    room: usize,
    split_world_edges: &SplitPass,
) -> (SceneDesc, ContactStats) {
    let mut out = scene.clone();
    let mut stats = ContactStats::default();
    let floor = CONTACT_FLOOR * target;
    let count = |s: &SceneDesc| s.meshes.iter().map(|m| m.positions.len()).sum::<usize>();
    let start = count(scene);
    let usable = floor.is_finite() && floor > 0.0 && coarse.contains(&true);
    if !usable {
        return (out, stats);
    }
    // Per mesh and triangle: a piece of a triangle split here (it goes on
    // to CONTACT_SHARE * h; others start only past CONTACT_TRIGGER * h).
    let mut cutting: Vec<Vec<bool>> = out.meshes.iter().map(|m| vec![false; m.triangles.len()]).collect();
    // Per mesh and triangle: to be examined (every triangle at first, then
    // the pieces of split ones: what stands in the others is unchanged).
    let mut fresh: Vec<Vec<bool>> = out.meshes.iter().map(|m| vec![true; m.triangles.len()]).collect();
    // What stands is read from the scene as loaded: the uniform step cuts
    // a wall into slivers whose feet rise a few centimetres.
    let everything = vec![true; input.meshes.len()];
    let standing = World::of(input, &everything);
    let bvh = Bvh::build(&standing.positions, &standing.triangles, &BvhBuildParams::default());
    for _ in 0..MAX_CONTACT_PASSES {
        let world = World::of(&out, coarse);
        let mut marks: Vec<(f32, WorldEdge, usize)> = (0..world.triangles.len())
            .into_par_iter()
            .filter(|&t| {
                let (m, i) = world.owner[t];
                world.splittable[t] && fresh[m as usize][i as usize]
            })
            .filter_map(|t| {
                let corners = world.corners(t);
                let (l, edge) = longest_edge(corners);
                if l <= floor {
                    return None;
                }
                let h = standing_height(&standing, &bvh, corners, l, CONTACT_LEAST * target);
                let (m, i) = world.owner[t];
                let share = if cutting[m as usize][i as usize] { CONTACT_SHARE } else { CONTACT_TRIGGER };
                (h > 0.0 && l > share * h).then_some((l / h, edge, t))
            })
            .collect();
        if marks.is_empty() {
            break;
        }
        // Within the budget: the triangles largest next to what stands first.
        marks.sort_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
        let left = room.saturating_sub(count(&out) - start);
        // An edge indexed in two meshes adds a position to each.
        if marks.len() * 2 > left {
            marks.truncate(left / 2);
            stats.stopped_by_budget = true;
        }
        if marks.is_empty() {
            break;
        }
        stats.edges += marks.len();
        stats.passes += 1;
        for &(_, _, t) in &marks {
            let (m, i) = world.owner[t];
            cutting[m as usize][i as usize] = true;
        }
        let chosen: HashSet<WorldEdge> = marks.into_iter().map(|(_, e, _)| e).collect();
        let (next, parents) = split_world_edges(&out, &chosen);
        cutting = parents.iter().zip(&cutting).map(|(p, c)| p.iter().map(|&j| c[j as usize]).collect()).collect();
        fresh = parents
            .iter()
            .zip(&fresh)
            .map(|(p, f)| {
                let mut pieces = vec![0u32; f.len()];
                p.iter().for_each(|&j| pieces[j as usize] += 1);
                p.iter().map(|&j| pieces[j as usize] > 1).collect()
            })
            .collect();
        out = next;
        if stats.stopped_by_budget {
            break;
        }
    }
    (out, stats)
}
