//! Input positions the lighting mesh dropped ([`super::simplify`]) take
//! their values from the lighting triangle beside them: for each, the
//! closest point `q` on a lighting triangle of its own region (material and
//! texture map) that faces its way, `n_p . n_t > MIN_COS` (the input
//! normal, area-weighted over its input triangles, against the lighting
//! triangle's face normal), and that it sees: the segment from the position
//! to `q` crosses no other lighting triangle near it. The value at the
//! position is then the lighting triangle's corner values weighted by the
//! barycentrics of `q` ([`Transfer`], read by
//! [`super::prep::PreparedScene::on_input`]).
//!
//! Why both checks: the two faces of a thin wall are two regions' or two
//! orientations' triangles a few millimetres apart, and the closest
//! triangle to a dropped position on the lit face may be the dark face's
//! (the normal test refuses it); a dropped position in a fold may be
//! closest to a triangle of the same face behind another (the visibility
//! test refuses it). A position with no such triangle within
//! [`MAX_RINGS`] grid cells keeps no value (`on_input` gives `None`, as for
//! a position no triangle uses).
//!
//! Search: a uniform grid of the lighting triangles' bounding boxes, cells
//! of their mean edge length, searched in growing shells until the best
//! candidate is closer than the next shell. Lengths in metres.

use crate::trace::ray::{intersect, KdTriangle, RayShear};
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;

/// Where an input position the lighting mesh dropped reads its value: a
/// lighting triangle (an index into `PreparedScene::triangles`) and the
/// weights of its three corners (summing to 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transfer {
    /// The lighting triangle, or [`NO_TRANSFER`].
    pub tri: u32,
    /// Weights of the triangle's corners 0, 1, 2.
    pub weights: [f32; 3],
    /// Distance from the position to the point it reads, metres.
    pub distance: f32,
}

/// [`Transfer::tri`] of a position that takes no value.
pub const NO_TRANSFER: u32 = u32::MAX;

impl Transfer {
    /// No value.
    pub const NONE: Transfer = Transfer { tri: NO_TRANSFER, weights: [0.0; 3], distance: 0.0 };
}

/// The least cosine between a dropped position's normal and a lighting
/// triangle's for the triangle to give it light (60 degrees).
pub const MIN_COS: f32 = 0.5;

/// Grid shells searched around a position before it is left without a value.
pub const MAX_RINGS: i32 = 3;

/// The lighting mesh a transfer searches: world positions, triangles
/// (local ids) and each triangle's region.
pub struct Lighting<'a> {
    /// Vertex positions, metres.
    pub positions: &'a [Vec3],
    /// Triangles over `positions`.
    pub triangles: &'a [[u32; 3]],
    /// Per triangle, its region ([`super::simplify::regions`]).
    pub region: &'a [u32],
}

/// The input's positions to transfer: world positions, triangles and
/// each triangle's region.
pub struct Input<'a> {
    /// World positions, metres.
    pub positions: &'a [Vec3],
    /// The input triangles.
    pub triangles: &'a [[u32; 3]],
    /// Per input triangle, its region.
    pub region: &'a [u32],
}

/// The transfer of every input position for which `wanted(i)` holds (the
/// others [`Transfer::NONE`]), onto `lighting` (module doc); `tri` is local
/// to `lighting.triangles`.
pub fn transfers(input: &Input, lighting: &Lighting, wanted: impl Fn(usize) -> bool + Sync) -> Vec<Transfer> {
    let n = input.positions.len();
    // Per position: its area-weighted normal and region (its first triangle's).
    let mut normal = vec![Vec3::ZERO; n];
    let mut region = vec![u32::MAX; n];
    for (t, &r) in input.triangles.iter().zip(input.region) {
        let [a, b, c] = t.map(|i| input.positions[i as usize]);
        let cross = (b - a).cross(c - a);
        for &i in t {
            normal[i as usize] += cross;
            if region[i as usize] == u32::MAX {
                region[i as usize] = r;
            }
        }
    }
    let grid = Grid::new(lighting);
    (0..n)
        .into_par_iter()
        .map(|i| {
            let n = normal[i].normalize_or_zero();
            if !wanted(i) || n == Vec3::ZERO {
                return Transfer::NONE;
            }
            grid.find(lighting, input.positions[i], n, region[i]).unwrap_or(Transfer::NONE)
        })
        .collect()
}

/// The lighting triangles by grid cell.
struct Grid {
    cell: f32,
    origin: Vec3,
    cells: HashMap<[i32; 3], Vec<u32>>,
    normals: Vec<Vec3>,
}

impl Grid {
    fn new(l: &Lighting) -> Grid {
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for p in l.positions {
            (lo, hi) = (lo.min(*p), hi.max(*p));
        }
        let edges: f64 = l
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| l.positions[i as usize]);
                ((a - b).length() + (b - c).length() + (c - a).length()) as f64 / 3.0
            })
            .sum();
        let mean = (edges / l.triangles.len().max(1) as f64) as f32;
        // At most about a million cells over the box, whatever the triangles' sizes.
        let cell = mean.max((hi - lo).max_element() / 1024.0).max(f32::MIN_POSITIVE);
        let mut g = Grid { cell, origin: lo, cells: HashMap::new(), normals: Vec::with_capacity(l.triangles.len()) };
        for (ti, t) in l.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|i| l.positions[i as usize]);
            g.normals.push((b - a).cross(c - a).normalize_or_zero());
            let (p, q) = (g.key(a.min(b).min(c)), g.key(a.max(b).max(c)));
            for x in p[0]..=q[0] {
                for y in p[1]..=q[1] {
                    for z in p[2]..=q[2] {
                        g.cells.entry([x, y, z]).or_default().push(ti as u32);
                    }
                }
            }
        }
        g
    }

    fn key(&self, p: Vec3) -> [i32; 3] {
        ((p - self.origin) / self.cell).floor().as_ivec3().to_array()
    }

    /// The transfer of a position `p` with normal `n` in region `region`:
    /// the candidates (own region, facing it) of growing shells until the
    /// nearest is closer than the next shell, then the nearest that `p`
    /// sees, tested against every triangle gathered.
    fn find(&self, l: &Lighting, p: Vec3, n: Vec3, region: u32) -> Option<Transfer> {
        let k = self.key(p);
        let mut seen: Vec<u32> = Vec::new();
        let mut shell: Vec<u32> = Vec::new();
        let mut candidates: Vec<(f32, u32, [f32; 3], Vec3)> = Vec::new();
        for r in 0..=MAX_RINGS {
            shell.clear();
            for x in -r..=r {
                for y in -r..=r {
                    for z in -r..=r {
                        if x.abs().max(y.abs()).max(z.abs()) != r {
                            continue;
                        }
                        if let Some(list) = self.cells.get(&[k[0] + x, k[1] + y, k[2] + z]) {
                            shell.extend_from_slice(list);
                        }
                    }
                }
            }
            shell.sort_unstable();
            shell.dedup();
            shell.retain(|t| seen.binary_search(t).is_err());
            for &t in &shell {
                if l.region[t as usize] != region || self.normals[t as usize].dot(n) < MIN_COS {
                    continue;
                }
                let [a, b, c] = l.triangles[t as usize].map(|i| l.positions[i as usize]);
                let (q, w) = closest_point(p, a, b, c);
                candidates.push(((q - p).length(), t, w, q));
            }
            seen.extend_from_slice(&shell);
            seen.sort_unstable();
            // Anything in a later shell is at least `r * cell` away.
            if candidates.iter().any(|c| c.0 <= r as f32 * self.cell) {
                break;
            }
        }
        candidates.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        candidates
            .into_iter()
            .find(|&(_, t, _, q)| !self.blocked(l, &seen, t, p, q))
            .map(|(distance, tri, weights, _)| Transfer { tri, weights, distance })
    }

    /// Whether the segment from `p` to `q` (on triangle `own`) crosses
    /// another of the triangles `near` (the watertight test,
    /// [`crate::trace::ray::intersect`]), its ends left out by a hair.
    fn blocked(&self, l: &Lighting, near: &[u32], own: u32, p: Vec3, q: Vec3) -> bool {
        let d = q - p;
        let len = d.length();
        if len <= 1e-6 * self.cell {
            return false;
        }
        let dir = d / len;
        let shear = RayShear::new(dir);
        let eps = 1e-4 * len;
        near.iter().filter(|&&t| t != own).any(|&t| {
            let [ia, ib, ic] = l.triangles[t as usize];
            let [v0, v1, v2] = [ia, ib, ic].map(|i| l.positions[i as usize].to_array());
            let tri = KdTriangle { v0, ia, v1, ib, v2, ic };
            intersect(&tri, p, &shear, eps, len - eps).is_some()
        })
    }
}

/// The point of triangle `abc` closest to `p` and its barycentric weights
/// (of `a`, `b`, `c`); Ericson, Real-Time Collision Detection, 5.1.5.
pub fn closest_point(p: Vec3, a: Vec3, b: Vec3, c: Vec3) -> (Vec3, [f32; 3]) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w]);
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    (a + ab * v + ac * w, [1.0 - v - w, v, w])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closest point against a brute-force search over a fine sampling
    /// of the triangle, with its weights reproducing it.
    #[test]
    fn closest_point_matches_brute_force() {
        let (a, b, c) = (Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.5, 1.5, 0.3));
        let mut s = 12345u64;
        let mut rnd = || {
            s = crate::sampling::stream::splitmix64(s);
            crate::sampling::stream::unit(s) * 4.0 - 2.0
        };
        for _ in 0..200 {
            let p = Vec3::new(rnd(), rnd(), rnd());
            let (q, w) = closest_point(p, a, b, c);
            assert!((a * w[0] + b * w[1] + c * w[2] - q).length() < 1e-5);
            assert!(w.iter().all(|&x| x >= -1e-6) && (w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
            let mut brute = f32::MAX;
            for i in 0..=100 {
                for j in 0..=(100 - i) {
                    let (u, v) = (i as f32 / 100.0, j as f32 / 100.0);
                    brute = brute.min((a + (b - a) * u + (c - a) * v - p).length());
                }
            }
            assert!((q - p).length() <= brute + 1e-5, "{} > {brute}", (q - p).length());
        }
    }

    /// A thin wall (two faces 1 mm apart, facing away from each other):
    /// a position on each face takes its light from its own face's
    /// triangle, never the other's, though the other is as close.
    #[test]
    fn a_thin_wall_does_not_leak() {
        // Face A at z = 0 facing -z, face B at z = 0.001 facing +z; both 1 m squares of 2 triangles.
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.001),
            Vec3::new(1.0, 0.0, 0.001),
            Vec3::new(1.0, 1.0, 0.001),
            Vec3::new(0.0, 1.0, 0.001),
        ];
        let triangles = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let region = vec![0, 0, 0, 0];
        let lighting = Lighting { positions: &positions, triangles: &triangles, region: &region };
        // Input: a dropped position in the middle of each face with its own small fan.
        let inp_pos = vec![
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(0.4, 0.6, 0.0),
            Vec3::new(0.6, 0.6, 0.0),
            Vec3::new(0.5, 0.5, 0.001),
            Vec3::new(0.6, 0.6, 0.001),
            Vec3::new(0.4, 0.6, 0.001),
        ];
        let inp_tris = vec![[0, 1, 2], [3, 4, 5]];
        let input = Input { positions: &inp_pos, triangles: &inp_tris, region: &[0, 0] };
        let t = transfers(&input, &lighting, |i| i == 0 || i == 3);
        assert!(t[0].tri < 2, "face A's position reads face A: {:?}", t[0]);
        assert!((2..4).contains(&t[3].tri), "face B's position reads face B: {:?}", t[3]);
        assert_eq!(t[1], Transfer::NONE);
    }
}
