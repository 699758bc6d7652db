//! Hits to merged link groups: three barycentric links per front hit,
//! merged per target, quantized to f16 with error diffusion. Shared by the
//! CPU and GPU shooting paths.
//!
//! Sums are fixed point: each barycentric weight is rounded to a multiple
//! of `1 / fixed_scale(rays)` ([`fixed_scale`]: at least 2^-23 of a ray's
//! weight at 256 rays, far below the f16 step of 2^-11) and added as an
//! integer, so a group's sums do not depend on the order of its rays. That
//! is what lets a selective update patch a group (subtract the old hits of
//! the rays that changed, add the new ones, [`requantize`]) and get exactly
//! the group a full merge gives. A target with a non-zero sum always keeps
//! a link: where its weight rounds to zero in f16 it gets the smallest
//! positive f16 (2^-24) and the difference goes to the carry.
//!
//! Merging: the raw links of a vertex (three per front hit) are summed
//! per target in an open-addressing hash table ([`MergeScratch`], ray
//! order), then only the distinct targets are sorted. Sorting every raw
//! link instead took about 40% of the link stage (conference: 9.9 M rays/s
//! traced, 6.1 M/s with merging).

use bytemuck::{Pod, Zeroable};
use half::f16;

/// `HitRecord::tri` of a ray that left the scene.
pub const HIT_MISS: u32 = u32::MAX;
/// Flag in `HitRecord::tri` of a ray blocked by a back face.
pub const HIT_BACK: u32 = 0x8000_0000;

/// One ray's result, as written by the shooting shader (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HitRecord {
    /// Triangle id, `| HIT_BACK` for a back face, or [`HIT_MISS`].
    pub tri: u32,
    /// First barycentric coordinate: the weight of the triangle's second corner (the first gets `1 - u - v`).
    pub u: f32,
    /// Second barycentric coordinate: the weight of the triangle's third corner.
    pub v: f32,
    /// Distance, metres.
    pub t: f32,
}

impl HitRecord {
    /// The record of a traced ray's hit ([`HIT_MISS`] with `t = inf` for none).
    #[inline]
    pub fn of(hit: Option<crate::trace::ray::Hit>) -> HitRecord {
        match hit {
            None => HitRecord { tri: HIT_MISS, u: 0.0, v: 0.0, t: f32::INFINITY },
            Some(h) => HitRecord { tri: if h.front { h.tri } else { h.tri | HIT_BACK }, u: h.u, v: h.v, t: h.t },
        }
    }

    /// The hit this record names (`None` for a miss or a record that is
    /// not a traced hit): the inverse of [`HitRecord::of`].
    #[inline]
    pub fn hit(self) -> Option<crate::trace::ray::Hit> {
        (self.tri != HIT_MISS).then(|| crate::trace::ray::Hit {
            tri: self.tri & !HIT_BACK,
            u: self.u,
            v: self.v,
            t: self.t,
            front: self.tri & HIT_BACK == 0,
        })
    }
}

/// Counts of one vertex's rays.
#[derive(Clone, Copy, Debug, Default)]
pub struct HitCounts {
    /// Rays that met a front face.
    pub front: u32,
    /// Rays blocked by a back face.
    pub back: u32,
    /// Rays that left the scene.
    pub miss: u32,
}

/// Reusable buffers of [`merge_vertex`]: a hash table from target vertex
/// to summed weight (slots empty between calls) and the
/// list of slots in use.
#[derive(Clone, Debug, Default)]
pub struct MergeScratch {
    keys: Vec<u32>,
    sums: Vec<u64>,
    used: Vec<u32>,
    groups: Vec<u64>,
    group_sums: Vec<u32>,
    /// Corner vertices of each front hit's triangle, in ray order.
    corners: Vec<[u32; 3]>,
}

impl MergeScratch {
    const EMPTY: u32 = u32::MAX;

    /// Adds `w` to `target`'s sum; returns `target`'s slot.
    #[inline(always)]
    fn add(&mut self, target: u32, w: u64) -> usize {
        let mask = self.keys.len() - 1;
        let mut h = (target.wrapping_mul(0x9E37_79B1) >> 7) as usize & mask;
        loop {
            let k = self.keys[h];
            if k == target {
                self.sums[h] += w;
                return h;
            }
            if k == Self::EMPTY {
                self.keys[h] = target;
                self.sums[h] = w;
                self.used.push(h as u32);
                return h;
            }
            h = (h + 1) & mask;
        }
    }
}

/// The fixed-point scale of merged sums for `rays` rays per vertex: a
/// power of two such that `rays` whole weights still fit in a `u32`.
pub fn fixed_scale(rays: usize) -> f64 {
    let bits = usize::BITS - rays.max(1).saturating_sub(1).leading_zeros();
    (1u64 << (31 - bits.min(31))) as f64
}

/// A barycentric weight in fixed point (`x` clamped to [0, 1]), rounded
/// half away from zero.
#[inline(always)]
pub fn to_fixed(x: f64, scale: f64) -> u64 {
    let y = x.clamp(0.0, 1.0) * scale;
    // `y.round() as u64` without its libm call (the x86-64 baseline has
    // no rounding instruction; it was 4% of the link merge's time):
    // `y - trunc(y)` is exact, so this is the same number (NaN gives 0 in both).
    let r = y as u64;
    r + (y - r as f64 >= 0.5) as u64
}

/// The three fixed-point corner weights of a front hit at barycentrics `(u, v)`.
#[inline(always)]
pub fn corner_weights(u: f32, v: f32, scale: f64) -> [u64; 3] {
    let (u, v) = (u as f64, v as f64);
    [to_fixed(1.0 - u - v, scale), to_fixed(u, scale), to_fixed(v, scale)]
}

/// Appends the f16 weights of a group given as fixed-point sums (targets
/// sorted, sums non-zero) to `weights`: `sum / scale * weight_per_ray`,
/// rounded to f16 in target order with the rounding error carried to the
/// next link; a weight that rounds to zero becomes the smallest positive f16.
pub fn requantize(sums: impl Iterator<Item = u32>, weight_per_ray: f64, scale: f64, weights: &mut Vec<f16>) {
    let unit = weight_per_ray / scale;
    let mut carry = 0.0f64;
    for sum in sums {
        let exact = sum as f64 * unit + carry;
        let mut q = f16_from_f64(exact);
        // `exact` is finite (finite sums and weights), so q is never NaN.
        if f16_to_f64(q) <= 0.0 {
            q = f16::from_bits(1);
        }
        carry = exact - f16_to_f64(q);
        weights.push(q);
    }
}

/// The f16 of `x` as the golden results were made: rounded to f32 and
/// then to f16 (ties to even both times), which is what `half`'s
/// `f16::from_f64` does on x86 CPUs with F16C; this gives it on every CPU,
/// inlined (`half`'s conversions are calls with a run-time feature check:
/// with the reverse one, 5.6% of the link stage's samples on tearoom).
/// Infinite, NaN and overflowing inputs take `half`'s path.
#[inline(always)]
fn f16_from_f64(x: f64) -> f16 {
    let x = x as f32;
    let a = x.abs();
    // From 65520 up rounds to infinity; NaN fails the comparison.
    if !(a < 65520.0) {
        return f16::from_f32(x);
    }
    let sign = (x.to_bits() >> 16) as u16 & 0x8000;
    // Both roundings, then a select (no branch: links' weights fall on
    // either side of the least normal unpredictably).
    // Subnormal steps of 2^-24: `a * 2^24` is exact (below 2^10 where it
    // is taken), and adding and taking away 2^23 rounds it to an integer,
    // ties to even; 1024 (rounded up to the least normal) is that normal's
    // bit pattern.
    let subnormal = ((a * 16_777_216.0 + 8_388_608.0) - 8_388_608.0) as i32 as u32;
    // Normal: keep 10 of the 23 mantissa bits, ties to even; a carry out
    // of the mantissa moves into the exponent, as it should.
    let bits = a.to_bits();
    let normal = ((bits + ((1u32 << 12) - 1) + (bits >> 13 & 1)) >> 13).wrapping_sub((127 - 15) << 10);
    f16::from_bits(sign | (if a < MIN_NORMAL_F16 { subnormal } else { normal }) as u16)
}

/// `q.to_f64()`, exact and inlined (infinities and NaN take `half`'s path).
#[inline(always)]
fn f16_to_f64(q: f16) -> f64 {
    let h = q.to_bits();
    let (exp, man) = (h >> 10 & 0x1f, (h & 0x3ff) as u64);
    if exp == 31 {
        return q.to_f64();
    }
    // Both readings, then a select (as in `f16_from_f64`).
    let subnormal = man as f64 / 16_777_216.0;
    let normal = f64::from_bits((exp as u64 + 1023 - 15) << 52 | man << 42);
    let magnitude = if exp == 0 { subnormal } else { normal };
    f64::from_bits(magnitude.to_bits() | ((h & 0x8000) as u64) << 48)
}

/// The least normal f16, 2^-14.
const MIN_NORMAL_F16: f32 = 1.0 / 16_384.0;

/// Turns one vertex's hits (one per ray) into its merged link group,
/// appended to `targets`/`weights`; with `sums`, also appends each link's
/// fixed-point sum ([`fixed_scale`] of `hits.len()`). `scratch` is reused
/// between calls.
pub fn merge_vertex(
    hits: &[HitRecord],
    triangles: &[[u32; 3]],
    weight_per_ray: f64,
    scratch: &mut MergeScratch,
    targets: &mut Vec<u32>,
    weights: &mut Vec<f16>,
) -> HitCounts {
    merge_vertex_sums(hits, triangles, weight_per_ray, scratch, targets, weights, None)
}

/// [`merge_vertex`], also appending the fixed-point sums to `sums` when given.
pub fn merge_vertex_sums(
    hits: &[HitRecord],
    triangles: &[[u32; 3]],
    weight_per_ray: f64,
    scratch: &mut MergeScratch,
    targets: &mut Vec<u32>,
    weights: &mut Vec<f16>,
    sums: Option<&mut Vec<u32>>,
) -> HitCounts {
    let mut counts = HitCounts::default();
    let scale = fixed_scale(hits.len());
    // At most half full: a power of two at least twice the raw links.
    let size = (6 * hits.len()).next_power_of_two().max(64);
    if scratch.keys.len() < size {
        scratch.keys = vec![MergeScratch::EMPTY; size];
        scratch.sums = vec![0; size];
    }
    scratch.used.clear();
    // The hit triangles' corners first, in a loop of independent loads:
    // on conference the triangle array is 2.8 MB, and these loads, made
    // inside the hashing loop below, stalled it (38% of its samples).
    scratch.corners.clear();
    scratch.corners.extend(hits.iter().filter(|h| h.tri & HIT_BACK == 0).map(|h| triangles[h.tri as usize]));
    let mut front = 0;
    // Neighbouring rays (the direction set's 4x4 blocks) often meet one
    // triangle: its corners' slots are kept from the last front hit.
    let mut last = (HIT_MISS, [0usize; 3]);
    for h in hits {
        if h.tri == HIT_MISS {
            counts.miss += 1;
            continue;
        }
        if h.tri & HIT_BACK != 0 {
            counts.back += 1;
            continue;
        }
        counts.front += 1;
        let [ia, ib, ic] = scratch.corners[front];
        front += 1;
        let [wa, wb, wc] = corner_weights(h.u, h.v, scale);
        if h.tri == last.0 {
            let [sa, sb, sc] = last.1;
            scratch.sums[sa] += wa;
            scratch.sums[sb] += wb;
            scratch.sums[sc] += wc;
            continue;
        }
        last = (h.tri, [scratch.add(ia, wa), scratch.add(ib, wb), scratch.add(ic, wc)]);
    }
    let MergeScratch { keys, sums: table, used, groups, group_sums, .. } = scratch;
    // Sorted by target as plain u64 keys (target above, slot below): a
    // primitive sort, about twice as fast as sorting (target, sum) pairs.
    groups.clear();
    groups.extend(used.iter().map(|&slot| (keys[slot as usize] as u64) << 32 | slot as u64));
    groups.sort_unstable();
    let first = targets.len();
    group_sums.clear();
    for &key in groups.iter() {
        let (target, slot) = ((key >> 32) as u32, (key & 0xffff_ffff) as usize);
        keys[slot] = MergeScratch::EMPTY;
        // Zero sums (hits exactly on an edge or corner) give no link.
        if table[slot] > 0 {
            targets.push(target);
            group_sums.push(table[slot] as u32);
        }
    }
    debug_assert_eq!(targets.len() - first, group_sums.len());
    requantize(group_sums.iter().copied(), weight_per_ray, scale, weights);
    if let Some(sums) = sums {
        sums.extend_from_slice(group_sums);
    }
    counts
}

/// The state of selective updates: the hit id of every ray,
/// `ids[v * rays_per_vertex + k]` for ray `k` of vertex `v` (triangle id,
/// `| HIT_BACK`, or `HIT_MISS`), and the fixed-point sum of every link, in
/// the order of the links' targets.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RayHits {
    /// Rays shot per vertex (the stride of `ids`).
    pub rays_per_vertex: usize,
    /// The hit id of every ray, vertex after vertex.
    pub ids: Vec<u32>,
    /// The fixed-point sum of every link, in link order.
    pub sums: Vec<u32>,
}

impl RayHits {
    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        (std::mem::size_of_val(self.ids.as_slice()) + std::mem::size_of_val(self.sums.as_slice())) as u64
    }

    /// The ids of vertex `v`'s rays.
    pub fn row(&self, v: usize) -> &[u32] {
        &self.ids[v * self.rays_per_vertex..(v + 1) * self.rays_per_vertex]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `to_fixed` is `(x.clamp(0, 1) * scale).round()` on every input,
    /// halves, their neighbours, the clamp's ends and NaN included.
    #[test]
    fn to_fixed_rounds_as_round_does() {
        let reference = |x: f64, scale: f64| (x.clamp(0.0, 1.0) * scale).round() as u64;
        let mut xs = vec![0.0, 1.0, -0.5, 1.5, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e-300, 0.49999999999999994];
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..200_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            xs.push((state >> 11) as f64 / (1u64 << 53) as f64);
        }
        for scale in [fixed_scale(16), fixed_scale(256), fixed_scale(1024), 1.0, 2.0] {
            for k in 0..4096u64 {
                // Exact halves of the scale and the doubles beside them.
                let half = (k as f64 + 0.5) / scale;
                xs.extend([half, f64::from_bits(half.to_bits() - 1), f64::from_bits(half.to_bits() + 1)]);
            }
            for &x in &xs {
                assert_eq!(to_fixed(x, scale), reference(x, scale), "x = {x:e}, scale {scale}");
            }
        }
    }

    /// The inlined f16 conversions are `half`'s bit for bit (from f64
    /// through f32, as `half` does with F16C): every f16
    /// value, the midpoints between neighbours and the doubles beside them,
    /// both signs, the overflow edge, infinities, NaN and random doubles.
    #[test]
    fn f16_conversions_equal_half() {
        for h in 0..=u16::MAX {
            let q = f16::from_bits(h);
            let want = q.to_f64();
            let got = f16_to_f64(q);
            assert!(got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()), "{h:#06x}");
        }
        let mut xs = vec![0.0, -0.0, 65504.0, 65519.999, 65520.0, 65536.0, 1e300, f64::INFINITY, f64::NAN, 5e-324];
        for h in 0..0x7c00u16 {
            let (a, b) = (f16::from_bits(h).to_f64(), f16::from_bits(h + 1).to_f64());
            let mid = (a + b) / 2.0;
            let m32 = (mid as f32).to_bits();
            let (below, above) = (f32::from_bits(m32 - 1) as f64, f32::from_bits(m32 + 1) as f64);
            for x in [a, b, mid, f64::from_bits(mid.to_bits() - 1), f64::from_bits(mid.to_bits() + 1), below, above] {
                xs.extend([x, -x]);
            }
        }
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..200_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            // Exponents from 2^-40 to 2^24, either sign.
            let x = f64::from_bits((state & 0x800f_ffff_ffff_ffff) | (983 + (state >> 52 & 63)) << 52);
            xs.push(x);
        }
        for &x in &xs {
            // `half` without F16C rounds once, from the f64; the goldens
            // (and this function) round through f32.
            let (want, got) = (f16::from_f32(x as f32), f16_from_f64(x));
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "x = {x:e}: {:#x} {:#x}",
                got.to_bits(),
                want.to_bits()
            );
        }
    }

    /// Rays meeting one triangle in a row (the kept slots) merge to the
    /// same group as the same hits in any other order.
    #[test]
    fn merged_sums_do_not_depend_on_the_order_of_hits() {
        let triangles = [[0, 1, 2], [2, 1, 3], [3, 4, 2]];
        let hit = |tri: u32, u: f32, v: f32| HitRecord { tri, u, v, t: 1.0 };
        let mut hits = vec![
            hit(0, 0.2, 0.3),
            hit(0, 0.1, 0.1),
            hit(1, 0.5, 0.25),
            hit(1, 0.0, 0.0),
            hit(HIT_MISS, 0.0, 0.0),
            hit(1, 0.3, 0.3),
            hit(2, 0.7, 0.1),
            hit(HIT_BACK, 0.1, 0.1),
            hit(0, 0.6, 0.2),
        ];
        let merge = |hits: &[HitRecord]| {
            let (mut t, mut w, mut s) = (Vec::new(), Vec::new(), Vec::new());
            let c =
                merge_vertex_sums(hits, &triangles, 0.25, &mut MergeScratch::default(), &mut t, &mut w, Some(&mut s));
            (t, w, s, (c.front, c.back, c.miss))
        };
        let first = merge(&hits);
        assert_eq!(first.0, vec![0, 1, 2, 3, 4]);
        assert_eq!(first.3, (7, 1, 1));
        hits.reverse();
        assert_eq!(merge(&hits), first);
        hits.sort_by_key(|h| (h.u.to_bits(), h.tri));
        assert_eq!(merge(&hits), first);
    }
}
