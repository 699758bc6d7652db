//! Watertight ray-triangle intersection (Woop, Benthin & Wald 2013,
//! "Watertight Ray/Triangle Intersection", JCGT 2(1)): the triangle is
//! sheared into the ray's frame and the three edge functions are evaluated
//! on the shared corner coordinates, falling back to f64 when one is exactly
//! zero. A ray through a shared edge or vertex hits at least one of the
//! triangles, so closed meshes have no cracks (Möller-Trumbore lets about
//! one ray in 10^3-10^4 slip through edges of a regular grid).
//!
//! [`intersect4`] tests four triangles at once (SIMD lanes, structure of
//! arrays) with exactly the operations of [`intersect`] in each lane, so
//! every lane's result is bit for bit the scalar one.
//!
//! Two-sided: the hit records whether the ray met the front
//! (counter-clockwise) face. A back face blocks the ray and brings no light
//! (docs/DESIGN.md, units and conventions).

use super::KdTriangle;
use glam::{Vec3, Vec4};

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
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
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

/// Four triangles' corners as structure of arrays, `v[corner][axis][lane]`
/// (the CPU walk's leaf blocks; unused lanes are zero).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tri4 {
    /// Corners `v[corner][axis][lane]`, metres.
    pub v: [[[f32; 4]; 3]; 3],
}

/// Lane results of [`intersect4`]: `mask` bit `i` set where lane `i` hits.
#[derive(Clone, Copy, Debug)]
pub struct Hits4 {
    /// Bit `i` set where lane `i` hits.
    pub mask: u32,
    /// Hit distance per lane, metres (valid where the lane hits).
    pub t: [f32; 4],
    /// Barycentric weight of corner 1 per lane.
    pub u: [f32; 4],
    /// Barycentric weight of corner 2 per lane.
    pub v: [f32; 4],
    /// Bit `i` set where lane `i` meets the front face.
    pub front: u32,
}

/// [`intersect`] on the lanes of `tri` set in `lanes`, four at a time.
#[inline(always)]
pub fn intersect4(tri: &Tri4, lanes: u32, o: Vec3, s: &RayShear, tmin: f32, tmax: f32) -> Hits4 {
    // An array: glam indexes a `Vec3` through a branching `match`.
    let o = o.to_array();
    let p = |c: usize, k: usize| Vec4::from_array(tri.v[c][k]) - Vec4::splat(o[k]);
    let (akx, aky, akz) = (p(0, s.kx), p(0, s.ky), p(0, s.kz));
    let (bkx, bky, bkz) = (p(1, s.kx), p(1, s.ky), p(1, s.kz));
    let (ckx, cky, ckz) = (p(2, s.kx), p(2, s.ky), p(2, s.kz));
    let (sx, sy) = (Vec4::splat(s.sx), Vec4::splat(s.sy));
    let (ax, ay) = (akx - sx * akz, aky - sy * akz);
    let (bx, by) = (bkx - sx * bkz, bky - sy * bkz);
    let (cx, cy) = (ckx - sx * ckz, cky - sy * ckz);
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    let z = Vec4::ZERO;
    let zero = (u.cmpeq(z) | v.cmpeq(z) | w.cmpeq(z)).bitmask() & lanes;
    if zero != 0 {
        let (mut ua, mut va, mut wa) = (u.to_array(), v.to_array(), w.to_array());
        let (axa, aya, bxa, bya, cxa, cya) =
            (ax.to_array(), ay.to_array(), bx.to_array(), by.to_array(), cx.to_array(), cy.to_array());
        for i in 0..4 {
            if zero >> i & 1 == 1 {
                let (ax, ay, bx, by, cx, cy) =
                    (axa[i] as f64, aya[i] as f64, bxa[i] as f64, bya[i] as f64, cxa[i] as f64, cya[i] as f64);
                ua[i] = (cx * by - cy * bx) as f32;
                va[i] = (ax * cy - ay * cx) as f32;
                wa[i] = (bx * ay - by * ax) as f32;
            }
        }
        (u, v, w) = (Vec4::from_array(ua), Vec4::from_array(va), Vec4::from_array(wa));
    }
    let neg = (u.cmplt(z) | v.cmplt(z) | w.cmplt(z)).bitmask();
    let pos = (u.cmpgt(z) | v.cmpgt(z) | w.cmpgt(z)).bitmask();
    let det = u + v + w;
    let t_scaled = Vec4::splat(s.sz) * (u * akz + v * bkz + w * ckz);
    let inv = Vec4::ONE / det;
    let t = t_scaled * inv;
    let in_range = (t.cmpge(Vec4::splat(tmin)) & t.cmple(Vec4::splat(tmax))).bitmask();
    let mask = lanes & !(neg & pos) & !det.cmpeq(z).bitmask() & in_range;
    Hits4 { mask, t: t.to_array(), u: (v * inv).to_array(), v: (w * inv).to_array(), front: det.cmpgt(z).bitmask() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn tri(a: Vec3, b: Vec3, c: Vec3) -> KdTriangle {
        KdTriangle { v0: a.into(), v1: b.into(), v2: c.into(), ..Default::default() }
    }

    #[test]
    fn hit_matches_geometry_and_facing() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(3);
        let mut r = || Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let mut hits = 0;
        for _ in 0..20000 {
            let (a, b, c, o) = (r(), r(), r(), r() * 3.0);
            let target = r();
            let d = (target - o).normalize();
            let t = tri(a, b, c);
            if let Some((tt, u, v, front)) = intersect(&t, o, &RayShear::new(d), 0.0, f32::INFINITY) {
                hits += 1;
                let p = a * (1.0 - u - v) + b * u + c * v;
                assert!((o + d * tt - p).length() < 1e-4, "hit point mismatch");
                let n = (b - a).cross(c - a);
                assert_eq!(front, d.dot(n) < 0.0);
                assert!(u >= 0.0 && v >= 0.0 && u + v <= 1.0 + 1e-6);
            }
        }
        assert!(hits > 1000);
    }

    #[test]
    fn four_lanes_equal_scalar() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
        let mut r = || Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let mut hits = 0;
        for i in 0..20000 {
            // Some triangles on a coarse grid and rays through their corners
            // exercise the f64 fallback.
            let q = |v: Vec3| if i % 3 == 0 { (v * 4.0).round() / 4.0 } else { v };
            let tris: Vec<KdTriangle> = (0..4).map(|_| tri(q(r()), q(r()), q(r()))).collect();
            let o = q(r() * 2.0);
            let d = if i % 3 == 0 { (Vec3::from(tris[0].v1) - o).normalize() } else { r().normalize() };
            let s = RayShear::new(d);
            let mut t4 = Tri4::default();
            for (l, t) in tris.iter().enumerate() {
                for (c, v) in [t.v0, t.v1, t.v2].into_iter().enumerate() {
                    for (k, x) in v.into_iter().enumerate() {
                        t4.v[c][k][l] = x;
                    }
                }
            }
            let tmax = if i % 2 == 0 { f32::INFINITY } else { 1.5 };
            let lanes = if i % 5 == 0 { 0b0111 } else { 0b1111 };
            let h = intersect4(&t4, lanes, o, &s, 0.0, tmax);
            for (l, t) in tris.iter().enumerate() {
                let scalar = if lanes >> l & 1 == 1 { intersect(t, o, &s, 0.0, tmax) } else { None };
                let lane = (h.mask >> l & 1 == 1).then(|| (h.t[l], h.u[l], h.v[l], h.front >> l & 1 == 1));
                assert_eq!(
                    scalar.map(|x| (x.0.to_bits(), x.1.to_bits(), x.2.to_bits(), x.3)),
                    lane.map(|x| (x.0.to_bits(), x.1.to_bits(), x.2.to_bits(), x.3))
                );
                hits += scalar.is_some() as usize;
            }
        }
        assert!(hits > 3000, "{hits}");
    }

    #[test]
    fn shared_edges_are_watertight() {
        // A fan of thin triangles around a vertex; rays aimed exactly at the
        // shared edges and at the centre vertex must hit something.
        let centre = Vec3::new(0.1, 0.2, 0.0);
        let n = 37;
        let ring: Vec<Vec3> = (0..n)
            .map(|i| {
                let a = i as f32 / n as f32 * std::f32::consts::TAU;
                centre + Vec3::new(a.cos(), a.sin(), 0.0) * 0.7
            })
            .collect();
        let tris: Vec<KdTriangle> = (0..n).map(|i| tri(centre, ring[i], ring[(i + 1) % n])).collect();
        let o = Vec3::new(0.05, -0.1, 2.0);
        for i in 0..n {
            for f in [0.0f32, 0.13, 0.5, 0.77, 0.999] {
                let p = centre + (ring[i] - centre) * f;
                let d = (p - o).normalize();
                let s = RayShear::new(d);
                assert!(
                    tris.iter().any(|t| intersect(t, o, &s, 0.0, f32::INFINITY).is_some()),
                    "ray at {p} slipped through"
                );
            }
        }
    }
}
