//! Ray traversal: stackless along leaf ropes (the production path, mirrored
//! by the WGSL shader), a classic stack traversal and brute force (both test
//! oracles).
//!
//! The rope walk reads leaves and their triangles from the CPU-only copy
//! ([`super::accel`]); the oracles read the shared layout, so the tests
//! compare the two. Rays sharing an origin (a vertex's rays) can share the
//! walk from the root to their start leaf ([`StartLeaves`]).
//!
//! Rays carry a `skip` vertex: triangles with that solver vertex as a corner
//! are ignored (a ray leaving a smooth surface at vertex `p` cannot meet
//! them anywhere but at `p`; docs/DESIGN.md §3). Distances are metres along a unit
//! direction; hits with equal `t` are ordered by triangle id so every path
//! returns the same hit.

use super::accel::{CpuLeaf, ROPE_LEAF};
use super::triangle::intersect4;
use crate::trace::ray::{Hit, Ray, RayShear};
#[cfg(any(test, feature = "internals"))]
use crate::trace::ray::intersect;
use super::{KdTree, LEAF, NO_ROPE};
use glam::Vec3;

/// The start leaves of rays leaving one origin, by direction octant
/// (the leaf holding the origin depends on the direction only where the
/// origin lies on a split plane, and there only on the direction's signs).
#[derive(Clone, Copy, Debug)]
pub struct StartLeaves {
    origin: Vec3,
    leaves: [u32; 8],
}

impl StartLeaves {
    const UNKNOWN: u32 = u32::MAX;

    /// Start leaves of rays from `origin`, none located yet.
    pub fn new(origin: Vec3) -> StartLeaves {
        StartLeaves { origin, leaves: [Self::UNKNOWN; 8] }
    }

    #[inline(always)]
    fn leaf(&mut self, kd: &KdTree, ray: &Ray) -> u32 {
        let d = ray.dir;
        let octant = (d.x <= 0.0) as usize | ((d.y <= 0.0) as usize) << 1 | ((d.z <= 0.0) as usize) << 2;
        if self.leaves[octant] == Self::UNKNOWN {
            self.leaves[octant] = kd.locate(0, self.origin, d);
        }
        self.leaves[octant]
    }
}

/// The start leaf of the previous ray of a run of nearby rays (shadow rays
/// from one vertex's oversampling points). A ray whose entry point lies
/// strictly inside that leaf's box starts there: the walk from the root
/// would end in the same leaf, since the point is off every split plane on
/// the way down. Other rays walk from the root and replace the hint.
#[derive(Clone, Copy, Debug, Default)]
pub struct LeafHint {
    leaf: Option<u32>,
}

impl LeafHint {
    #[inline(always)]
    fn leaf(&mut self, kd: &KdTree, p: Vec3, dir: Vec3) -> u32 {
        if let Some(l) = self.leaf {
            let b = &kd.accel.leaves[l as usize];
            if p.cmpgt(Vec3::from(b.min)).all() && p.cmplt(Vec3::from(b.max)).all() {
                return l;
            }
        }
        let l = kd.locate(0, p, dir);
        self.leaf = Some(l);
        l
    }
}

/// Where a walk finds its first leaf.
enum Start<'a> {
    /// From the root.
    Root,
    /// Rays of one origin ([`StartLeaves`]).
    Shared(&'a mut StartLeaves),
    /// Near the previous ray's start ([`LeafHint`]).
    Near(&'a mut LeafHint),
}

/// Nearer of two hits: smaller `t`, ties by triangle id (the order every
/// tracer and brute force use, so they all return the same hit).
#[inline(always)]
pub(crate) fn closer(t: f32, tri: u32, best: &Option<Hit>) -> bool {
    match best {
        None => true,
        Some(b) => t < b.t || (t == b.t && tri < b.tri),
    }
}

impl KdTree {
    /// Clips the ray to the root box: `(t_enter, t_exit)` or `None`.
    #[inline]
    fn clip_root(&self, ray: &Ray, inv: Vec3) -> Option<(f32, f32)> {
        // Arrays, not `Vec3`: glam indexes a `Vec3` through a `match`, a
        // branch per access where the index is not a constant.
        let (o, d, inv) = (ray.origin.to_array(), ray.dir.to_array(), inv.to_array());
        let (mut t0, mut t1) = (ray.tmin, ray.tmax);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < self.min[a] || o[a] > self.max[a] {
                    return None;
                }
                continue;
            }
            let ta = (self.min[a] - o[a]) * inv[a];
            let tb = (self.max[a] - o[a]) * inv[a];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        (t0 <= t1 && !self.nodes.is_empty()).then_some((t0, t1))
    }

    /// Tests a leaf's triangles (shared layout), keeping the nearest hit.
    #[inline(always)]
    #[cfg(any(test, feature = "internals"))]
    fn test_leaf(&self, leaf: u32, ray: &Ray, shear: &RayShear, best: &mut Option<Hit>) {
        let l = &self.leaves[leaf as usize];
        let ids = &self.leaf_triangles[l.first as usize..(l.first + l.count) as usize];
        let tmax = best.map_or(ray.tmax, |b| b.t);
        for &id in ids {
            let tri = &self.triangles[id as usize];
            if tri.ia == ray.skip || tri.ib == ray.skip || tri.ic == ray.skip {
                continue;
            }
            if let Some((t, u, v, front)) = intersect(tri, ray.origin, shear, ray.tmin, tmax) {
                if closer(t, id, best) {
                    *best = Some(Hit { tri: id, u, v, t, front });
                }
            }
        }
    }

    /// Tests a leaf's triangles (CPU copy, four at a time), keeping the
    /// nearest hit (or stopping at any hit). Lanes are taken in leaf order
    /// with the leaf's starting `tmax`, as [`KdTree::test_leaf`] does.
    #[inline(always)]
    fn test_cpu_leaf<const ANY: bool>(
        &self,
        leaf: &CpuLeaf,
        ray: &Ray,
        shear: &RayShear,
        best: &mut Option<Hit>,
    ) -> bool {
        let tmax = best.map_or(ray.tmax, |b| b.t);
        let mut left = leaf.count;
        let mut block = leaf.first as usize;
        while left > 0 {
            let lanes = if left >= 4 { 0b1111 } else { (1 << left) - 1 };
            let blk = &self.accel.blocks[block];
            let h = intersect4(&blk.tri, lanes, ray.origin, shear, ray.tmin, tmax);
            let mut m = h.mask;
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                let [ia, ib, ic, id] = blk.lanes[i];
                if ia == ray.skip || ib == ray.skip || ic == ray.skip {
                    continue;
                }
                if closer(h.t[i], id, best) {
                    *best = Some(Hit { tri: id, u: h.u[i], v: h.v[i], t: h.t[i], front: h.front >> i & 1 == 1 });
                    if ANY {
                        return true;
                    }
                }
            }
            left = left.saturating_sub(4);
            block += 1;
        }
        false
    }

    /// The leaf a CPU rope leads to for a ray at `t`, leaving the current
    /// leaf through `face` (a rope to an inner node descends from it). The
    /// entry point lies on the face's plane: that coordinate is the plane's
    /// own, not `origin + t * dir` rounded off it, so a leaf only an ulp or
    /// two thick (a flat triangle's slab) is entered, not stepped over.
    #[inline(always)]
    fn enter(&self, rope: u32, ray: &Ray, t: f32, face: usize, leaf: &CpuLeaf) -> u32 {
        if rope & ROPE_LEAF != 0 {
            rope & !ROPE_LEAF
        } else {
            // Arrays, not `Vec3`: glam indexes a `Vec3` at a run-time axis
            // through a jump table, an indirect branch that is mispredicted
            // about every time.
            let mut p = (ray.origin + ray.dir * t).to_array();
            p[face / 2] = if face % 2 == 1 { leaf.max[face / 2] } else { leaf.min[face / 2] };
            self.locate(rope, Vec3::from_array(p), ray.dir)
        }
    }

    #[inline(always)]
    fn walk_ropes<const ANY: bool>(&self, ray: &Ray, start: Start) -> Option<Hit> {
        let inv = ray.dir.recip();
        let (mut t_enter, t_exit_root) = self.clip_root(ray, inv)?;
        let shear = RayShear::new(ray.dir);
        let mut best: Option<Hit> = None;
        let leaf_id = match start {
            // At t = 0 the entry point is the origin itself, shared by the
            // rays of a start cache; the leaf depends only on the signs.
            Start::Shared(cache) if t_enter == 0.0 && ray.origin == cache.origin => cache.leaf(self, ray),
            Start::Near(hint) => hint.leaf(self, ray.origin + ray.dir * t_enter, ray.dir),
            _ => self.locate(0, ray.origin + ray.dir * t_enter, ray.dir),
        };
        // Each step moves to a leaf further along the ray; the bound only guards
        // against a malformed tree.
        let mut leaf = &self.accel.leaves[leaf_id as usize];
        // Arrays for the per-axis loops (see `clip_root`).
        let (o, d, inv) = (ray.origin.to_array(), ray.dir.to_array(), inv.to_array());
        for _ in 0..=self.leaves.len() {
            let (mut t_exit, mut exit_face) = (f32::INFINITY, usize::MAX);
            let mut t_face = [f32::INFINITY; 3];
            for a in 0..3 {
                let (bound, f) = if d[a] > 0.0 {
                    (leaf.max[a], 2 * a + 1)
                } else if d[a] < 0.0 {
                    (leaf.min[a], 2 * a)
                } else {
                    continue;
                };
                let t = (bound - o[a]) * inv[a];
                t_face[a] = t;
                if t < t_exit {
                    t_exit = t;
                    exit_face = f;
                }
            }
            // The next leaf is found before this one's triangles are tested,
            // so finding it overlaps the tests (the order of the tests does not
            // change the nearest hit).
            let next = if t_exit >= t_exit_root || exit_face == usize::MAX || leaf.ropes[exit_face] == NO_ROPE {
                None
            } else {
                Some(
                    &self.accel.leaves
                        [self.enter(leaf.ropes[exit_face], ray, t_enter.max(t_exit), exit_face, leaf) as usize],
                )
            };
            if self.test_cpu_leaf::<ANY>(leaf, ray, &shear, &mut best) {
                return best;
            }
            // Leaving through a leaf edge or corner: also test the leaves
            // across the other tied faces (see the module doc of kdtree).
            if t_exit < t_exit_root {
                for a in 0..3 {
                    let f = 2 * a + (d[a] > 0.0) as usize;
                    if f == exit_face || t_face[a] - t_exit > 1e-6 * t_exit.abs() {
                        continue;
                    }
                    let rope = leaf.ropes[f];
                    if rope != NO_ROPE {
                        let side = &self.accel.leaves[self.enter(rope, ray, t_exit, f, leaf) as usize];
                        if self.test_cpu_leaf::<ANY>(side, ray, &shear, &mut best) {
                            return best;
                        }
                    }
                }
            }
            if let Some(b) = best {
                if b.t <= t_exit {
                    return best;
                }
            }
            let Some(n) = next else {
                return best;
            };
            t_enter = t_enter.max(t_exit);
            leaf = n;
        }
        best
    }

    /// The leaf under `node` containing `p` (ties go the way `dir` points).
    #[inline]
    fn locate(&self, mut node: u32, p: Vec3, dir: Vec3) -> u32 {
        // Arrays: a `Vec3` indexed at the node's axis goes through a jump
        // table (see `enter`).
        let (p, dir) = (p.to_array(), dir.to_array());
        let mut n = self.nodes[node as usize];
        while n.kind != LEAF {
            let a = n.kind as usize;
            node = if p[a] < n.split || (p[a] == n.split && dir[a] <= 0.0) { n.a } else { n.b };
            n = self.nodes[node as usize];
        }
        n.a
    }

    /// Nearest hit along the ray by walking leaf ropes (no stack).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.walk_ropes::<false>(ray, Start::Root)
    }

    /// As [`KdTree::intersect`], for one of many rays leaving the same
    /// origin: `start` (made for that origin) remembers the leaf the rays
    /// start in, so the walk from the root is done once per direction
    /// octant instead of once per ray. Same hits as `intersect` (a ray from
    /// another origin just does not use the cache).
    #[inline(always)]
    pub fn intersect_from(&self, ray: &Ray, start: &mut StartLeaves) -> Option<Hit> {
        self.walk_ropes::<false>(ray, Start::Shared(start))
    }

    /// True if anything (front or back face) lies on the ray segment.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.walk_ropes::<true>(ray, Start::Root).is_some()
    }

    /// As [`KdTree::occluded`], for one of a run of rays starting near each
    /// other: `hint` carries the start leaf from ray to ray. Same answers.
    pub fn occluded_near(&self, ray: &Ray, hint: &mut LeafHint) -> bool {
        self.walk_ropes::<true>(ray, Start::Near(hint)).is_some()
    }

    /// Nearest hit by front-to-back traversal with an explicit stack (test
    /// oracle; splits within a relative 1e-6 of an interval's end visit
    /// both children).
    #[cfg(any(test, feature = "internals"))]
    pub fn intersect_stack(&self, ray: &Ray) -> Option<Hit> {
        let inv = ray.dir.recip();
        let (t0, t1) = self.clip_root(ray, inv)?;
        let shear = RayShear::new(ray.dir);
        let mut best: Option<Hit> = None;
        let mut stack: Vec<(u32, f32, f32)> = vec![(0, t0, t1)];
        while let Some((mut node, tmin, mut tmax)) = stack.pop() {
            if best.is_some_and(|b| b.t < tmin) {
                continue;
            }
            loop {
                let n = self.nodes[node as usize];
                if n.kind == LEAF {
                    self.test_leaf(n.a, ray, &shear, &mut best);
                    break;
                }
                let a = n.kind as usize;
                let below_first = ray.origin[a] < n.split || (ray.origin[a] == n.split && ray.dir[a] <= 0.0);
                let (first, second) = if below_first { (n.a, n.b) } else { (n.b, n.a) };
                let t_split = (n.split - ray.origin[a]) * inv[a];
                // A relative margin: an interval one ulp-thick leaf wide can
                // round to nothing, so a split that close to either end
                // sends the ray into both children.
                let (lo, hi) = (tmin - 1e-6 * tmin.abs(), tmax + 1e-6 * tmax.abs());
                if ray.dir[a] == 0.0 || t_split > hi || t_split <= 0.0 {
                    node = first;
                } else if t_split < lo {
                    node = second;
                } else {
                    stack.push((second, t_split, tmax));
                    node = first;
                    tmax = t_split;
                }
            }
        }
        best
    }
}

/// Nearest hit by testing every triangle (test oracle).
#[cfg(any(test, feature = "internals"))]
pub fn brute_force(kd: &KdTree, ray: &Ray) -> Option<Hit> {
    let mut best: Option<Hit> = None;
    let shear = RayShear::new(ray.dir);
    for (id, tri) in kd.triangles.iter().enumerate() {
        if tri.ia == ray.skip || tri.ib == ray.skip || tri.ic == ray.skip {
            continue;
        }
        if let Some((t, u, v, front)) = intersect(tri, ray.origin, &shear, ray.tmin, ray.tmax) {
            if closer(t, id as u32, &best) {
                best = Some(Hit { tri: id as u32, u, v, t, front });
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::ray::NO_SKIP;

    #[test]
    fn shadow_segments_stop_short_by_the_larger_margin() {
        let o = Vec3::ZERO;
        // Near: the absolute margin; far: the relative one.
        assert_eq!(Ray::shadow(o, Vec3::X, 1.0, 1e-3, 0.0, NO_SKIP).tmax, 1.0 - 1e-3);
        assert_eq!(Ray::shadow(o, Vec3::X, 1000.0, 1e-3, 0.0, NO_SKIP).tmax, 1000.0 - 0.1);
        // Never below tmin; a directional light's segment has no end.
        assert_eq!(Ray::shadow(o, Vec3::X, 1e-4, 1e-3, 1e-5, 7).tmax, 1e-5);
        let sun = Ray::shadow(o, Vec3::Y, f32::INFINITY, 1e-3, 1e-5, 7);
        assert_eq!((sun.tmin, sun.tmax, sun.skip), (1e-5, f32::INFINITY, 7));
    }

    /// A point within two offsets of the origin, or a direction that is not
    /// finite, takes no ray; beyond, the segment of `Ray::shadow`; a
    /// touching stand-in has no length.
    #[test]
    fn touching_points_take_no_shadow_ray() {
        let o = Vec3::ZERO;
        assert_eq!(Ray::shadow_checked(o, Vec3::X, 2e-3, 1e-3, 0.0, NO_SKIP), None);
        assert_eq!(Ray::shadow_checked(o, Vec3::NAN, 1.0, 1e-3, 0.0, NO_SKIP), None);
        let far = Ray::shadow_checked(o, Vec3::X, 2.1e-3, 1e-3, 0.0, 3).expect("a segment");
        assert_eq!(far, Ray::shadow(o, Vec3::X, 2.1e-3, 1e-3, 0.0, 3));
        let sun = Ray::shadow_checked(o, Vec3::Y, f32::INFINITY, 1e-3, 0.0, 3).expect("unbounded");
        assert_eq!(sun.tmax, f32::INFINITY);
        let t = Ray::touching(o, Vec3::Z, 5);
        assert_eq!((t.tmin, t.tmax, t.skip), (0.0, 0.0, 5));
    }
}
