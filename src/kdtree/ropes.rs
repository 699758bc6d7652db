//! Leaf ropes with the rope optimization of Popov et al. 2007: each rope is
//! pushed down from the neighbouring node as far as the neighbouring
//! subtree's splits allow while still covering the whole face.

use super::{Aabb, KdTree, LEAF, NO_ROPE};

/// Face index `2*axis + (0 for the min side, 1 for the max side)`.
#[inline]
pub fn face(axis: usize, max_side: bool) -> usize {
    2 * axis + max_side as usize
}

/// Pushes rope `r` of face `f` of box `b` down the tree.
fn optimize(kd: &KdTree, mut r: u32, f: usize, b: &Aabb) -> u32 {
    let (fa, max_side) = (f / 2, f % 2 == 1);
    while r != NO_ROPE {
        let n = kd.nodes[r as usize];
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

fn recurse(kd: &mut KdTree, node: u32, b: Aabb, mut ropes: [u32; 6]) {
    for (f, r) in ropes.iter_mut().enumerate() {
        *r = optimize(kd, *r, f, &b);
    }
    let n = kd.nodes[node as usize];
    if n.kind == LEAF {
        kd.leaves[n.a as usize].ropes = ropes;
        return;
    }
    let ax = n.kind as usize;
    let (lb, rb) = b.split(ax, n.split);
    let mut lr = ropes;
    lr[face(ax, true)] = n.b;
    let mut rr = ropes;
    rr[face(ax, false)] = n.a;
    recurse(kd, n.a, lb, lr);
    recurse(kd, n.b, rb, rr);
}

/// Fills the ropes of every leaf.
pub fn build_ropes(kd: &mut KdTree) {
    if kd.nodes.is_empty() {
        return;
    }
    let root = Aabb { min: kd.min, max: kd.max };
    recurse(kd, 0, root, [NO_ROPE; 6]);
}
