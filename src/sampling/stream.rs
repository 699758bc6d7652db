//! Named sample streams: every random number linkgi draws outside the link
//! directions comes from a hash of the scene's seed, a stream's salt and
//! the indices of what is sampled (vertex, triangle, rank, sample), never
//! from a generator advanced in evaluation order, so samples do not
//! depend on threads, batches or which tracer answered. Each use has its
//! own [`Stream`] (a documented salt), so no two uses share numbers.
//!
//! The hash is SplitMix64's finalizer ([`splitmix64`]); [`unit()`] turns a
//! hash into a uniform number in `[0, 1)` from its top 24 bits (exact in
//! f32); [`cosine_direction`] turns one into a cosine-distributed
//! direction about a normal. Near hits' samples hash from the vertex, the
//! hit's triangle and its rank among the vertex's hits on that triangle
//! ([`Stream::hit_key`]): a near hit more or less elsewhere (where the CPU
//! and GPU tracers differ at `t = 0`) leaves the others' samples as they
//! were.

use super::warp::{basis, cosine_hemisphere};
use glam::{Vec2, Vec3};

/// The SplitMix64 finalizer (Steele et al. 2014): a well-mixed 64-bit hash
/// of `z`, for per-item jitter that must not depend on evaluation order.
#[inline]
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform number in `[0, 1)` from the top 24 bits of hash `x`.
#[inline]
pub fn unit(x: u64) -> f32 {
    (x >> 40) as f32 / (1u64 << 24) as f32
}

/// Two uniform numbers from hash `x`: `unit(x)` and `unit` of its rehash.
#[inline]
pub fn unit2(x: u64) -> Vec2 {
    Vec2::new(unit(x), unit(splitmix64(x)))
}

/// A cosine-distributed unit direction about the unit `normal` from hash
/// `x` (pdf `cos / pi`), or `None` on the horizon.
#[inline]
pub fn cosine_direction(x: u64, normal: Vec3) -> Option<Vec3> {
    let (t, b) = basis(normal);
    let local = cosine_hemisphere(unit2(x));
    let dir = (t * local.x + b * local.y + normal * local.z).normalize_or_zero();
    (dir != Vec3::ZERO && local.z > 0.0).then_some(dir)
}

/// `h` folded with each of `indices` in turn: `h = splitmix64(h ^ index)`.
/// A sample's hash from its stream's key (or from a key already folded,
/// such as a near hit's) and its indices.
#[inline]
pub fn fold(h: u64, indices: &[u64]) -> u64 {
    indices.iter().fold(h, |h, &i| splitmix64(h ^ i))
}

/// One use of random numbers: its salt, XORed into the seed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stream(u64);

impl Stream {
    /// The global rotation offset of the vertices' direction sets
    /// ([`super::vertex_rotations_and_sets`], a PCG seeded with `seed ^ salt`).
    pub const ROTATIONS: Stream = Stream(0x9e37_79b9_7f4a_7c15);
    /// The vertices drawn for the noise check and their second ray set
    /// ([`crate::exchange::denoise::noise_check`]).
    pub const NOISE_CHECK: Stream = Stream(0xd1b5_4a32_d192_ed03);
    /// Jitter of the sub-cells of the sky's refined cells ([`crate::sky::refine`]).
    pub const SKY_CELLS: Stream = Stream(0x629a_292a_367c_d507);
    /// The emitter links' per-vertex sample offsets
    /// ([`crate::exchange::sources::emitter_links`], a PCG seeded with
    /// [`Stream::point_seed`]). It shared salt 0 with [`Stream::SKY_CELLS`]
    /// until it got its own.
    pub const EMITTER_LINKS: Stream = Stream(0x6a09_e667_f3bc_c909);
    /// Jitter of the vertices' portal samples ([`crate::sky::portal`]).
    pub const PORTALS: Stream = Stream(0x5be0_cd19_137e_2179);
    /// Points on emitters from near hits ([`crate::exchange::near::emitters`]).
    pub const NEAR_EMITTERS: Stream = Stream(0x2545_f491_4f6c_dd1d);
    /// Sky directions and portal points from near hits ([`crate::exchange::near::sky`]).
    pub const NEAR_SKY: Stream = Stream(0x3c6e_f372_fe94_f82b);
    /// Final-gather directions from near hits ([`crate::exchange::near::gather`]).
    pub const NEAR_GATHER: Stream = Stream(0x9b05_688c_2b3e_6c1f);
    /// The vertices whose near hits decide which near-field terms a solve
    /// keeps (`solver/decide.rs`).
    pub const TERM_SAMPLE: Stream = Stream(0x510e_527f_ade6_82d1);
    /// Which near hits a vertex with more than its share keeps
    /// ([`crate::links::near::NearRule`]).
    pub const NEAR_KEEP: Stream = Stream(0x1f83_d9ab_fb41_bd6b);
    /// The reference path tracer's per-vertex paths ([`crate::reference`]).
    #[cfg(any(test, feature = "cli", feature = "internals"))]
    pub const REFERENCE: Stream = Stream(0x5be0_cd19_1f83_d9ab);
    /// The reference path tracer's per-pixel paths ([`crate::reference`]).
    #[cfg(any(test, feature = "cli", feature = "internals"))]
    pub const REFERENCE_PIXELS: Stream = Stream(0xcbbb_9d5d_c105_9ed8);

    /// `seed` with the stream's salt: the seed of this stream.
    #[inline]
    pub const fn seed(self, seed: u64) -> u64 {
        seed ^ self.0
    }

    /// The seed of the generator of a vertex at position `p` with normal
    /// `n` in this stream: keyed by the vertex's geometry, not its index,
    /// so a vertex that a refinement round keeps (same position and
    /// normal, another index) draws the same samples as before
    /// ([`crate::exchange::EmitterLinks::after_split`]). Two vertices with
    /// the same position and normal share their samples.
    #[inline]
    pub fn point_seed(self, seed: u64, p: glam::Vec3, n: glam::Vec3) -> u64 {
        let [a, b, c] = p.to_array().map(f32::to_bits);
        let [d, e, f] = n.to_array().map(f32::to_bits);
        let h = splitmix64(self.key(seed) ^ (u64::from(a) | u64::from(b) << 32));
        let h = splitmix64(h ^ (u64::from(c) | u64::from(d) << 32));
        splitmix64(h ^ (u64::from(e) | u64::from(f) << 32))
    }

    /// The stream's key for `seed`, hashed on its own first (seeds that
    /// differ in low bits must not share samples).
    #[inline]
    pub fn key(self, seed: u64) -> u64 {
        splitmix64(self.seed(seed))
    }

    /// The hash of one sample of this stream: its [`Stream::key`] folded
    /// with the sample's indices in order ([`fold`]). The one layout of
    /// every stream's samples: indices are never packed into bit fields,
    /// so no index can spill into another's bits however large.
    #[inline]
    pub fn hash(self, seed: u64, indices: &[u64]) -> u64 {
        fold(self.key(seed), indices)
    }

    /// The key of near hit `rank` (among vertex `v`'s hits on triangle
    /// `tri`) of vertex `v`: [`Stream::hash`] of `(v, tri | rank << 32)`
    /// (`tri` is 32 bits); its samples fold their own indices into it.
    #[inline]
    pub fn hit_key(self, seed: u64, v: usize, tri: u32, rank: usize) -> u64 {
        self.hash(seed, &[v as u64, u64::from(tri) | (rank as u64) << 32])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_is_in_the_unit_interval_and_exact() {
        assert_eq!(unit(0), 0.0);
        assert!(unit(u64::MAX) < 1.0);
        assert_eq!(unit(1 << 40), 1.0 / (1u64 << 24) as f32);
    }

    #[test]
    fn cosine_directions_are_unit_above_the_surface_with_cosine_mean() {
        let n = Vec3::new(0.3, 0.9, -0.2).normalize();
        let mut mean_cos = 0.0f64;
        let m = 20000;
        for i in 0..m {
            let d = cosine_direction(splitmix64(i), n).expect("off the horizon");
            assert!((d.length() - 1.0).abs() < 1e-5 && d.dot(n) > 0.0);
            mean_cos += d.dot(n) as f64;
        }
        // E[cos] under pdf cos/pi is 2/3.
        assert!((mean_cos / m as f64 - 2.0 / 3.0).abs() < 0.01, "{}", mean_cos / m as f64);
    }

    /// The packed layout this replaced (`v << 20 ^ p << 8 ^ j`) gave sample
    /// 256 of portal 0 the hash of sample 0 of portal 1; folded indices
    /// keep every index apart, and the near hits' key is the same fold.
    #[test]
    fn indices_never_share_bits() {
        let s = Stream::PORTALS;
        assert_ne!(s.hash(1, &[0, 0, 256]), s.hash(1, &[0, 1, 0]));
        assert_ne!(s.hash(1, &[1 << 12, 0]), s.hash(1, &[0, 1 << 32]));
        assert_ne!(s.hash(1, &[0]), s.hash(1, &[0, 0]));
        assert_eq!(s.hit_key(7, 3, 5, 2), fold(s.key(7), &[3, 5 | 2 << 32]));
        assert_eq!(fold(fold(9, &[1]), &[2]), fold(9, &[1, 2]));
    }

    #[test]
    fn streams_differ() {
        let all = [
            Stream::ROTATIONS,
            Stream::SKY_CELLS,
            Stream::EMITTER_LINKS,
            Stream::NOISE_CHECK,
            Stream::PORTALS,
            Stream::NEAR_EMITTERS,
            Stream::NEAR_SKY,
            Stream::NEAR_GATHER,
            Stream::TERM_SAMPLE,
            Stream::NEAR_KEEP,
            Stream::REFERENCE,
            Stream::REFERENCE_PIXELS,
        ];
        for (i, a) in all.iter().enumerate() {
            for b in &all[i + 1..] {
                assert_ne!(a.key(1), b.key(1));
            }
        }
        assert_ne!(Stream::NEAR_SKY.hit_key(1, 0, 5, 0), Stream::NEAR_SKY.hit_key(1, 0, 5, 1));
    }
}
