//! What a deformation moved: the analysis behind selective updates
//! (docs/DESIGN.md §7).
//!
//! Given the prepared scene before and after a deformation (same vertices
//! and triangles, new positions and normals), [`Motion::between`] finds
//!
//! - the **moved triangles**: a corner's position changed;
//! - the **remade vertices**: everything a vertex's rays and shadow rays
//!   start from may have changed, so all of them are traced anew. That is
//!   a vertex whose position or normal changed, or one with a moved
//!   incident triangle or ring neighbour (its ray origin, wedges and
//!   one-ring oversampling points depend on those);
//! - per mesh with moved triangles, the axis-aligned **box** of those
//!   triangles before and after the move (one box over both), which every
//!   ray segment that can have changed meets.
//!
//! Every other vertex keeps its rays; one of its rays can only change if
//! its old hit lies on a moved triangle or if a moved triangle now lies on
//! its segment (see `links::selective`). Positions in metres.

use super::prep::PreparedScene;

pub use crate::kdtree::Aabb;

/// What moved between two states of one prepared scene.
#[derive(Clone, Debug)]
pub struct Motion {
    /// Per vertex: all its rays and shadow rays are traced anew.
    pub remade: Vec<bool>,
    /// Per triangle: a corner moved.
    pub moved_triangle: Vec<bool>,
    /// The moved triangles (solver vertex ids).
    pub moved_triangles: Vec<[u32; 3]>,
    /// Per mesh with moved triangles: the box of those triangles before and
    /// after the move, with a rounding margin.
    pub boxes: Vec<Aabb>,
    /// The box of the moved triangles after the move, with a rounding margin.
    pub new_box: Aabb,
    /// Number of remade vertices.
    pub remade_count: usize,
}

impl Motion {
    /// The motion from `old` to `new`; `None` when they are not two states
    /// of one mesh (vertex count or triangles differ).
    pub fn between(old: &PreparedScene, new: &PreparedScene) -> Option<Motion> {
        let n = new.vertex_count();
        if old.vertex_count() != n || old.triangles != new.triangles {
            return None;
        }
        let moved: Vec<bool> = (0..n).map(|v| old.positions[v] != new.positions[v]).collect();
        let moved_triangle: Vec<bool> = new.triangles.iter().map(|t| t.iter().any(|&i| moved[i as usize])).collect();
        let remade: Vec<bool> = (0..n)
            .map(|v| {
                moved[v]
                    || old.normals[v] != new.normals[v]
                    || new.rings.row(v).iter().any(|&u| moved[u as usize])
                    || new.vertex_triangles.row(v).iter().any(|&t| moved_triangle[t as usize])
            })
            .collect();
        let mut moved_triangles = Vec::new();
        let mut boxes = Vec::new();
        let mut new_box = Aabb::EMPTY;
        for m in &new.meshes {
            let mut b = Aabb::EMPTY;
            let mut nb = Aabb::EMPTY;
            let range = m.triangles.start as usize..m.triangles.end as usize;
            for (&tri, _) in new.triangles[range.clone()].iter().zip(&moved_triangle[range]).filter(|(_, &m)| m) {
                moved_triangles.push(tri);
                for &i in &tri {
                    b.grow(old.positions[i as usize]);
                    nb.grow(new.positions[i as usize]);
                }
            }
            if !nb.is_empty() {
                let both = b.union(nb);
                boxes.push(both.expanded(both.rounding_margin()));
                new_box = new_box.union(nb);
            }
        }
        if !new_box.is_empty() {
            new_box = new_box.expanded(new_box.rounding_margin());
        }
        let remade_count = remade.iter().filter(|&&r| r).count();
        Some(Motion { remade, moved_triangle, moved_triangles, boxes, new_box, remade_count })
    }

    /// True when nothing moved and no normal changed.
    #[cfg(any(test, feature = "internals"))]
    pub fn is_empty(&self) -> bool {
        self.remade_count == 0 && self.moved_triangles.is_empty()
    }

    /// The union of [`Motion::boxes`].
    pub fn union_box(&self) -> Aabb {
        self.boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(*b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn segment_box() {
        let b = Aabb { min: Vec3::ZERO, max: Vec3::ONE };
        let o = Vec3::new(-1.0, 0.5, 0.5);
        let d = Vec3::X;
        assert!(b.meets_segment(o, d.recip(), 0.0, f32::INFINITY));
        assert!(!b.meets_segment(o, d.recip(), 0.0, 0.9));
        assert!(b.meets_segment(o, d.recip(), 0.0, 1.0));
        assert!(!b.meets_segment(o, (-d).recip(), 0.0, f32::INFINITY));
        // In the slab's plane (d.y = 0 with o.y on the face).
        let o2 = Vec3::new(-1.0, 1.0, 0.5);
        assert!(b.meets_segment(o2, d.recip(), 0.0, 5.0));
        assert!(!b.meets_segment(Vec3::new(-1.0, 1.5, 0.5), d.recip(), 0.0, 5.0));
    }

    #[test]
    fn plane_cull() {
        let b = Aabb { min: Vec3::new(-1.0, -3.0, -1.0), max: Vec3::new(1.0, -2.0, 1.0) };
        assert!(b.below_plane(Vec3::ZERO, Vec3::Y, 0.0));
        assert!(!b.below_plane(Vec3::ZERO, -Vec3::Y, 0.0));
        assert!(!b.below_plane(Vec3::new(0.0, -2.5, 0.0), Vec3::Y, 0.0));
    }
}
