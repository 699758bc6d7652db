//! The core of ray tracing that every tracer shares: the ray segment
//! ([`Ray`], with the one shadow-segment rule), the hit ([`Hit`]), the
//! triangle as traced ([`KdTriangle`]) and the watertight ray-triangle
//! test ([`intersect`]; Woop, Benthin & Wald 2013, "Watertight
//! Ray/Triangle Intersection", JCGT 2(1)): the triangle is sheared into
//! the ray's frame and the three edge functions are evaluated on the shared
//! corner coordinates, falling back to f64 when one is exactly zero. A ray
//! through a shared edge or vertex hits at least one of the triangles, so
//! closed meshes have no cracks (Möller-Trumbore lets about one ray in
//! 10^3-10^4 slip through edges of a regular grid). The kd-tree's four-wide
//! test (`kdtree/triangle.rs`) and the BVH's eight-wide one (`bvh/leaf.rs`)
//! repeat its operations lane by lane, so every lane's result is bit for
//! bit this one's.
//!
//! Two-sided: the hit records whether the ray met the front
//! (counter-clockwise) face. A back face blocks the ray and brings no light
//! (docs/DESIGN.md, units and conventions). Lengths in metres along a unit
//! direction.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// No vertex to skip.
pub const NO_SKIP: u32 = u32::MAX;

/// A ray segment `origin + t * dir`, `t` in `[tmin, tmax]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin, metres.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Start of the segment along `dir`, metres.
    pub tmin: f32,
    /// End of the segment along `dir`, metres (infinite: unbounded).
    pub tmax: f32,
    /// Solver vertex whose incident triangles are ignored, or [`NO_SKIP`].
    pub skip: u32,
}

impl Ray {
    /// An unbounded ray from `origin` along the unit `dir` (`tmin` 0, no vertex skipped).
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray { origin, dir, tmin: 0.0, tmax: f32::INFINITY, skip: NO_SKIP }
    }

    /// The shadow segment from `origin` toward a point `dist` away along the
    /// unit `dir`, from `tmin` (0, or a small offset off a vertex's own
    /// surface) to `max(eps, 1e-4 dist)` short of the point, never below
    /// `tmin`: the one rule of every shadow ray (light links, emitter links,
    /// the near field's, the CPU renderer's). The relative margin keeps the
    /// point's own surface off the segment where f32 rounding of a far
    /// point exceeds `eps` (metres); an infinite `dist` (a directional
    /// light) gives an unbounded segment; `skip` as in [`Ray::skip`].
    #[inline]
    pub fn shadow(origin: Vec3, dir: Vec3, dist: f32, eps: f32, tmin: f32, skip: u32) -> Ray {
        let tmax = if dist.is_finite() { (dist - eps.max(1e-4 * dist)).max(tmin) } else { f32::INFINITY };
        Ray { origin, dir, tmin, tmax, skip }
    }

    /// [`Ray::shadow`], or `None` where the point touches the origin
    /// (`dist <= 2 eps`) or the direction is not finite: nothing can lie in
    /// between, so the point counts as seen without a ray. The one home of
    /// that guard (light links, emitter links, the near field's lights and
    /// emitters).
    #[inline]
    pub fn shadow_checked(origin: Vec3, dir: Vec3, dist: f32, eps: f32, tmin: f32, skip: u32) -> Option<Ray> {
        (dist > 2.0 * eps && dir.is_finite()).then(|| Ray::shadow(origin, dir, dist, eps, tmin, skip))
    }

    /// A segment of no length from `origin` along the unit `dir`, which
    /// every tracer reports unoccluded: where [`Ray::shadow_checked`] finds
    /// a touching point and the caller keeps one ray per sample.
    #[inline]
    pub fn touching(origin: Vec3, dir: Vec3, skip: u32) -> Ray {
        Ray { origin, dir, tmin: 0.0, tmax: 0.0, skip }
    }
}

/// A triangle: its corners `v0, v1, v2` (counter-clockwise from the front;
/// stored as corners, not edges, so triangles sharing an edge see the same
/// floats and the watertight test leaves no cracks) and the solver vertex
/// ids of its corners (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct KdTriangle {
    /// Corner 0, metres.
    pub v0: [f32; 3],
    /// Solver vertex id of corner 0.
    pub ia: u32,
    /// Corner 1, metres.
    pub v1: [f32; 3],
    /// Solver vertex id of corner 1.
    pub ib: u32,
    /// Corner 2, metres.
    pub v2: [f32; 3],
    /// Solver vertex id of corner 2.
    pub ic: u32,
}

/// Nearest hit of a ray: triangle id, barycentrics of corners 1 and 2
/// (`1 - u - v` for corner 0), distance `t` in metres along a unit
/// direction, and which face was met.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The triangle's id.
    pub tri: u32,
    /// Barycentric weight of corner 1.
    pub u: f32,
    /// Barycentric weight of corner 2.
    pub v: f32,
    /// Distance along the ray, metres.
    pub t: f32,
    /// True if the ray met the front face (counter-clockwise side).
    pub front: bool,
}

impl Hit {
    /// Barycentric weights of the triangle's three corners.
    #[inline]
    pub fn barycentrics(&self) -> [f32; 3] {
        [1.0 - self.u - self.v, self.u, self.v]
    }
}

/// Per-ray constants of the watertight test: the permuted axes and shear.
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    pub(crate) kx: usize,
    pub(crate) ky: usize,
    pub(crate) kz: usize,
    pub(crate) sx: f32,
    pub(crate) sy: f32,
    pub(crate) sz: f32,
}

impl RayShear {
    /// The permuted axes `(kx, ky, kz)`: `kz` is the direction's largest component.
    #[inline(always)]
    pub fn axes(&self) -> (usize, usize, usize) {
        (self.kx, self.ky, self.kz)
    }

    /// Shear along x: `d[kx] / d[kz]`.
    #[inline(always)]
    pub fn sx(&self) -> f32 {
        self.sx
    }

    /// Shear along y: `d[ky] / d[kz]`.
    #[inline(always)]
    pub fn sy(&self) -> f32 {
        self.sy
    }

    /// Scale along z: `1 / d[kz]`.
    #[inline(always)]
    pub fn sz(&self) -> f32 {
        self.sz
    }

    /// The shear constants of a ray with direction `d`.
    #[inline]
    pub fn new(d: Vec3) -> RayShear {
        let kz = d.abs().max_position();
        // An array: glam indexes a `Vec3` through a branching `match`.
        let d = d.to_array();
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayShear { kx, ky, kz, sx: d[kx] / d[kz], sy: d[ky] / d[kz], sz: 1.0 / d[kz] }
    }
}

/// Intersects a ray (origin `o`, shear of its direction) with `tri`;
/// returns `(t, u, v, front)` for `t` in `[tmin, tmax]`.
#[inline(always)]
pub fn intersect(tri: &KdTriangle, o: Vec3, s: &RayShear, tmin: f32, tmax: f32) -> Option<(f32, f32, f32, bool)> {
    let a = Vec3::from(tri.v0) - o;
    let b = Vec3::from(tri.v1) - o;
    let c = Vec3::from(tri.v2) - o;
    let (ax, ay) = (a[s.kx] - s.sx * a[s.kz], a[s.ky] - s.sy * a[s.kz]);
    let (bx, by) = (b[s.kx] - s.sx * b[s.kz], b[s.ky] - s.sy * b[s.kz]);
    let (cx, cy) = (c[s.kx] - s.sx * c[s.kz], c[s.ky] - s.sy * c[s.kz]);
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let t_scaled = s.sz * (u * a[s.kz] + v * b[s.kz] + w * c[s.kz]);
    let inv = 1.0 / det;
    let t = t_scaled * inv;
    if !(t >= tmin && t <= tmax) {
        return None;
    }
    // det > 0: the corners run counter-clockwise as seen along the ray, i.e.
    // the ray meets the front face.
    Some((t, v * inv, w * inv, det > 0.0))
}
