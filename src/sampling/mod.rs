//! Ray directions (docs/DESIGN.md §2): `k*k` cosine-weighted directions from a
//! stratified, jittered grid on the unit square, mapped to the disc by the
//! concentric map of Shirley & Chiu (1997) and lifted to the hemisphere
//! (Malley's method), so `pdf(w) = cos(theta) / pi` (per steradian).
//!
//! Directions are ordered in 4*4 blocks of grid cells so consecutive rays
//! (neighbouring GPU threads) trace neighbouring directions. One set serves
//! every vertex: it is turned into each vertex's frame, rotated about the
//! normal by an angle from a graph colouring of the one-rings, so that
//! neighbours get complementary rotations (interleaved sampling: smoothing
//! over a one-ring then averages differently rotated sets). Everything is
//! deterministic in the seed.

use glam::{Vec2, Vec3};
use rand::{Rng, SeedableRng};
use std::f32::consts::FRAC_PI_2;

use crate::csr::Csr;

pub mod stream;
mod warp;
pub use stream::Stream;
pub use warp::{basis, cosine_hemisphere};
#[cfg(test)]
use warp::{concentric_disk, concentric_disk_inverse, cosine_hemisphere_inverse, cosine_hemisphere_pdf};

/// The grid cells of a `k*k` grid in 4*4-block order.
pub fn block_order(k: u32) -> Vec<(u32, u32)> {
    let mut out = Vec::with_capacity((k * k) as usize);
    for by in (0..k).step_by(4) {
        for bx in (0..k).step_by(4) {
            for y in by..(by + 4).min(k) {
                for x in bx..(bx + 4).min(k) {
                    out.push((x, y));
                }
            }
        }
    }
    out
}

/// How many jittered direction sets a scene's vertices share
/// ([`DirectionSet`]): neighbours use different ones.
pub const DIRECTION_SETS: u32 = 2;

/// The shared direction sets (local frame, +z = normal), each in block
/// order: [`DIRECTION_SETS`] stratified sets with independent jitter, one
/// after the other in `dirs`. A vertex uses the set [`vertex_rotations_and_sets`] gives it.
///
/// Why several: rotations about the normal randomize azimuth only, so with
/// one set every vertex would integrate elevation with the same jittered
/// points, and that quadrature's error would be one shared bias for the
/// whole scene (cornell at 64 rays: total bias -3.1% to -0.3% over four
/// seeds with one set). Neighbours on different sets make those errors
/// independent, and smoothing averages them. Two, not more: more sets
/// lower the bias further but raise the worst vertex's error in the
/// furnace (docs/DESIGN.md §2 has the figures).
#[derive(Clone, Debug, PartialEq)]
pub struct DirectionSet {
    /// Directions per side of the stratified grid: each set holds `k * k`.
    pub k: u32,
    /// `DIRECTION_SETS` sets of `k * k` directions.
    pub dirs: Vec<Vec3>,
}

impl DirectionSet {
    /// [`DIRECTION_SETS`] sets of `k*k` jittered stratified cosine directions for `seed`.
    pub fn new(k: u32, seed: u64) -> Self {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
        let inv = 1.0 / k as f32;
        let mut dirs = Vec::with_capacity((DIRECTION_SETS * k * k) as usize);
        for _ in 0..DIRECTION_SETS {
            dirs.extend(block_order(k).into_iter().map(|(x, y)| {
                let j = Vec2::new(rng.random::<f32>(), rng.random::<f32>());
                // Keep strictly inside the cell so no direction is exactly tangent.
                let u = (Vec2::new(x as f32, y as f32) + j.clamp(Vec2::splat(1e-4), Vec2::splat(1.0 - 1e-4))) * inv;
                cosine_hemisphere(u).normalize()
            }));
        }
        Self { k, dirs }
    }

    /// Rays per vertex, `k * k`.
    pub fn len(&self) -> usize {
        (self.k * self.k) as usize
    }

    /// True if the sets hold no direction (`k` is 0).
    #[cfg(any(test, feature = "internals"))]
    pub fn is_empty(&self) -> bool {
        self.k == 0
    }

    /// Direction set `s`.
    pub fn set(&self, s: u32) -> &[Vec3] {
        let n = self.len();
        &self.dirs[s as usize * n..(s as usize + 1) * n]
    }
}

/// Van der Corput radical inverse in base 2.
fn radical_inverse(i: u32) -> f32 {
    (i.reverse_bits() as f64 / 4294967296.0) as f32
}

/// Every vertex's rotation about its normal (radians) and direction set
/// ([`DirectionSet`]) from its colour (`PreparedScene::colours`: a
/// colouring of the one-ring graph, [`colours`]): colour `c` turns into
/// `pi/2 * radical_inverse(c)` plus a seeded offset, and uses set
/// `c mod` [`DIRECTION_SETS`]. The concentric grid repeats under quarter
/// turns, so colours 0, 1, 2, 3 sit at 0, 1/2, 1/4, 3/4 of the quarter
/// turn: neighbours interleave, in rotation and in jitter.
pub fn vertex_rotations_and_sets(colours: &[u32], seed: u64) -> (Vec<f32>, Vec<u32>) {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(Stream::ROTATIONS.seed(seed));
    let offset: f32 = rng.random::<f32>() * FRAC_PI_2;
    let rotations = colours.iter().map(|&c| offset + FRAC_PI_2 * radical_inverse(c)).collect();
    (rotations, colours.iter().map(|&c| c % DIRECTION_SETS).collect())
}

/// Greedy colouring of the one-ring graph (vertex order, smallest free
/// colour): neighbours get different colours.
pub fn colours(rings: &Csr) -> Vec<u32> {
    colours_keeping(rings, &vec![None; rings.rows()])
}

/// [`colours`] with the colours of `kept` vertices given (`Some`): the
/// others take, in vertex order, the smallest colour none of their
/// coloured neighbours has. Refinement keeps the colours (so the ray
/// frames) of the vertices it keeps this way.
pub fn colours_keeping(rings: &Csr, kept: &[Option<u32>]) -> Vec<u32> {
    let n = rings.rows();
    let mut color: Vec<u32> = kept.iter().map(|c| c.unwrap_or(u32::MAX)).collect();
    let mut used: Vec<u32> = Vec::new();
    for v in 0..n {
        if color[v] != u32::MAX {
            continue;
        }
        used.clear();
        used.extend(rings.row(v).iter().map(|&u| color[u as usize]).filter(|&c| c != u32::MAX));
        used.sort_unstable();
        let mut c = 0;
        for &x in &used {
            if x == c {
                c += 1;
            } else if x > c {
                break;
            }
        }
        color[v] = c;
    }
    color
}

/// World-space frame `(t, b, n)` of a vertex with normal `n` rotated by `angle`.
pub fn vertex_frame(n: Vec3, angle: f32) -> (Vec3, Vec3, Vec3) {
    let (t, b) = basis(n);
    let (s, c) = angle.sin_cos();
    (t * c + b * s, b * c - t * s, n)
}

/// Local direction `d` of a [`DirectionSet`] in the world frame `(t, b, n)`
/// of [`vertex_frame`], normalized: the one formula every shooter (CPU, GPU
/// host side, sky visibility) uses, so all agree bit for bit.
#[inline]
pub fn world_direction(frame: (Vec3, Vec3, Vec3), d: Vec3) -> Vec3 {
    let (t, b, n) = frame;
    (t * d.x + b * d.y + n * d.z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn concentric_round_trip() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
        for _ in 0..10000 {
            let u = Vec2::new(rng.random(), rng.random());
            let back = concentric_disk_inverse(concentric_disk(u));
            assert!((back - u).abs().max_element() < 1e-4, "{u} -> {back}");
        }
    }

    #[test]
    fn cosine_round_trip_and_pdf() {
        let mut rng = rand_pcg::Pcg32::seed_from_u64(8);
        let mut mean_cos = 0.0f64;
        let n = 200_000;
        for _ in 0..n {
            let u = Vec2::new(rng.random(), rng.random());
            let w = cosine_hemisphere(u);
            assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0);
            assert!((cosine_hemisphere_inverse(w) - u).abs().max_element() < 1e-3);
            mean_cos += w.z as f64;
        }
        // E[cos] under cos/pi density is 2/3.
        assert!((mean_cos / n as f64 - 2.0 / 3.0).abs() < 3e-3);
        // The pdf integrates to 1 over the hemisphere (midpoint rule in (cos theta, phi)).
        let m = 400;
        let mut integral = 0.0f64;
        for i in 0..m {
            let z = (i as f32 + 0.5) / m as f32;
            integral +=
                cosine_hemisphere_pdf(Vec3::new((1.0 - z * z).sqrt(), 0.0, z)) as f64 * 2.0 * PI as f64 / m as f64;
        }
        assert!((integral - 1.0).abs() < 1e-4, "{integral}");
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::Z, Vec3::new(1.0, 2.0, -3.0).normalize()] {
            let (t, b) = basis(n);
            assert!(t.dot(b).abs() < 1e-6 && t.dot(n).abs() < 1e-6 && (t.cross(b) - n).length() < 1e-5);
            let (t2, b2, n2) = vertex_frame(n, 0.7);
            assert!(t2.dot(b2).abs() < 1e-6 && t2.dot(n2).abs() < 1e-6 && (t2.cross(b2) - n2).length() < 1e-5);
        }
    }

    #[test]
    fn block_order_covers_grid_once() {
        for k in [1, 3, 4, 6, 16] {
            let mut cells = block_order(k);
            assert_eq!(cells.len(), (k * k) as usize);
            cells.sort_unstable();
            cells.dedup();
            assert_eq!(cells.len(), (k * k) as usize);
        }
        // The first 16 rays of a 16*16 set are one 4*4 block.
        assert!(block_order(16)[..16].iter().all(|&(x, y)| x < 4 && y < 4));
    }

    #[test]
    fn direction_set_is_stratified_and_deterministic() {
        let a = DirectionSet::new(16, 3);
        assert_eq!(a, DirectionSet::new(16, 3));
        assert_ne!(a, DirectionSet::new(16, 4));
        // Each direction maps back into its own grid cell, in every set.
        assert_eq!(a.dirs.len(), a.len() * DIRECTION_SETS as usize);
        assert_ne!(a.set(0), a.set(1));
        for (w, (x, y)) in a.dirs.iter().zip(block_order(16).into_iter().cycle()) {
            let u = cosine_hemisphere_inverse(*w) * 16.0;
            assert!(u.x.floor() as u32 == x || (u.x - x as f32).abs() < 1e-2, "{u} vs {x},{y}");
            assert!(u.y.floor() as u32 == y || (u.y - y as f32).abs() < 1e-2, "{u} vs {x},{y}");
        }
        // Mean of cos over a stratified set is close to 2/3.
        let mean: f32 = a.set(DIRECTION_SETS - 1).iter().map(|d| d.z).sum::<f32>() / a.len() as f32;
        assert!((mean - 2.0 / 3.0).abs() < 5e-3, "{mean}");
    }

    #[test]
    fn neighbours_get_different_rotations() {
        // A 4-cycle plus a chord.
        let pairs: Vec<(u32, u32)> =
            [(0, 1), (1, 2), (2, 3), (3, 0), (0, 2)].iter().flat_map(|&(a, b)| [(a, b), (b, a)]).collect();
        let rings = Csr::from_pairs(4, &pairs);
        let rot = vertex_rotations_and_sets(&colours(&rings), 1).0;
        for &(a, b) in &pairs {
            assert_ne!(rot[a as usize], rot[b as usize]);
        }
        assert_eq!(rot, vertex_rotations_and_sets(&colours(&rings), 1).0);
        // Kept colours stay; the others avoid them.
        let c = colours_keeping(&rings, &[None, Some(0), None, Some(2)]);
        assert_eq!((c[1], c[3]), (0, 2));
        for &(a, b) in &pairs {
            assert_ne!(c[a as usize], c[b as usize], "{c:?}");
        }
    }
}
