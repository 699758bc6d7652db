//! CPU-only copy of the leaf data, laid out for the CPU rope walk
//! ([`crate::kdtree::traverse`]). The GPU keeps using the shared
//! [`KdLeaf`](super::KdLeaf)/[`KdTriangle`](super::KdTriangle) layout; this
//! one only changes where the CPU reads the same numbers from, so every hit
//! is bit for bit the one the shared layout gives.
//!
//! - Leaves are 64-byte aligned (one cache line each).
//! - A rope whose target node is a leaf points at the leaf itself
//!   ([`ROPE_LEAF`] set), so following it skips the node load.
//! - Each leaf's triangles are copied, in the leaf's order, next to each
//!   other with their ids (one 64-byte line per reference), so testing a
//!   leaf reads one contiguous run instead of an index list plus scattered
//!   triangles. This costs about 64 bytes per triangle reference.

use super::{KdLeaf, KdNode, KdTriangle, LEAF, NO_ROPE};

/// Flag of a CPU rope that names a leaf (index in the low bits) instead of a node.
pub const ROPE_LEAF: u32 = 0x8000_0000;

/// A leaf for the CPU walk: box, range in [`CpuAccel::tris`], ropes.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CpuLeaf {
    pub min: [f32; 3],
    pub first: u32,
    pub max: [f32; 3],
    pub count: u32,
    /// As [`KdLeaf::ropes`], but a rope to a leaf node is `ROPE_LEAF | leaf`.
    pub ropes: [u32; 6],
}

/// One triangle reference of a leaf: the triangle and its id.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CpuTri {
    pub tri: KdTriangle,
    pub id: u32,
}

/// The CPU-only leaf layout of a tree.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CpuAccel {
    pub leaves: Vec<CpuLeaf>,
    /// Triangle references in leaf order (the order of `KdTree::leaf_triangles`).
    pub tris: Vec<CpuTri>,
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
        CpuAccel {
            leaves: leaves
                .iter()
                .map(|l| CpuLeaf { min: l.min, first: l.first, max: l.max, count: l.count, ropes: l.ropes.map(rope) })
                .collect(),
            tris: leaf_triangles.iter().map(|&id| CpuTri { tri: triangles[id as usize], id }).collect(),
        }
    }

    /// Bytes of the layout.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.leaves.as_slice()) + std::mem::size_of_val(self.tris.as_slice())
    }
}
