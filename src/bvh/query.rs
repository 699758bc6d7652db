//! Box queries on the 8-wide BVH: every triangle whose bounding box
//! overlaps a given box (closed intervals, so boxes that only touch
//! overlap). Used where geometry near a triangle matters rather than what
//! a ray meets (the a-priori contact splits, [`crate::scene::contact`]).
//!
//! A stack walk over the nodes: a slot is entered where its box overlaps
//! the query box on every axis; in a leaf each used lane's triangle box
//! (the min and max of its three corners) is tested the same way. Empty
//! slots have inverted boxes and unused lanes NaN corners, so neither ever
//! overlaps. Lengths in metres.

use super::{is_leaf, leaf::LANES, leaf::UNUSED, leaf_range, Bvh, EMPTY};
use glam::Vec3;

impl Bvh {
    /// Calls `visit` with the id of every triangle whose bounding box
    /// overlaps `[min, max]` (each once, in tree order).
    pub fn overlapping(&self, min: Vec3, max: Vec3, mut visit: impl FnMut(u32)) {
        if self.nodes.is_empty() || self.triangle_count == 0 {
            return;
        }
        let overlaps = |lo: Vec3, hi: Vec3| lo.cmple(max).all() && hi.cmpge(min).all();
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            for slot in 0..8 {
                let child = node.child[slot];
                if child == EMPTY {
                    continue;
                }
                let (lo, hi) = node.slot_box(slot);
                if !overlaps(lo, hi) {
                    continue;
                }
                if !is_leaf(child) {
                    stack.push(child);
                    continue;
                }
                let (first, count) = leaf_range(child);
                for block in &self.blocks[first as usize..(first + count) as usize] {
                    for lane in 0..LANES {
                        if block.tri[lane] == UNUSED {
                            continue;
                        }
                        let [a, b, c] = [0, 1, 2].map(|k| block.corner(k, lane));
                        if overlaps(a.min(b).min(c), a.max(b).max(c)) {
                            visit(block.tri[lane]);
                        }
                    }
                }
            }
        }
    }
}
