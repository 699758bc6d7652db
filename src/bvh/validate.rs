//! Structural checks of a built or refitted BVH, called from every test
//! that builds one.

use super::leaf::{LANES, UNUSED};
use super::{is_leaf, leaf_range, Bvh, EMPTY};
use glam::Vec3;

impl Bvh {
    /// Checks: node indices in range, every node reached once from the
    /// root and stored after its parent (preorder, which the refit needs);
    /// leaf block ranges in range and not shared; every triangle id
    /// `0..triangle_count` in exactly one lane of a reachable leaf; unused
    /// lanes have NaN corners; empty slots have inverted boxes; each inner
    /// child's slot box holds all of that child's slot boxes; each leaf's
    /// slot box holds its triangles' corners; the scene bounds hold the
    /// root's children.
    pub fn validate(&self) -> Result<(), String> {
        if self.nodes.is_empty() {
            return if self.triangle_count == 0 { Ok(()) } else { Err("no nodes but triangles".into()) };
        }
        let mut seen = vec![false; self.nodes.len()];
        let mut block_seen = vec![false; self.blocks.len()];
        let mut tri_seen = vec![false; self.triangle_count];
        let inside = |lo: Vec3, hi: Vec3, olo: Vec3, ohi: Vec3| lo.cmpge(olo).all() && hi.cmple(ohi).all();
        let mut stack = vec![0u32];
        seen[0] = true;
        while let Some(i) = stack.pop() {
            let n = &self.nodes[i as usize];
            for slot in 0..8 {
                let c = n.child[slot];
                let (lo, hi) = n.slot_box(slot);
                if c == EMPTY {
                    if !n.slot_box(slot).0.cmpgt(n.slot_box(slot).1).all() {
                        return Err(format!("node {i} slot {slot}: empty slot with a real box"));
                    }
                    continue;
                }
                if i == 0 && !inside(lo, hi, self.min, self.max) {
                    return Err(format!("root slot {slot}: box outside the scene bounds"));
                }
                if is_leaf(c) {
                    let (first, count) = leaf_range(c);
                    if (first + count) as usize > self.blocks.len() {
                        return Err(format!("node {i} slot {slot}: blocks {first}+{count} out of range"));
                    }
                    for b in first..first + count {
                        if std::mem::replace(&mut block_seen[b as usize], true) {
                            return Err(format!("block {b} shared by two leaves"));
                        }
                        let blk = &self.blocks[b as usize];
                        for lane in 0..LANES {
                            let id = blk.tri[lane];
                            let corners = (0..3).map(|c| blk.corner(c, lane));
                            if id == UNUSED {
                                if corners.clone().any(|p| !p.is_nan())
                                    || (0..3).any(|c| blk.corners[c][lane] != UNUSED)
                                {
                                    return Err(format!("block {b} lane {lane}: unused lane with corners"));
                                }
                                continue;
                            }
                            if id as usize >= self.triangle_count {
                                return Err(format!("block {b} lane {lane}: triangle {id} out of range"));
                            }
                            if std::mem::replace(&mut tri_seen[id as usize], true) {
                                return Err(format!("triangle {id} in two lanes"));
                            }
                            for p in corners {
                                if !inside(p, p, lo, hi) {
                                    return Err(format!("triangle {id}: corner {p} outside its leaf box"));
                                }
                            }
                        }
                    }
                } else {
                    if c as usize >= self.nodes.len() || c <= i {
                        return Err(format!("node {i} slot {slot}: child node {c} out of range or before its parent"));
                    }
                    if std::mem::replace(&mut seen[c as usize], true) {
                        return Err(format!("node {c} reached twice"));
                    }
                    let cn = &self.nodes[c as usize];
                    for s in 0..8 {
                        if cn.child[s] == EMPTY {
                            continue;
                        }
                        let (clo, chi) = cn.slot_box(s);
                        if !inside(clo, chi, lo, hi) {
                            return Err(format!("node {c} slot {s}: box outside its parent's slot box"));
                        }
                    }
                    stack.push(c);
                }
            }
        }
        if let Some(n) = seen.iter().position(|s| !s) {
            return Err(format!("node {n} unreachable"));
        }
        if let Some(t) = tri_seen.iter().position(|s| !s) {
            return Err(format!("triangle {t} unreachable"));
        }
        Ok(())
    }
}
