//! Refitting for deforming meshes, and the SAH cost that decides between a
//! refit and a rebuild.
//!
//! [`Bvh::refit`] keeps the tree's topology and recomputes every box from
//! the new vertex positions in O(n): the leaf blocks' corners are
//! rewritten from their vertex ids (in parallel), then the node boxes are
//! recomputed children first (nodes are stored in preorder, so walking the
//! node array backwards sees every child before its parent). The tree
//! stays valid for any motion, but a refitted tree can be much slower than
//! a fresh one when triangles move far; [`Bvh::update`] rebuilds when the
//! refitted SAH cost exceeds `rebuild_factor` times the last build's.

use super::leaf::{LANES, UNUSED};
use super::{is_leaf, leaf_range, Bvh, EMPTY};
use glam::Vec3;
use rayon::prelude::*;
use std::time::Instant;

/// What [`Bvh::update`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Update {
    /// The tree was refitted to the new positions.
    Refit,
    /// The tree was built again (the refitted SAH cost was too high, or the triangle count changed).
    Rebuild,
}

fn area(lo: Vec3, hi: Vec3) -> f32 {
    let d = (hi - lo).max(Vec3::ZERO);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

impl Bvh {
    /// Box of a leaf child's used lanes.
    fn leaf_box(&self, child: u32) -> (Vec3, Vec3) {
        let (first, count) = leaf_range(child);
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for blk in &self.blocks[first as usize..(first + count) as usize] {
            for lane in 0..LANES {
                if blk.tri[lane] == UNUSED {
                    continue;
                }
                for c in 0..3 {
                    let p = blk.corner(c, lane);
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
            }
        }
        (lo, hi)
    }

    /// Moves every triangle to `positions` (same vertex ids, same
    /// triangles as the build) and refits all boxes; the SAH cost in
    /// `stats` is updated.
    pub fn refit(&mut self, positions: &[Vec3]) {
        let start = Instant::now();
        self.blocks.par_iter_mut().for_each(|blk| {
            for lane in 0..LANES {
                if blk.tri[lane] == UNUSED {
                    continue;
                }
                for c in 0..3 {
                    let p = positions[blk.corners[c][lane] as usize];
                    for k in 0..3 {
                        blk.v[c][k][lane] = p[k];
                    }
                }
            }
        });
        let mut boxes = vec![(Vec3::INFINITY, Vec3::NEG_INFINITY); self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for slot in 0..8 {
                let c = self.nodes[i].child[slot];
                if c == EMPTY {
                    continue;
                }
                let (clo, chi) = if is_leaf(c) { self.leaf_box(c) } else { boxes[c as usize] };
                self.nodes[i].set_slot(slot, c, clo, chi);
                lo = lo.min(clo);
                hi = hi.max(chi);
            }
            self.nodes[i].set_order();
            boxes[i] = (lo, hi);
        }
        if let Some(&(lo, hi)) = boxes.first() {
            (self.min, self.max) = (lo, hi);
        }
        self.stats.sah_cost = self.sah_cost();
        self.stats.refit_ms = start.elapsed().as_secs_f64() * 1e3;
    }

    /// Brings the tree to `positions`: a refit, or a rebuild over
    /// `triangles` when the refitted SAH cost exceeds
    /// `params.rebuild_factor` times the last build's (or the triangle
    /// count changed).
    pub fn update(&mut self, positions: &[Vec3], triangles: &[[u32; 3]]) -> Update {
        if triangles.len() == self.triangle_count {
            self.refit(positions);
            if self.stats.sah_cost <= self.params.rebuild_factor * self.stats.fresh_sah_cost {
                return Update::Refit;
            }
        }
        let (params, isa) = (self.params, self.isa);
        *self = Bvh::build(positions, triangles, &params);
        self.set_isa(isa);
        Update::Rebuild
    }

    /// Expected cost of a ray by the surface area heuristic: every node
    /// test weighted by its box's area over the root's, plus every leaf's
    /// blocks likewise (units of one block test).
    pub fn sah_cost(&self) -> f32 {
        let root = area(self.min, self.max);
        if !(root > 0.0) || self.nodes.is_empty() {
            return 0.0;
        }
        let p = &self.params;
        let mut cost = p.traversal_cost as f64;
        for n in &self.nodes {
            for slot in 0..8 {
                let c = n.child[slot];
                if c == EMPTY {
                    continue;
                }
                let (lo, hi) = n.slot_box(slot);
                let w = (area(lo, hi) / root) as f64;
                cost +=
                    w * if is_leaf(c) { p.intersect_cost * leaf_range(c).1 as f32 } else { p.traversal_cost } as f64;
            }
        }
        cost as f32
    }
}
