//! Leaf ropes with the rope optimization of Popov et al. 2007: each rope is
//! pushed down from the neighbouring node as far as the neighbouring
//! subtree's splits allow while still covering the whole face.
//!
//! The two subtrees below each of the top few nodes get their ropes in
//! parallel: the tree is stored in preorder, so a subtree's leaves are one
//! contiguous run of the leaf array.

use super::{Aabb, KdLeaf, KdNode, KdTree, LEAF, NO_ROPE};

/// Depth down to which the two children's ropes are filled in parallel.
const PARALLEL_DEPTH: u32 = 3;

/// Face index `2*axis + (0 for the min side, 1 for the max side)`.
#[inline]
pub fn face(axis: usize, max_side: bool) -> usize {
    2 * axis + max_side as usize
}

/// Pushes rope `r` of face `f` of box `b` down the tree.
fn optimize(nodes: &[KdNode], mut r: u32, f: usize, b: &Aabb) -> u32 {
    let (fa, max_side) = (f / 2, f % 2 == 1);
    while r != NO_ROPE {
        let n = nodes[r as usize];
        if n.kind == LEAF {
            break;
        }
        let ax = n.kind as usize;
        if ax == fa {
            // The child of the neighbour that touches our face.
            r = if max_side { n.a } else { n.b };
        } else if n.split <= b.min[ax] {
            r = n.b;
        } else if n.split >= b.max[ax] {
            r = n.a;
        } else {
            break;
        }
    }
    r
}

/// The first leaf (in storage order) of the subtree under `node`.
fn first_leaf(nodes: &[KdNode], mut node: u32) -> u32 {
    while nodes[node as usize].kind != LEAF {
        node = nodes[node as usize].a;
    }
    nodes[node as usize].a
}

/// Fills the ropes of the leaves under `node`; `leaves` holds exactly those
/// leaves, the first of them being leaf number `leaf0`.
fn recurse(nodes: &[KdNode], leaves: &mut [KdLeaf], leaf0: u32, node: u32, b: Aabb, mut ropes: [u32; 6], depth: u32) {
    for (f, r) in ropes.iter_mut().enumerate() {
        *r = optimize(nodes, *r, f, &b);
    }
    let n = nodes[node as usize];
    if n.kind == LEAF {
        leaves[(n.a - leaf0) as usize].ropes = ropes;
        return;
    }
    let ax = n.kind as usize;
    let (lb, rb) = b.split(ax, n.split);
    let mut lr = ropes;
    lr[face(ax, true)] = n.b;
    let mut rr = ropes;
    rr[face(ax, false)] = n.a;
    if depth < PARALLEL_DEPTH {
        let mid = first_leaf(nodes, n.b);
        let (left, right) = leaves.split_at_mut((mid - leaf0) as usize);
        rayon::join(
            || recurse(nodes, left, leaf0, n.a, lb, lr, depth + 1),
            || recurse(nodes, right, mid, n.b, rb, rr, depth + 1),
        );
    } else {
        recurse(nodes, leaves, leaf0, n.a, lb, lr, depth + 1);
        recurse(nodes, leaves, leaf0, n.b, rb, rr, depth + 1);
    }
}

/// Fills the ropes of every leaf.
pub fn build_ropes(kd: &mut KdTree) {
    if kd.nodes.is_empty() {
        return;
    }
    let root = Aabb { min: kd.min, max: kd.max };
    recurse(&kd.nodes, &mut kd.leaves, 0, 0, root, [NO_ROPE; 6], 0);
}
