//! CPU-only copy of the leaf data, laid out for the CPU rope walk
//! ([`crate::kdtree::traverse`]). The GPU keeps using the shared
//! [`super::KdLeaf`]/[`super::KdTriangle`] layout; this
//! one only changes where the CPU reads the same numbers from, so every hit
//! is bit for bit the one the shared layout gives.
//!
//! - Leaves are 64-byte aligned (one cache line each).
//! - A rope whose target node is a leaf points at the leaf itself
//!   ([`ROPE_LEAF`] set), so following it skips the node load.
//! - Each leaf's triangles are copied, in the leaf's order, into blocks of
//!   four ([`Tri4`], structure of arrays, tested four at a time by
//!   [`intersect4`](super::triangle::intersect4)); a leaf's blocks are
//!   contiguous, so testing it reads one run instead of an index list plus
//!   scattered triangles. Corner vertex ids and triangle ids follow the
//!   corners in the block (read only for lanes that hit). This costs 208
//!   bytes per started block of four references.

use super::triangle::Tri4;
use super::{KdLeaf, KdNode, LEAF, NO_ROPE};
use crate::trace::ray::KdTriangle;

/// Flag of a CPU rope that names a leaf (index in the low bits) instead of a node.
pub const ROPE_LEAF: u32 = 0x8000_0000;

/// A leaf for the CPU walk: box, triangles, ropes.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CpuLeaf {
    /// Minimum corner of the leaf's box, metres.
    pub min: [f32; 3],
    /// First block in [`CpuAccel::blocks`].
    pub first: u32,
    /// Maximum corner of the leaf's box, metres.
    pub max: [f32; 3],
    /// Triangle references (in `ceil(count / 4)` blocks).
    pub count: u32,
    /// As [`KdLeaf::ropes`], but a rope to a leaf node is `ROPE_LEAF | leaf`.
    pub ropes: [u32; 6],
}

/// The CPU-only leaf layout of a tree.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CpuAccel {
    /// The leaves, in the order of [`KdTree::leaves`](super::KdTree::leaves).
    pub leaves: Vec<CpuLeaf>,
    /// Leaf triangles, four per block, leaf after leaf in leaf order.
    pub blocks: Vec<CpuBlock>,
}

/// Four triangle references of a leaf: corners, and per lane the corner
/// vertex ids `ia, ib, ic` and the triangle id (read only for lanes that hit).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CpuBlock {
    /// The four triangles' corners.
    pub tri: Tri4,
    /// Per lane: `[ia, ib, ic, triangle id]`.
    pub lanes: [[u32; 4]; 4],
}

impl CpuAccel {
    /// Derives the layout from the shared one.
    pub fn new(nodes: &[KdNode], leaves: &[KdLeaf], leaf_triangles: &[u32], triangles: &[KdTriangle]) -> CpuAccel {
        let rope = |r: u32| {
            if r == NO_ROPE {
                return NO_ROPE;
            }
            let n = nodes[r as usize];
            if n.kind == LEAF {
                ROPE_LEAF | n.a
            } else {
                r
            }
        };
        let mut out = CpuAccel { leaves: Vec::with_capacity(leaves.len()), ..Default::default() };
        for l in leaves {
            out.leaves.push(CpuLeaf {
                min: l.min,
                first: out.blocks.len() as u32,
                max: l.max,
                count: l.count,
                ropes: l.ropes.map(rope),
            });
            for ids in leaf_triangles[l.first as usize..(l.first + l.count) as usize].chunks(4) {
                let mut block = Tri4::default();
                let mut lanes = [[0u32; 4]; 4];
                for (lane, &id) in ids.iter().enumerate() {
                    let t = &triangles[id as usize];
                    for (c, v) in [t.v0, t.v1, t.v2].into_iter().enumerate() {
                        for (k, x) in v.into_iter().enumerate() {
                            block.v[c][k][lane] = x;
                        }
                    }
                    lanes[lane] = [t.ia, t.ib, t.ic, id];
                }
                out.blocks.push(CpuBlock { tri: block, lanes });
            }
        }
        out
    }

    /// Bytes of the layout.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.leaves.as_slice()) + std::mem::size_of_val(self.blocks.as_slice())
    }
}
