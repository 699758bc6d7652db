//! Four triangles at once against one ray (SIMD lanes, structure of
//! arrays) for the kd-tree's leaves: exactly the operations of the
//! watertight test ([`crate::trace::ray::intersect`]) in each lane, so every
//! lane's result is bit for bit the scalar one.

use crate::trace::ray::RayShear;
use glam::{Vec3, Vec4};

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
    use crate::trace::ray::{intersect, KdTriangle};
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
