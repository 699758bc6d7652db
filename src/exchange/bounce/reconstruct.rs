//! Gradient-corrected source radiosity: the bounces' radiosity as the link
//! hits should read it, not as linear interpolation over a triangle gives it.
//!
//! A link hit at `h` on triangle `T` reads the radiosity
//! `sum_c beta_c B_c`, linear in the barycentrics `beta_c`. Where `B` is
//! curved that is biased: for a quadratic `B`,
//! `B(h) = sum_c beta_c [B_c + 1/2 grad B_c . (h - x_c)]` exactly, and
//! averaged over a triangle hit uniformly the second term is
//! `sum_c grad B_c . (e_ca + e_cb) / 24` (`e_ca = x_a - x_c`). Over a
//! surface these terms cancel between neighbouring triangles except at the
//! surface's edges (the integral of a linear interpolant's error is a
//! boundary term, `h^2/12 (B'(a) - B'(b))` in 1D): a wall's radiosity
//! falls toward the concave corners where it meets the floor and the next
//! wall, so linear interpolation reads every wall darker than it is. On
//! the Cornell box the links' `E_i` read 0.60% dark at 4096 rays a vertex
//! against the reference path tracer (65536 paths), 0.26% with the walls
//! tessellated twice as finely: the bias of linear elements, not noise.
//!
//! The correction moves each corner's share to its vertex: with the
//! fan-weighted offset
//!
//! ```text
//! mu_c = sum_{T at c} A_T (e_ca + e_cb) / (8 sum_{T at c} A_T)
//! Btilde_c = B_c + grad B_c . mu_c          (clamped to B's range over c's row)
//! ```
//!
//! a receiver whose hits cover `c`'s fan uniformly reads
//! `sum_T A_T/3 * Btilde_c`, which is the exact integral for quadratic `B`
//! when `grad B_c` is exact. `mu_c` is zero for a vertex inside a regular
//! fan (the terms cancel; such rows are left empty) and points into the
//! surface at its border and crease vertices, so `Btilde` differs from `B`
//! mostly there. `grad B_c` comes from a weighted least-squares quadratic
//! fit (gradient and Hessian in `c`'s tangent plane, neighbours weighted by
//! `1 / d^2`) over `c`'s two-ring, exact for quadratic `B` on a border too;
//! where the two-ring does not determine a quadratic, a plane over the
//! one-ring. Either way `Btilde_c = B_c + sum_n K_cn (B_n - B_c)` with
//! fixed weights `K_cn`: one sparse pass per bounce, about as costly as a
//! one-ring smoothing. The clamp to the row's range keeps the pass from
//! raising the largest radiosity (the bounces' convergence and the energy
//! bound rest on that); measured with the first, plane-fit version,
//! cornell's figures were the same to 4 digits without it.
//!
//! Where it applies: to the radiosity every bounce gathers (the CPU
//! kernel, [`crate::exchange::bounce::gather::CpuBounces`], and the WGSL one,
//! `reconstruct_radiosity`), and to the first bounce's source except the
//! emitters' direct light, whose near-hit correction
//! ([`crate::exchange::near::emitters`]) keeps its linear corner term in its stored
//! coefficients. The near-hit corrections ([`crate::exchange::near::light`],
//! [`crate::exchange::near::sky`], [`crate::exchange::near::gather`]) subtract what the links
//! read, so they interpolate the corrected values too
//! ([`Reconstruction::through_albedo`]).
//!
//! Measured (`--off reconstruct` without; `cargo test --release --test measured -- --ignored
//! radiosity_correction_lowers_tearoom_error` checks tearoom at 1024 rays,
//! 1.108 -> 1.027% now against a 4096-path reference; total relative RMSE with the
//! reference's noise removed, auto bounces, seed 1; this 2-core VM),
//! without / with:
//!
//! | scene | 256 rays | 1024 rays |
//! |---|---|---|
//! | cornell (65536-path reference) | 2.227 / 2.215% | 0.991 / 0.958% |
//! | tearoom (16384) | 2.080 / 2.073% | 1.120 / 1.040% |
//! | window (16384) | 1.795 / 1.732% | 1.102 / 1.096% (seed 2: 1.120 / 1.122%) |
//!
//! Cornell's `E_i` alone at 4096 rays: 0.685 / 0.491% (bias -0.60 /
//! -0.39% against a 4096-path reference); its mean at 1024 rays against a
//! 1024-path reference -0.21 / +0.00%. A closed room of albedo 0.99 held
//! 5.4% less light than its exact balance `E_d / (1 - rho)`, 0.58% with.
//! `window`'s room (25 cm triangles) keeps most of its sky light's dark
//! bias (-1.3% with, -2.3% without; -0.4% with the room tessellated twice
//! as finely): the rest is finer than its mesh. Tried: a plane fit over the
//! one-ring for every vertex (one-sided gradients at the borders): cornell
//! 0.962%, tearoom 1.055%, the closed room 1.6% short; twice `mu`:
//! overcorrects (cornell `E_i` at 4096 rays 0.705%); the emitters' direct
//! light corrected too: `window`'s lamp 0.3% brighter than the reference
//! (its near hits' corner terms then disagree).
//!
//! Units: `mu` and positions in metres; `K` unitless; the values passed
//! through are radiosity W/(m^2 sr) or irradiance W/m^2 (the pass is
//! linear apart from the clamp).

use crate::csr::{Csr, RowBuilder};
use crate::scene::prep::PreparedScene;
use glam::{Mat2, Vec2, Vec3, Vec4};
use rayon::prelude::*;

/// The sparse correction `Btilde_c = B_c + sum_n K_cn (B_n - B_c)`, one
/// row per vertex (CSR). A vertex with nothing to correct (`mu_c`
/// negligible) or no gradient (collinear or no neighbours) has an empty
/// row: unchanged.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Reconstruction {
    /// Row `c`: `(n, K_cn)` entries (neighbour, weight).
    pub rows: Csr<(u32, f32)>,
}

/// Two unit tangents of unit normal `n`.
fn tangents(n: Vec3) -> (Vec3, Vec3) {
    let a = if n.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
    let t1 = (a - n * n.dot(a)).normalize_or_zero();
    (t1, n.cross(t1))
}

/// Row of vertex `c`: `(n, K_cn)` over its two-ring (quadratic fit) or,
/// where that is not determined, its one-ring (plane fit); empty where
/// `mu_c` is negligible (under 1e-3 of the mean edge).
fn row(s: &PreparedScene, c: usize) -> Vec<(u32, f32)> {
    let xc = s.positions[c];
    let (t1, t2) = tangents(s.normals[c]);
    let (mut mu, mut area) = (Vec3::ZERO, 0f32);
    for &t in s.vertex_triangles.row(c) {
        let p = s.triangles[t as usize].map(|k| s.positions[k as usize]);
        let a = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        // (x_a - x_c) + (x_b - x_c): the corner c's own term is zero.
        mu += a * p.iter().map(|q| *q - xc).sum::<Vec3>();
        area += a;
    }
    if area.is_nan() || area <= 0.0 {
        return Vec::new();
    }
    mu /= 8.0 * area;
    let mu = Vec2::new(mu.dot(t1), mu.dot(t2));
    // A regular fan's terms cancel: nothing to correct (rounding aside).
    let l = s.rings.row(c).iter().map(|&n| (s.positions[n as usize] - xc).length()).sum::<f32>()
        / s.rings.row(c).len().max(1) as f32;
    if mu.length() <= 1e-3 * l {
        return Vec::new();
    }
    if let Some(r) = quadratic_row(s, c, t1, t2, mu) {
        return r;
    }
    // Too few or too regular neighbours for a quadratic: the one-ring's plane.
    let ring: Vec<(u32, Vec2, f32)> = s
        .rings
        .row(c)
        .iter()
        .map(|&n| {
            let d = s.positions[n as usize] - xc;
            let d = Vec2::new(d.dot(t1), d.dot(t2));
            (n, d, 1.0 / d.length_squared().max(f32::MIN_POSITIVE))
        })
        .collect();
    let m = ring.iter().fold(Mat2::ZERO, |m, (_, d, w)| m + Mat2::from_cols(*d * d.x, *d * d.y) * *w);
    // Unitless (1/d^2 weights): a ring whose directions span the plane
    // has det about (count/2)^2; collinear ones near 0.
    let trace = m.col(0).x + m.col(1).y;
    if !(m.determinant() > 1e-4 * trace * trace) {
        return Vec::new();
    }
    let a = m.inverse() * mu;
    let out: Vec<(u32, f32)> = ring.iter().map(|(n, d, w)| (*n, w * a.dot(*d))).collect();
    if out.iter().all(|(_, k)| k.is_finite()) {
        out
    } else {
        Vec::new()
    }
}

/// `(n, K_cn)` over `c`'s two-ring from a weighted least-squares
/// quadratic fit (gradient and Hessian in the tangent plane); `None` where
/// the two-ring does not determine one.
fn quadratic_row(s: &PreparedScene, c: usize, t1: Vec3, t2: Vec3, mu: Vec2) -> Option<Vec<(u32, f32)>> {
    let xc = s.positions[c];
    let mut pts: Vec<u32> = Vec::new();
    for &n in s.rings.row(c) {
        pts.push(n);
        pts.extend(s.rings.row(n as usize).iter().copied().filter(|&m| m as usize != c));
    }
    pts.sort_unstable();
    pts.dedup();
    if pts.len() < 6 {
        return None;
    }
    let d: Vec<[f64; 2]> = pts
        .iter()
        .map(|&n| {
            let v = s.positions[n as usize] - xc;
            [v.dot(t1) as f64, v.dot(t2) as f64]
        })
        .collect();
    let h = d.iter().map(|p| (p[0] * p[0] + p[1] * p[1]).sqrt()).sum::<f64>() / d.len() as f64;
    if !(h > 0.0) {
        return None;
    }
    let rows: Vec<[f64; 5]> = d
        .iter()
        .map(|p| {
            let (x, y) = (p[0] / h, p[1] / h);
            [x, y, 0.5 * x * x, x * y, 0.5 * y * y]
        })
        .collect();
    let w: Vec<f64> = rows.iter().map(|r| 1.0 / (r[0] * r[0] + r[1] * r[1]).max(1e-12)).collect();
    // Normal matrix with the identity beside it, Gauss-Jordan.
    let mut m = [[0f64; 10]; 5];
    for (r, wi) in rows.iter().zip(&w) {
        for i in 0..5 {
            for j in 0..5 {
                m[i][j] += wi * r[i] * r[j];
            }
        }
    }
    for (i, row) in m.iter_mut().enumerate() {
        row[5 + i] = 1.0;
    }
    let scale = (0..5).map(|i| m[i][i]).fold(0f64, f64::max);
    for col in 0..5 {
        let piv = (col..5).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if !(m[piv][col].abs() > 1e-9 * scale) {
            return None;
        }
        m.swap(col, piv);
        let p = m[col][col];
        m[col].iter_mut().for_each(|x| *x /= p);
        for r in 0..5 {
            if r != col {
                let f = m[r][col];
                if f != 0.0 {
                    let src = m[col];
                    m[r].iter_mut().zip(src).for_each(|(x, y)| *x -= f * y);
                }
            }
        }
    }
    // Gradient rows of (A^T W A)^-1 A^T W, in 1/metre: K_n = mu . G_n.
    let out: Vec<(u32, f32)> = pts
        .iter()
        .zip(rows.iter().zip(&w))
        .map(|(&n, (r, wi))| {
            let g = |k: usize| (0..5).map(|j| m[k][5 + j] * r[j]).sum::<f64>() * wi / h;
            (n, (mu.x as f64 * g(0) + mu.y as f64 * g(1)) as f32)
        })
        .collect();
    out.iter().all(|(_, k)| k.is_finite()).then_some(out)
}

impl Reconstruction {
    /// The weights of `scene`'s vertices (positions, normals, one-rings and
    /// incident triangles).
    pub fn new(scene: &PreparedScene) -> Reconstruction {
        let rows: Vec<Vec<(u32, f32)>> = (0..scene.vertex_count()).into_par_iter().map(|c| row(scene, c)).collect();
        let mut table = RowBuilder::new();
        for row in rows {
            table.extend(row);
            table.end_row();
        }
        Reconstruction { rows: table.finish() }
    }

    /// Vertices covered.
    pub fn rows(&self) -> usize {
        self.rows.rows()
    }

    /// `Btilde` of vertex `c` (module doc) from `b` (padded; the fourth
    /// lane passes through like the others). The order of operations is
    /// the WGSL pass's.
    #[inline]
    pub fn at(&self, b: &[Vec4], c: usize) -> Vec4 {
        let bc = b[c];
        let (mut acc, mut lo, mut hi) = (bc, bc, bc);
        for &(n, k) in self.rows.row(c) {
            let bn = b[n as usize];
            acc += (bn - bc) * k;
            lo = lo.min(bn);
            hi = hi.max(bn);
        }
        acc.max(lo).min(hi)
    }

    /// `Btilde` of every vertex into `out`.
    pub fn apply(&self, b: &[Vec4], out: &mut [Vec4]) {
        out.par_iter_mut().enumerate().for_each(|(c, o)| *o = self.at(b, c));
    }

    /// `x'` with `rho x' = Btilde(rho x)` per channel (`x` irradiance,
    /// W/m^2; zero where the albedo is): the irradiance whose reflection
    /// the links read after the correction, which the near-hit
    /// corrections interpolate.
    pub fn through_albedo(&self, albedo: &[Vec3], x: &[Vec3]) -> Vec<Vec3> {
        let rx: Vec<Vec4> = x.iter().zip(albedo).map(|(e, r)| (*e * *r).extend(0.0)).collect();
        (0..x.len())
            .into_par_iter()
            .map(|c| {
                let y = self.at(&rx, c).truncate();
                let r = albedo[c];
                Vec3::select(r.cmpgt(Vec3::ZERO), y / r.max(Vec3::splat(f32::MIN_POSITIVE)), Vec3::ZERO)
            })
            .collect()
    }

    /// Checks against `n` vertices: CSR offsets, neighbours in range,
    /// finite weights.
    #[cfg(any(test, feature = "internals"))]
    pub fn validate(&self, n: usize) -> Result<(), String> {
        if self.rows.rows() != n {
            return Err(format!("reconstruction: {} rows for {n} vertices", self.rows.rows()));
        }
        self.rows
            .validate(n, |_, &(t, k)| {
                if t as usize >= n || !k.is_finite() {
                    return Err(format!("neighbour {t} of {n}, weight {k}"));
                }
                Ok(())
            })
            .map_err(|e| format!("reconstruction: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::shapes::MeshBuilder;
    use crate::scene::{prep, SceneDesc};

    /// A 2 x 1 m floor of `nu x nv` quads (two triangles each), normals up.
    fn floor(nu: u32, nv: u32) -> PreparedScene {
        let mut b = MeshBuilder::new();
        let grey = b.add_material("grey", Vec3::splat(0.5));
        b.quad_grid(Vec3::new(0.0, 0.0, 1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, -1.0), nu, nv, grey);
        let desc = SceneDesc {
            name: "floor".into(),
            settings: Default::default(),
            camera: Default::default(),
            meshes: vec![b.finish("floor", 30.0)],
            lights: Vec::new(),
            sky: None,
            warnings: Vec::new(),
            notes: Vec::new(),
        };
        prep::prepare(&desc).expect("floor prepares")
    }

    /// `sum_T A_T/3 sum_c v_c`: what a receiver hitting every triangle
    /// uniformly reads of per-vertex values `v` (the integral of their
    /// linear interpolant).
    fn area_read(s: &PreparedScene, v: &[f32]) -> f64 {
        s.triangles
            .iter()
            .map(|t| {
                let p = t.map(|k| s.positions[k as usize]);
                let a = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length() as f64;
                a / 3.0 * t.iter().map(|&k| v[k as usize] as f64).sum::<f64>()
            })
            .sum()
    }

    fn corrected(r: &Reconstruction, b: &[f32]) -> Vec<f32> {
        let b4: Vec<Vec4> = b.iter().map(|x| Vec4::new(*x, 0.0, 0.0, 0.0)).collect();
        (0..b.len()).map(|c| r.at(&b4, c).x).collect()
    }

    /// A dome `B = 1 + x(2 - x) + z(1 - z)` over the 2 x 1 m floor, highest
    /// in the middle and falling to the borders, as a wall's radiosity falls
    /// toward its corners: its exact integral is 2 + 4/3 + 1/3 = 11/3.
    /// Linear interpolation reads it low by the boundary term
    /// `h^2/12` times the jumps of `B'` at the borders (measured to 5%);
    /// the corrected values (quadratic fits: exact gradients) read it 500x
    /// closer at h = 1/8 m and 2000x at 1/16 m (2e-5 and 1.3e-6 of 11/3:
    /// f32 rounding and the grid's corners), the linear one falls as `h^2`.
    #[test]
    fn corrected_values_integrate_a_dome_closely() {
        let exact = 11.0 / 3.0;
        let mut errs = Vec::new();
        for n in [8u32, 16] {
            let s = floor(2 * n, n);
            let r = Reconstruction::new(&s);
            r.validate(s.vertex_count()).expect("valid");
            let b: Vec<f32> = s.positions.iter().map(|p| 1.0 + p.x * (2.0 - p.x) + p.z * (1.0 - p.z)).collect();
            let linear = area_read(&s, &b) - exact;
            let fixed = area_read(&s, &corrected(&r, &b)) - exact;
            // h = 1/n on both axes; B' jumps by 2 + 2 across x (over 1 m of
            // border) and by 1 + 1 across z (over 2 m).
            let h = 1.0 / n as f64;
            let predicted = -(h * h / 12.0) * (2.0 * 2.0 * 1.0 + 2.0 * 1.0 * 2.0);
            assert!((linear - predicted).abs() < 0.05 * predicted.abs(), "n {n}: linear {linear:e} vs {predicted:e}");
            assert!(fixed.abs() < 0.01 * linear.abs(), "n {n}: corrected {fixed:e} against linear {linear:e}");
            errs.push(fixed.abs());
        }
        assert!(errs[1] < errs[0] / 8.0, "errors {errs:?} do not fall faster than h^3");
    }

    /// Constants pass unchanged (every difference `B_n - B_c` is zero), so
    /// a uniformly lit furnace is untouched; every weight is finite, border
    /// vertices have rows and interior ones (regular fans, `mu` zero) small
    /// or empty ones.
    #[test]
    fn constants_pass_unchanged_and_interior_rows_are_near_zero() {
        let s = floor(12, 6);
        let r = Reconstruction::new(&s);
        r.validate(s.vertex_count()).expect("valid");
        let ones = vec![1.5f32; s.vertex_count()];
        assert!(corrected(&r, &ones).iter().all(|&x| x == 1.5));
        for c in 0..s.vertex_count() {
            let k: f32 = r.rows.row(c).iter().map(|e| e.1.abs()).sum();
            if s.boundary[c] {
                assert!(k > 0.01, "border vertex {c}: no correction");
            } else {
                assert!(k < 0.2, "interior vertex {c}: weights {k}");
            }
        }
    }

    /// The clamp: no corrected value leaves the range of its own and its
    /// row's values (its two-ring's), whatever the field (here noise), so
    /// the pass never raises the largest radiosity; and `through_albedo` is
    /// the identity where the field is constant and zero where the albedo
    /// is.
    #[test]
    fn corrected_values_stay_within_the_ring() {
        let s = floor(10, 5);
        let r = Reconstruction::new(&s);
        let b: Vec<f32> = (0..s.vertex_count()).map(|i| ((i * 7919) % 13) as f32).collect();
        let c = corrected(&r, &b);
        assert!(r.rows.offsets.windows(2).any(|w| w[1] - w[0] > 8), "no two-ring rows");
        for v in 0..s.vertex_count() {
            let ring = r.rows.row(v).iter().map(|&(n, _)| b[n as usize]);
            let (lo, hi) = ring.fold((b[v], b[v]), |(lo, hi), x| (lo.min(x), hi.max(x)));
            assert!(c[v] >= lo && c[v] <= hi, "vertex {v}: {} outside [{lo}, {hi}]", c[v]);
        }
        let albedo: Vec<Vec3> = (0..s.vertex_count()).map(|i| Vec3::new(0.5, 0.0, 0.25 + 0.01 * i as f32)).collect();
        let x = vec![Vec3::splat(2.0); s.vertex_count()];
        for (a, y) in albedo.iter().zip(r.through_albedo(&albedo, &x)) {
            assert!((y.x - 2.0).abs() < 1e-5 && y.y == 0.0, "{y} for albedo {a}");
        }
    }
}
