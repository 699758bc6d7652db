//! The geometry of the emitter links ([`super::emitter_links`],
//! docs/DESIGN.md §4): the form factor of an emissive triangle at a vertex
//! (unitless) by Lambert's formula,
//!
//! ```text
//! F_t = 1/(2 pi) * | sum_k gamma_k * n·c_k |
//! ```
//!
//! over the triangle clipped to the vertex's upper half space (`gamma_k`:
//! the angle edge `k` subtends at the vertex, radians; `c_k`: the unit
//! normal of the plane through the vertex and that edge), and uniform
//! points on the clipped polygon.
//!
//! [`EmitterMesh::form_factors`] gives `F_t` of every emissive triangle at
//! one vertex, bit for bit [`form_factor`]'s, with less work: a run of 32
//! triangles whose bounding sphere lies below the vertex's horizon is
//! passed over (each `F_t` is 0), a corner's direction is normalised once
//! for all its triangles, and an edge's term `gamma_k n·c_k` once for the
//! two triangles that share it (the other one reads its negation, which
//! IEEE arithmetic gives exactly: `b x a = -(a x b)` and `b·a = a·b`
//! component by component). Triangles that cross the horizon take
//! [`form_factor`] itself.
//!
//! A triangle far from the vertex (its centroid `c` further than [`FAR`]
//! times its longest edge `s` and higher than `s` above the horizon, so
//! every corner is above it) takes the
//! point estimate instead, `F_t = (n·c) |a·c| / (pi |c|^4)` with `a` its
//! area vector: no arc tangents. Its error, measured over 20,000 random
//! triangles and directions at `|c| >= FAR s` against Lambert's formula, is
//! at most 1.3e-4 of the triangle's frontal factor `A / (pi |c|^2)`
//! (3.6e-4 at `17 s`, 1.3e-3 at `10 s`). Deviation from an exact `F_t`:
//! a window of many small panes lights a large room, and on Šibenik the
//! exact formula took 31% of the solve (the point estimate took its
//! GI from 46.2 to 35.2 s).

use crate::scene::prep::PreparedScene;
use glam::{DVec3, Vec2, Vec3};
use std::collections::HashMap;
use std::f64::consts::PI;

/// One emissive triangle.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Emitter {
    pub(crate) corners: [Vec3; 3],
    pub(crate) group: u32,
    /// Its index in the scene's triangles.
    pub(crate) triangle: u32,
    /// `(b - a) x (c - a)` of its corners in f64 (m^2, twice its area
    /// along its front normal), computed once for [`Emitter::faces`].
    area_normal: DVec3,
}

impl Emitter {
    /// Emissive triangle `triangle` of group `group` with `corners`.
    pub(crate) fn new(corners: [Vec3; 3], group: u32, triangle: u32) -> Emitter {
        let [a, b, c] = corners.map(|x| x.as_dvec3());
        Emitter { corners, group, triangle, area_normal: (b - a).cross(c - a) }
    }

    /// Whether its front (counter-clockwise side) faces the point `p`:
    /// emitters light their front only.
    #[inline]
    pub(crate) fn faces(&self, p: Vec3) -> bool {
        self.area_normal.dot(p.as_dvec3() - self.corners[0].as_dvec3()) > 0.0
    }
}

/// The part of triangle `q` (corners relative to the vertex) with
/// `n·y >= 0`: up to four corners, f64.
pub(crate) fn clip(n: DVec3, q: [DVec3; 3]) -> ([DVec3; 4], usize) {
    let h = q.map(|c| n.dot(c));
    let mut out = [DVec3::ZERO; 4];
    let mut m = 0;
    for k in 0..3 {
        let (a, b) = (k, (k + 1) % 3);
        if h[a] >= 0.0 {
            out[m] = q[a];
            m += 1;
        }
        if (h[a] >= 0.0) != (h[b] >= 0.0) {
            let s = h[a] / (h[a] - h[b]);
            let mut y = q[a] + (q[b] - q[a]) * s;
            y -= n * n.dot(y).min(0.0); // exactly on the horizon, not below it
            out[m] = y;
            m += 1;
        }
    }
    (out, m)
}

/// Projected solid angle of the polygon `poly` (corners relative to the
/// vertex, none below its horizon) over `pi`: Lambert's formula, two-sided.
pub(crate) fn lambert(n: DVec3, poly: &[DVec3]) -> f64 {
    let mut s = 0.0;
    for k in 0..poly.len() {
        let a = poly[k].normalize_or_zero();
        let b = poly[(k + 1) % poly.len()].normalize_or_zero();
        let c = a.cross(b);
        let len = c.length();
        if len > 0.0 {
            s += len.atan2(a.dot(b)) * n.dot(c) / len;
        }
    }
    (0.5 * s.abs() / PI).min(1.0)
}

/// A triangle whose centroid is further from the vertex than `FAR` times
/// its longest edge takes the point estimate of its factor (module doc).
pub(crate) const FAR: f64 = 32.0;

/// What the point estimate reads of a triangle (absolute positions, f64).
#[derive(Clone, Copy, Debug)]
struct Far {
    /// The centroid, metres.
    centroid: DVec3,
    /// The area vector `(b - a) x (c - a) / 2`, m^2.
    area: DVec3,
    /// Its longest edge, metres.
    edge: f64,
}

impl Far {
    fn of(corners: &[Vec3; 3]) -> Far {
        let [a, b, c] = corners.map(|x| x.as_dvec3());
        let edge = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared()).sqrt();
        Far { centroid: (a + b + c) / 3.0, area: 0.5 * (b - a).cross(c - a), edge }
    }

    /// The point estimate of `F_t` at a vertex at `p` with unit normal
    /// `n`, or `None` unless the triangle is far ([`FAR`]) and wholly above
    /// the horizon (every corner lies within one longest edge of the
    /// centroid, so a centroid higher than that is enough).
    #[inline]
    fn factor(&self, p: DVec3, n: DVec3) -> Option<f64> {
        let c = self.centroid - p;
        let r2 = c.length_squared();
        let reach = FAR * self.edge;
        let h = n.dot(c);
        if !(r2 > reach * reach && h > self.edge) {
            return None;
        }
        Some((h * self.area.dot(c).abs() / (PI * r2 * r2)).min(1.0))
    }
}

/// What a vertex sees of a triangle: far (its point estimate and the
/// whole triangle), nothing, or the part above the horizon.
enum Seen {
    Far(f64, [DVec3; 3]),
    Nothing,
    Clipped([DVec3; 4], usize),
}

/// Triangle `corners` seen from a vertex at `p` with normal `n` (corners
/// relative to the vertex, f64).
fn seen(p: Vec3, n: Vec3, corners: &[Vec3; 3]) -> Seen {
    let (pd, nd) = (p.as_dvec3(), n.as_dvec3());
    let q = corners.map(|c| c.as_dvec3() - pd);
    if let Some(f) = Far::of(corners).factor(pd, nd) {
        return Seen::Far(f, q);
    }
    // A corner on the vertex puts the vertex in the triangle's plane: no solid angle.
    let scale = q.iter().map(|c| c.length()).fold(0.0, f64::max);
    if q.iter().any(|c| c.length() <= 1e-9 * scale) || q.iter().all(|c| nd.dot(*c) <= 0.0) {
        return Seen::Nothing;
    }
    match clip(nd, q) {
        (poly, m) if m >= 3 => Seen::Clipped(poly, m),
        _ => Seen::Nothing,
    }
}

/// `F_t` of one triangle at a vertex at `p` with normal `n`, with the clipped polygon.
pub(crate) fn form_factor(p: Vec3, n: Vec3, corners: &[Vec3; 3]) -> (f64, [DVec3; 4], usize) {
    match seen(p, n, corners) {
        Seen::Far(f, q) => (f, [q[0], q[1], q[2], DVec3::ZERO], 3),
        Seen::Nothing => (0.0, [DVec3::ZERO; 4], 0),
        Seen::Clipped(poly, m) => (lambert(n.as_dvec3(), &poly[..m]), poly, m),
    }
}

/// The polygon of [`form_factor`] without its factor (no arc tangents):
/// where points are drawn on a triangle whose `F_t` is already known.
pub(crate) fn seen_polygon(p: Vec3, n: Vec3, corners: &[Vec3; 3]) -> ([DVec3; 4], usize) {
    match seen(p, n, corners) {
        Seen::Far(_, q) => ([q[0], q[1], q[2], DVec3::ZERO], 3),
        Seen::Nothing => ([DVec3::ZERO; 4], 0),
        Seen::Clipped(poly, m) => (poly, m),
    }
}

/// A point drawn uniformly on the convex polygon `poly` (3 or 4 corners) for `u` in `[0, 1)^2`.
pub(crate) fn polygon_point(poly: &[DVec3], u: Vec2) -> DVec3 {
    let tri_area = |a: DVec3, b: DVec3, c: DVec3| (b - a).cross(c - a).length();
    let (a, mut b, mut c) = (poly[0], poly[1], poly[2]);
    let mut x = u.x as f64;
    if poly.len() == 4 {
        let (a1, a2) = (tri_area(poly[0], poly[1], poly[2]), tri_area(poly[0], poly[2], poly[3]));
        let split = a1 / (a1 + a2).max(f64::MIN_POSITIVE);
        if x < split {
            x /= split.max(f64::MIN_POSITIVE);
        } else {
            (b, c) = (poly[2], poly[3]);
            x = (x - split) / (1.0 - split).max(f64::MIN_POSITIVE);
        }
    }
    let s = x.clamp(0.0, 1.0).sqrt();
    let (b0, b1) = (1.0 - s, u.y as f64 * s);
    a * b0 + b * b1 + c * (1.0 - b0 - b1)
}

/// Emissive triangles per run tested against a vertex's horizon at once.
const RUN: usize = 32;

/// The emissive triangles as one mesh: corners shared between triangles
/// (a solver vertex is one corner slot), edges shared between them, and
/// runs of consecutive triangles with their bounding spheres.
#[derive(Clone, Debug, Default)]
pub(crate) struct EmitterMesh {
    /// Position of each corner slot, metres.
    slots: Vec<DVec3>,
    /// Per triangle, the slots of its corners.
    corners: Vec<[u32; 3]>,
    /// Per triangle, the edge from corner `k` to corner `k + 1`:
    /// `id << 1 | 1` where the edge was first met the other way round.
    edges: Vec<[u32; 3]>,
    edge_count: usize,
    runs: Vec<Run>,
    /// Per triangle, what its point estimate reads.
    far: Vec<Far>,
}

/// Triangles `first..end` inside the sphere `center`, `radius` (metres).
#[derive(Clone, Copy, Debug)]
struct Run {
    first: u32,
    end: u32,
    center: DVec3,
    radius: f64,
}

/// Per-thread buffers of [`EmitterMesh::form_factors`]: every corner
/// slot seen from the current vertex (the length of its offset `q`, m;
/// its height `n·q` above the horizon, m; its unit direction), and the
/// edge terms computed so far (NaN: not yet).
#[derive(Clone, Debug, Default)]
pub(crate) struct FormFactorScratch {
    len: Vec<f64>,
    h: Vec<f64>,
    dir: Vec<DVec3>,
    edge_term: Vec<f64>,
}

impl EmitterMesh {
    /// The mesh of `emitters` (in their order) of `scene`.
    pub(crate) fn new(scene: &PreparedScene, emitters: &[Emitter]) -> EmitterMesh {
        let mut slot_of: HashMap<u32, u32> = HashMap::new();
        let mut edge_of: HashMap<(u32, u32), u32> = HashMap::new();
        let mut out = EmitterMesh::default();
        for e in emitters {
            let tri = scene.triangles[e.triangle as usize];
            let slots = tri.map(|v| {
                *slot_of.entry(v).or_insert_with(|| {
                    out.slots.push(scene.positions[v as usize].as_dvec3());
                    (out.slots.len() - 1) as u32
                })
            });
            let edges = [0, 1, 2].map(|k| {
                let (a, b) = (slots[k], slots[(k + 1) % 3]);
                if let Some(&id) = edge_of.get(&(b, a)) {
                    return id << 1 | 1;
                }
                let next = edge_of.len() as u32;
                *edge_of.entry((a, b)).or_insert(next) << 1
            });
            out.corners.push(slots);
            out.edges.push(edges);
            out.far.push(Far::of(&e.corners));
        }
        out.edge_count = edge_of.len();
        for first in (0..emitters.len()).step_by(RUN) {
            let end = (first + RUN).min(emitters.len());
            let pts = || out.corners[first..end].iter().flatten().map(|&s| out.slots[s as usize]);
            let center = pts().sum::<DVec3>() / (3 * (end - first)) as f64;
            let radius = pts().map(|p| (p - center).length()).fold(0.0, f64::max);
            out.runs.push(Run { first: first as u32, end: end as u32, center, radius });
        }
        out
    }

    /// `out[t]` = `F_t` of every emitter `t` (of `emitters`, the list the
    /// mesh was made of) at a vertex at `p` with normal `n`: equal to
    /// `form_factor(p, n, &emitters[t].corners).0` bit for bit.
    pub(crate) fn form_factors(
        &self,
        emitters: &[Emitter],
        p: Vec3,
        n: Vec3,
        s: &mut FormFactorScratch,
        out: &mut Vec<f64>,
    ) {
        out.clear();
        out.resize(self.corners.len(), 0.0);
        let (pd, nd) = (p.as_dvec3(), n.as_dvec3());
        // Corner slots are looked at when a triangle is not far: NaN until then.
        s.len.clear();
        s.len.resize(self.slots.len(), f64::NAN);
        s.h.resize(self.slots.len(), 0.0);
        s.dir.resize(self.slots.len(), DVec3::ZERO);
        let corner = |s: &mut FormFactorScratch, k: usize| {
            if s.len[k].is_nan() {
                let q = self.slots[k] - pd;
                s.len[k] = q.length();
                s.h[k] = nd.dot(q);
                s.dir[k] = q.normalize_or_zero();
            }
        };
        s.edge_term.clear();
        s.edge_term.resize(self.edge_count, f64::NAN);
        let n_len = nd.length();
        for run in &self.runs {
            let dc = run.center - pd;
            // Every corner is within `radius` of the centre, so its height
            // is at most `n·dc + |n| radius`; the margin covers rounding.
            if nd.dot(dc) + n_len * run.radius < -1e-9 * (dc.length() + run.radius) {
                continue;
            }
            for t in run.first as usize..run.end as usize {
                if let Some(f) = self.far[t].factor(pd, nd) {
                    out[t] = f;
                    continue;
                }
                let [a, b, c] = self.corners[t].map(|k| k as usize);
                for k in [a, b, c] {
                    corner(s, k);
                }
                // As `form_factor`: a corner on the vertex, or nothing above the horizon.
                let (la, lb, lc) = (s.len[a], s.len[b], s.len[c]);
                let scale = 0.0f64.max(la).max(lb).max(lc);
                if la <= 1e-9 * scale || lb <= 1e-9 * scale || lc <= 1e-9 * scale {
                    continue;
                }
                let (ha, hb, hc) = (s.h[a], s.h[b], s.h[c]);
                if ha <= 0.0 && hb <= 0.0 && hc <= 0.0 {
                    continue;
                }
                if ha < 0.0 || hb < 0.0 || hc < 0.0 {
                    out[t] = form_factor(p, n, &emitters[t].corners).0;
                    continue;
                }
                // Unclipped: `lambert` over the corners, edge terms shared.
                let slots = [a, b, c];
                let mut sum = 0.0;
                for k in 0..3 {
                    let e = self.edges[t][k];
                    let id = (e >> 1) as usize;
                    let mut term = s.edge_term[id];
                    if term.is_nan() {
                        let (u, w) = (slots[k], slots[(k + 1) % 3]);
                        let (u, w) = if e & 1 == 0 { (u, w) } else { (w, u) };
                        term = edge_term(s.dir[u], s.dir[w], nd);
                        s.edge_term[id] = term;
                    }
                    sum += if e & 1 == 0 { term } else { -term };
                }
                out[t] = (0.5 * sum.abs() / PI).min(1.0);
            }
        }
    }
}

/// Lambert's term of the edge from unit direction `a` to `b` at a vertex
/// with normal `n`: `lambert`'s loop body, 0 where `a x b` vanishes.
#[inline]
fn edge_term(a: DVec3, b: DVec3, n: DVec3) -> f64 {
    let c = a.cross(b);
    let len = c.length();
    if len > 0.0 {
        len.atan2(a.dot(b)) * n.dot(c) / len
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exchange::sources::emitter_links::emitters_of;
    use crate::scene::shapes::MeshBuilder;

    /// Lambert's formula against brute-force cosine-weighted sampling of
    /// the hemisphere (the share of cosine-distributed directions that meet
    /// the triangle), for triangles above, across and below the horizon.
    #[test]
    fn form_factor_equals_cosine_sampling() {
        let n = Vec3::new(0.2, 1.0, -0.1).normalize();
        let tris = [
            [Vec3::new(-1.0, 1.0, -1.0), Vec3::new(1.0, 1.2, -0.5), Vec3::new(0.2, 0.8, 1.0)],
            [Vec3::new(-1.0, -0.5, 0.5), Vec3::new(1.5, 0.7, 0.3), Vec3::new(0.2, 0.4, -1.5)],
            [Vec3::new(0.3, -1.0, 0.5), Vec3::new(1.5, -0.2, 0.3), Vec3::new(0.2, -0.4, -1.5)],
            [Vec3::new(0.01, 0.02, 0.0), Vec3::new(3.0, 0.5, 0.1), Vec3::new(0.1, 0.3, 2.0)],
        ];
        let (t, b) = crate::sampling::basis(n);
        let k = 400;
        for corners in tris {
            let (f, _, _) = form_factor(Vec3::ZERO, n, &corners);
            let mut hits = 0u32;
            for i in 0..k {
                for j in 0..k {
                    let u = Vec2::new((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                    let d = crate::sampling::cosine_hemisphere(u);
                    let dir = t * d.x + b * d.y + n * d.z;
                    if meets(dir, &corners) {
                        hits += 1;
                    }
                }
            }
            let brute = hits as f64 / (k * k) as f64;
            assert!((f - brute).abs() < 2e-3, "{corners:?}: Lambert {f}, sampled {brute}");
        }
    }

    /// Moller-Trumbore: does the ray from the origin along `d` meet the triangle?
    fn meets(d: Vec3, c: &[Vec3; 3]) -> bool {
        let (e1, e2) = (c[1] - c[0], c[2] - c[0]);
        let pv = d.cross(e2);
        let det = e1.dot(pv);
        if det.abs() < 1e-12 {
            return false;
        }
        let tv = -c[0];
        let u = tv.dot(pv) / det;
        let qv = tv.cross(e1);
        let v = d.dot(qv) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(qv) / det > 0.0
    }

    /// A unit square 1 m above a point, facing it: the analytic
    /// point-to-parallel-rectangle factor at its corner, four times.
    #[test]
    fn form_factor_of_a_square_over_a_point() {
        let n = Vec3::Y;
        let (a, h) = (0.8f64, 1.0f64);
        let q = |x: f32, z: f32| Vec3::new(x, h as f32, z);
        let s = a as f32;
        let tris = [[q(-s, -s), q(s, -s), q(s, s)], [q(-s, -s), q(s, s), q(-s, s)]];
        let f: f64 = tris.iter().map(|t| form_factor(Vec3::ZERO, n, t).0).sum();
        // Corner of an a x a rectangle at height h: 1/(2 pi) (X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + Y/.. atan(X/..)).
        let (x, y) = (a / h, a / h);
        let corner = (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
            + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
            / (2.0 * PI);
        assert!((f - 4.0 * corner).abs() < 1e-7, "{f} vs {}", 4.0 * corner);
        // Fully overhead and huge: the whole hemisphere.
        let big = 1e4f32;
        let tris = [[q(-big, -big), q(big, -big), q(big, big)], [q(-big, -big), q(big, big), q(-big, big)]];
        let f: f64 = tris.iter().map(|t| form_factor(Vec3::ZERO, n, t).0).sum();
        assert!((f - 1.0).abs() < 1e-3, "{f}");
    }

    /// The point estimate of a far triangle against Lambert's formula:
    /// within 1.5e-4 of its frontal factor `A / (pi r^2)` for random
    /// triangles at random directions above the horizon (centroid higher
    /// than a longest edge), from `FAR` to 3 `FAR` longest edges away (the module doc's bound); nearer, no
    /// estimate.
    #[test]
    fn far_triangles_take_the_point_estimate_within_its_bound() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
        let n = DVec3::Z;
        let (mut worst, mut tried) = (0f64, 0);
        for _ in 0..20_000 {
            let mut g = || DVec3::new(rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5, rng.random::<f64>() - 0.5);
            let tri = [g(), g(), g()];
            let mut d = g().normalize();
            d.z = d.z.abs();
            let s = (tri[1] - tri[0]).length().max((tri[2] - tri[1]).length()).max((tri[0] - tri[2]).length());
            let c = (tri[0] + tri[1] + tri[2]) / 3.0;
            let r = s * FAR * (1.0 + 2.0 * rng.random::<f64>()) * 1.0001;
            let q = tri.map(|x| x - c + d * r);
            // Not far: a centroid within one edge of the horizon (a corner may be under it).
            if d.z * r <= s * 1.0001 {
                continue;
            }
            let corners = q.map(|x| x.as_vec3());
            let q = corners.map(|x| x.as_dvec3());
            let exact = lambert(n, &q);
            let far = Far::of(&corners).factor(DVec3::ZERO, n).expect("far");
            let area = 0.5 * (q[1] - q[0]).cross(q[2] - q[0]).length();
            let rc = ((q[0] + q[1] + q[2]) / 3.0).length();
            worst = worst.max((far - exact).abs() / (area / (PI * rc * rc)));
            tried += 1;
            let near = tri.map(|x| (x - c + d * (s * FAR * 0.9)).as_vec3());
            assert!(Far::of(&near).factor(DVec3::ZERO, n).is_none());
        }
        assert!(tried > 5000 && worst < 1.5e-4, "{tried} triangles: worst {worst}");
    }

    /// Points on a clipped polygon stay on it and cover its two halves in proportion to their areas.
    #[test]
    fn polygon_points_are_uniform() {
        let poly = [DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), DVec3::new(2.0, 1.0, 0.0), DVec3::new(0.0, 1.0, 0.0)];
        let mut left = 0;
        let k = 100;
        for i in 0..k {
            for j in 0..k {
                let y = polygon_point(&poly, Vec2::new((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32));
                assert!(y.x >= -1e-12 && y.x <= 2.0 + 1e-12 && y.y >= -1e-12 && y.y <= 1.0 + 1e-12 && y.z == 0.0);
                left += (y.x < 1.0) as u32;
            }
        }
        assert!((left as f64 / (k * k) as f64 - 0.5).abs() < 0.01, "{left}");
    }

    /// The shared evaluation equals `form_factor` bit for bit at every
    /// vertex of a room with an emissive sphere and an emissive open box
    /// (triangles above, across and below the horizons; corners on the
    /// vertex; edges met both ways round).
    #[test]
    fn shared_form_factors_equal_form_factor() {
        let mut desc = crate::scene::builtin::closed_room(4, 0.5);
        let mut b = MeshBuilder::new();
        let m = b.add_material("glow", Vec3::ONE);
        b.materials[m as usize].emission = Vec3::splat(2.0);
        b.icosphere(Vec3::new(0.2, 1.1, -0.3), 0.3, 2, m, false);
        b.cuboid_open(
            Vec3::new(-0.9, 0.0, 0.2),
            Vec3::new(-0.3, 0.5, 0.8),
            [3; 3],
            [Some(m), Some(m), None, Some(m), Some(m), Some(m)],
            false,
        );
        desc.meshes.push(b.finish("glow", 30.0));
        let scene = crate::scene::prep::prepare(&desc).unwrap();
        let (em, _) = emitters_of(&scene);
        let mesh = EmitterMesh::new(&scene, &em);
        assert!(mesh.runs.len() > 4 && mesh.edge_count < 3 * em.len());
        let (mut scratch, mut f) = (FormFactorScratch::default(), Vec::new());
        let (mut positive, mut clipped) = (0, 0);
        for v in 0..scene.vertex_count() {
            let (p, n) = (scene.positions[v], scene.normals[v]);
            mesh.form_factors(&em, p, n, &mut scratch, &mut f);
            for (t, e) in em.iter().enumerate() {
                let want = form_factor(p, n, &e.corners).0;
                assert_eq!(f[t].to_bits(), want.to_bits(), "vertex {v}, emitter {t}: {} vs {want}", f[t]);
                positive += (want > 0.0) as usize;
                let h = e.corners.map(|c| n.as_dvec3().dot(c.as_dvec3() - p.as_dvec3()));
                clipped += (want > 0.0 && h.iter().any(|&h| h < 0.0)) as usize;
            }
        }
        assert!(positive > 1000 && clipped > 100, "{positive} positive, {clipped} clipped");
    }
}
