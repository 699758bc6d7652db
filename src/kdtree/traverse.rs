//! Ray traversal: stackless along leaf ropes (the production path, mirrored
//! by the WGSL shader), a classic stack traversal and brute force (both test
//! oracles).
//!
//! Rays carry a `skip` vertex: triangles with that solver vertex as a corner
//! are ignored (a ray leaving a smooth surface at vertex `p` cannot meet
//! them anywhere but at `p`; DESIGN.md §3). Distances are metres along a unit
//! direction; hits with equal `t` are ordered by triangle id so every path
//! returns the same hit.

use super::triangle::{intersect, Hit, RayShear};
use super::{KdTree, LEAF, NO_ROPE};
use glam::Vec3;

/// No vertex to skip.
pub const NO_SKIP: u32 = u32::MAX;

/// A ray segment `origin + t * dir`, `t` in `[tmin, tmax]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
    /// Solver vertex whose incident triangles are ignored, or [`NO_SKIP`].
    pub skip: u32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir, tmin: 0.0, tmax: f32::INFINITY, skip: NO_SKIP }
    }
}

#[inline(always)]
fn closer(t: f32, tri: u32, best: &Option<Hit>) -> bool {
    match best {
        None => true,
        Some(b) => t < b.t || (t == b.t && tri < b.tri),
    }
}

impl KdTree {
    /// Clips the ray to the root box: `(t_enter, t_exit)` or `None`.
    #[inline]
    fn clip_root(&self, ray: &Ray, inv: Vec3) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (ray.tmin, ray.tmax);
        for a in 0..3 {
            if ray.dir[a] == 0.0 {
                if ray.origin[a] < self.min[a] || ray.origin[a] > self.max[a] {
                    return None;
                }
                continue;
            }
            let ta = (self.min[a] - ray.origin[a]) * inv[a];
            let tb = (self.max[a] - ray.origin[a]) * inv[a];
            t0 = t0.max(ta.min(tb));
            t1 = t1.min(ta.max(tb));
        }
        (t0 <= t1 && !self.nodes.is_empty()).then_some((t0, t1))
    }

    /// Tests a leaf's triangles, keeping the nearest hit (or stopping at any hit).
    #[inline(always)]
    fn test_leaf<const ANY: bool>(&self, leaf: u32, ray: &Ray, shear: &RayShear, best: &mut Option<Hit>) -> bool {
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
                    if ANY {
                        return true;
                    }
                }
            }
        }
        false
    }

    fn walk_ropes<const ANY: bool>(&self, ray: &Ray) -> Option<Hit> {
        let inv = ray.dir.recip();
        let (mut t_enter, t_exit_root) = self.clip_root(ray, inv)?;
        let shear = RayShear::new(ray.dir);
        let mut best: Option<Hit> = None;
        let mut node = 0u32;
        // Each step moves to a leaf further along the ray; the bound only guards
        // against a malformed tree.
        for _ in 0..=self.leaves.len() {
            let leaf_id = self.locate(node, ray.origin + ray.dir * t_enter, ray.dir);
            if self.test_leaf::<ANY>(leaf_id, ray, &shear, &mut best) {
                return best;
            }
            let leaf = &self.leaves[leaf_id as usize];
            let (mut t_exit, mut exit_face) = (f32::INFINITY, usize::MAX);
            let mut t_face = [f32::INFINITY; 3];
            for a in 0..3 {
                let (bound, f) = if ray.dir[a] > 0.0 {
                    (leaf.max[a], 2 * a + 1)
                } else if ray.dir[a] < 0.0 {
                    (leaf.min[a], 2 * a)
                } else {
                    continue;
                };
                let t = (bound - ray.origin[a]) * inv[a];
                t_face[a] = t;
                if t < t_exit {
                    t_exit = t;
                    exit_face = f;
                }
            }
            // Leaving through a leaf edge or corner: also test the leaves
            // across the other tied faces (see the module doc of kdtree).
            if t_exit < t_exit_root {
                for a in 0..3 {
                    let f = 2 * a + (ray.dir[a] > 0.0) as usize;
                    if f == exit_face || t_face[a] - t_exit > 1e-6 * t_exit.abs() {
                        continue;
                    }
                    let rope = leaf.ropes[f];
                    if rope != NO_ROPE {
                        let side = self.locate(rope, ray.origin + ray.dir * t_exit, ray.dir);
                        if self.test_leaf::<ANY>(side, ray, &shear, &mut best) {
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
            if t_exit >= t_exit_root || exit_face == usize::MAX {
                return best;
            }
            let rope = leaf.ropes[exit_face];
            if rope == NO_ROPE {
                return best;
            }
            node = rope;
            t_enter = t_enter.max(t_exit);
        }
        best
    }

    /// The leaf under `node` containing `p` (ties go the way `dir` points).
    #[inline]
    fn locate(&self, mut node: u32, p: Vec3, dir: Vec3) -> u32 {
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
        self.walk_ropes::<false>(ray)
    }

    /// True if anything (front or back face) lies on the ray segment.
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.walk_ropes::<true>(ray).is_some()
    }

    /// Nearest hit by front-to-back traversal with an explicit stack (test oracle).
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
                    self.test_leaf::<false>(n.a, ray, &shear, &mut best);
                    break;
                }
                let a = n.kind as usize;
                let below_first = ray.origin[a] < n.split || (ray.origin[a] == n.split && ray.dir[a] <= 0.0);
                let (first, second) = if below_first { (n.a, n.b) } else { (n.b, n.a) };
                let t_split = (n.split - ray.origin[a]) * inv[a];
                if ray.dir[a] == 0.0 || t_split > tmax || t_split < 0.0 {
                    node = first;
                } else if t_split < tmin {
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
