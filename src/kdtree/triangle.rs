//! Ray-triangle intersection (Möller & Trumbore 1997), two-sided: the hit
//! records whether the ray met the front (counter-clockwise) face. A back
//! face blocks the ray and brings no light (DESIGN.md units and conventions).

use super::KdTriangle;
use glam::Vec3;

/// Nearest hit of a ray: triangle id, barycentrics of corners 1 and 2
/// (`a = 1 - u - v` for corner 0), distance `t` in metres along a unit
/// direction, and which face was met.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub tri: u32,
    pub u: f32,
    pub v: f32,
    pub t: f32,
    pub front: bool,
}

impl Hit {
    /// Barycentric weights of the triangle's three corners.
    #[inline]
    pub fn barycentrics(&self) -> [f32; 3] {
        [1.0 - self.u - self.v, self.u, self.v]
    }
}

/// Intersects a ray with `tri`; returns `(t, u, v, front)` for `t` in `[tmin, tmax]`.
#[inline(always)]
pub fn intersect(tri: &KdTriangle, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, f32, f32, bool)> {
    let e1 = Vec3::from(tri.e1);
    let e2 = Vec3::from(tri.e2);
    let pvec = d.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let tvec = o - Vec3::from(tri.v0);
    let u = tvec.dot(pvec) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let v = d.dot(qvec) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(qvec) * inv;
    if t < tmin || t > tmax {
        return None;
    }
    // det = -d . (e1 x e2): positive when the ray meets the front face.
    Some((t, u, v, det > 0.0))
}
