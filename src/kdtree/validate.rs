//! Structural checks of a built tree, called from every test that builds one.

use super::{Aabb, KdTree, LEAF, NO_ROPE};
use glam::Vec3;

impl KdTree {
    /// Checks: child indices in range and each node reached once; splits
    /// inside their node's bounds; leaf boxes equal the boxes implied by the
    /// splits; triangle ids in range; every triangle reachable (a point
    /// inside it lies in a leaf that lists it); ropes point at a node whose
    /// box touches the face and covers it, or leave the scene exactly when
    /// the face lies on the scene bounds; the CPU-only copy matches.
    pub fn validate(&self) -> Result<(), String> {
        if self.nodes.is_empty() {
            return Err("tree has no nodes".into());
        }
        let boxes = self.node_boxes();
        let mut seen = vec![false; self.nodes.len()];
        let mut leaf_seen = vec![false; self.leaves.len()];
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let i = n as usize;
            if i >= self.nodes.len() {
                return Err(format!("node index {n} out of range"));
            }
            if std::mem::replace(&mut seen[i], true) {
                return Err(format!("node {n} reached twice"));
            }
            let node = self.nodes[i];
            let b = boxes[i];
            if node.kind == LEAF {
                let li = node.a as usize;
                if li >= self.leaves.len() || std::mem::replace(&mut leaf_seen[li], true) {
                    return Err(format!("node {n}: leaf index {li} out of range or shared"));
                }
                let leaf = &self.leaves[li];
                if Vec3::from(leaf.min) != b.min || Vec3::from(leaf.max) != b.max {
                    return Err(format!("leaf {li}: stored box differs from the split box"));
                }
                if (leaf.first + leaf.count) as usize > self.leaf_triangles.len() {
                    return Err(format!("leaf {li}: triangle range out of bounds"));
                }
            } else {
                if node.kind > 2 {
                    return Err(format!("node {n}: bad kind {}", node.kind));
                }
                let a = node.kind as usize;
                if !(node.split >= b.min[a] && node.split <= b.max[a]) {
                    return Err(format!("node {n}: split {} outside [{}, {}]", node.split, b.min[a], b.max[a]));
                }
                stack.push(node.a);
                stack.push(node.b);
            }
        }
        if let Some(i) = seen.iter().position(|s| !s) {
            return Err(format!("node {i} is unreachable"));
        }
        if let Some(&bad) = self.leaf_triangles.iter().find(|&&t| t as usize >= self.triangles.len()) {
            return Err(format!("leaf references triangle {bad} of {}", self.triangles.len()));
        }
        if self.accel != super::CpuAccel::new(&self.nodes, &self.leaves, &self.leaf_triangles, &self.triangles) {
            return Err("the CPU leaf copy (accel) differs from the shared layout".into());
        }
        self.validate_reachable()?;
        self.validate_ropes(&boxes)
    }

    /// Every leaf containing point `p` (both sides on ties).
    fn leaves_at(&self, p: Vec3, out: &mut Vec<u32>) {
        out.clear();
        let mut stack = vec![0u32];
        while let Some(n) = stack.pop() {
            let node = self.nodes[n as usize];
            if node.kind == LEAF {
                out.push(node.a);
                continue;
            }
            let a = node.kind as usize;
            if p[a] <= node.split {
                stack.push(node.a);
            }
            if p[a] >= node.split {
                stack.push(node.b);
            }
        }
    }

    fn validate_reachable(&self) -> Result<(), String> {
        let mut leaves = Vec::new();
        for (id, tri) in self.triangles.iter().enumerate() {
            let v0 = Vec3::from(tri.v0);
            let (e1, e2) = (Vec3::from(tri.v1) - v0, Vec3::from(tri.v2) - v0);
            // The centroid and points near each corner.
            for (u, v) in [(1.0 / 3.0, 1.0 / 3.0), (0.02, 0.02), (0.96, 0.02), (0.02, 0.96)] {
                let p = v0 + e1 * u + e2 * v;
                self.leaves_at(p.clamp(self.min, self.max), &mut leaves);
                let found = leaves.iter().any(|&l| {
                    let lf = &self.leaves[l as usize];
                    self.leaf_triangles[lf.first as usize..(lf.first + lf.count) as usize].contains(&(id as u32))
                });
                if !found {
                    return Err(format!("triangle {id} is not listed in the leaf containing its point {p}"));
                }
            }
        }
        Ok(())
    }

    fn validate_ropes(&self, boxes: &[Aabb]) -> Result<(), String> {
        for (li, leaf) in self.leaves.iter().enumerate() {
            let (lmin, lmax) = (Vec3::from(leaf.min), Vec3::from(leaf.max));
            for f in 0..6 {
                let (a, max_side) = (f / 2, f % 2 == 1);
                let plane = if max_side { lmax[a] } else { lmin[a] };
                let on_bounds = if max_side { plane >= self.max[a] } else { plane <= self.min[a] };
                let r = leaf.ropes[f];
                if r == NO_ROPE {
                    if !on_bounds {
                        return Err(format!("leaf {li} face {f}: no rope but the face is inside the scene"));
                    }
                    continue;
                }
                if on_bounds {
                    return Err(format!("leaf {li} face {f}: rope {r} on a face on the scene bounds"));
                }
                let Some(nb) = boxes.get(r as usize) else {
                    return Err(format!("leaf {li} face {f}: rope {r} out of range"));
                };
                let touches = if max_side { nb.min[a] == plane } else { nb.max[a] == plane };
                let covers = (0..3).filter(|&b| b != a).all(|b| nb.min[b] <= lmin[b] && nb.max[b] >= lmax[b]);
                if !touches || !covers {
                    return Err(format!(
                        "leaf {li} face {f}: rope {r} box {:?} does not touch and cover the face of {:?}",
                        nb,
                        Aabb { min: lmin, max: lmax }
                    ));
                }
            }
        }
        Ok(())
    }
}
